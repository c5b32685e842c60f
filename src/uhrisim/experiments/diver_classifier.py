"""Fit the diver/clutter classifier (``uhrisim.perception.classify``) on simulator data.

The scenario is flown with its observer's contacts from simulation *truth* (so the trail
does not depend on the classifier being fitted), its sonar's label images on, and the
perception chain run beside it on every ping. Each track update is one sample: its
features (:func:`~uhrisim.perception.classify.track_features`) and its class — *diver*
when most labelled cells of the blob it took are the target's label, *clutter*
otherwise (pilings, the other swimmer, the sea floor, speckle). The per-class mean and
standard deviation of each feature are the classifier's parameters.

    python -m uhrisim.experiments.diver_classifier OUT.json [--seeds 11 12] [--duration 180]

wrote the shipped ``perception/data/diver_classifier.json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from uhrisim.perception.classify import FEATURES, DiverClassifier, track_features
from uhrisim.perception.pipeline import SonarPerception
from uhrisim.scenario.load import ScenarioFile, validate_data
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.hooks import sensor_key
from uhrisim.sim.simulation import Simulation
from uhrisim.sim.sonar_contacts import perception_params

STD_FLOOR = 0.02


def truth_driven(path: Path) -> tuple[ScenarioFile, str, str]:
    """The scenario at ``path`` with its sonar observer on truth contacts and labels on;
    (scenario, observer, target)."""
    data = yaml.safe_load(path.read_text())
    observer = next(a for a in data["agents"] if a.get("contacts", {}).get("source") == "sonar")
    observer["contacts"]["source"] = "truth"
    observer["helm"].pop("macros", None)  # the plain trail, without the sonar's reacquire
    for sensor in observer["sensors"]:
        sensor["labels"] = True
    scenario = validate_data(data, str(path))
    return ScenarioFile(scenario, path), observer["name"], data["metrics"]["target"]


def collect(path: Path, seed: int, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """(features (n, len(FEATURES)), is_diver (n,)) of one run."""
    source, observer, target = truth_driven(path)
    sim = Simulation(source, seed=seed)
    cfg = next(a for a in source.scenario.agents if a.name == observer).contacts.sonar
    perception = SonarPerception(perception_params(cfg, source, "collect"))
    target_label = sim.scene.labels.index(
        sim.scene.bodies[sim.scene.body_names.index(target)].label)
    rows, classes = [], []
    key = sensor_key(observer, sim.agents[observer].sonars[0].name)
    while sim.t < duration:
        frame = sim.step()
        ping = frame.pings.get(key)
        if ping is None:
            continue
        seen = perception.process(ping)
        tracks = {tr.id: tr for tr in perception.tracker.tracks}
        for report in seen.tracks:
            if report.blob < 0:
                continue
            cells = ping.label_polar[seen.blobs.blob_cells(report.blob)]
            cells = cells[cells >= 0]
            is_diver = cells.size > 0 and np.bincount(cells).argmax() == target_label
            rows.append(track_features(tracks[report.id]))
            classes.append(is_diver)
    return np.array(rows).reshape(-1, len(FEATURES)), np.array(classes, bool)


def fit(path: Path, seeds: list[int], duration: float) -> dict[str, Any]:
    parts = [collect(path, s, duration) for s in seeds]
    X = np.concatenate([p[0] for p in parts])
    y = np.concatenate([p[1] for p in parts])
    if y.all() or not y.any():
        raise RuntimeError("the runs gave samples of one class only")
    d, c = X[y], X[~y]
    classifier = DiverClassifier(
        tuple(d.mean(axis=0)), tuple(np.maximum(d.std(axis=0), STD_FLOOR)),
        tuple(c.mean(axis=0)), tuple(np.maximum(c.std(axis=0), STD_FLOOR)),
        provenance=(f"fitted by uhrisim.experiments.diver_classifier on {path.name}, seeds "
                    f"{seeds}, {duration:g} s each, trail on truth contacts; {int(y.sum())} "
                    f"diver and {int((~y).sum())} clutter track updates labelled by the "
                    "sonar's label images"))
    return classifier.to_dict()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--scenario", type=Path, default=None,
                        help="scenario (default: the shipped track_and_trail_sonar_clutter)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[11, 12])
    parser.add_argument("--duration", type=float, default=180.0)
    args = parser.parse_args(argv)
    scenario = args.scenario or shipped_scenario("track_and_trail_sonar_clutter.yaml")
    params = fit(scenario, args.seeds, args.duration)
    args.out.write_text(json.dumps(params, indent=2) + "\n")
    print(params["provenance"])


if __name__ == "__main__":
    main()
