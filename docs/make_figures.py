"""Regenerate the README's and the docs' figures, and the README's demo numbers, from real
runs: ``make docs-figures`` (about half an hour on 2 cores; a viewer screenshot too where
a headless Chromium is installed, ``make browser``).

What it runs (outputs in ``out/docs/``) and what it replaces:

* ``uhrisim demo`` (600 simulated s, seed 1) -> ``docs/img/trajectory.png``,
  ``range_bearing.png``, ``sonar_strip.png`` and the paragraph of README.md between the
  ``demo-metrics`` markers (:func:`demo_paragraph`, from its ``metrics.json``);
* ``uhrisim figure sonar-tank`` -> ``docs/img/sonar_tank_fan.png`` (the maker's view);
  ``uhrisim figure sonar-presets`` -> ``docs/img/presets/``;
* ``uhrisim figure camera`` -> ``docs/img/camera_grid.jpg``;
* ``uhrisim sweep`` of the example file (18 runs) -> ``docs/img/sweep_summary.png``;
* ``uhrisim dataset ... --frames 16`` -> ``docs/img/dataset_preview.png``;
* the viewer (``tests/support/browser.py``) during the mission -> ``docs/img/viewer.png``;
  replaying the demo's recording (played, then a seek: the plots' gap; the sonar zoomed)
  -> ``docs/img/viewer_replay.png``; during the salvage mission (tools, sites, the posed
  diver, the task panel) -> ``docs/img/viewer_team.png``.

``--reuse`` keeps what an earlier run left in ``out/docs/`` (a step whose outputs exist is
not run again). Benchmarks are not rerun here: their figures in the README are measured
on a stated machine with ``make bench`` (docs/performance.md).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
README = ROOT / "README.md"
START, END = "<!-- demo-metrics: written by make docs-figures -->", "<!-- /demo-metrics -->"


def demo_paragraph(metrics: dict) -> str:
    """The README's account of the demo run, in words, from its ``metrics.json``."""
    acquired = metrics["time_to_acquire_s"]
    r, b, d = (metrics[k] for k in ("range_error_m", "bearing_error_deg", "depth_error_m"))
    collisions = metrics["collisions"]
    return (
        f"The paper's mission, {metrics['simulated_s']:.0f} simulated seconds, seed "
        f"{metrics['seed']} (`out/demo/metrics.json`): the ROV "
        + ("never acquires the trail" if acquired is None else
           f"acquires the trail after {acquired:.1f} s and then holds it with a range error "
           f"of {r['rms']:.2f} m RMS (p95 {r['p95_abs']:.2f} m), a bearing error of "
           f"{b['rms']:.1f}° RMS, the diver's depth within {1000 * d['max_abs']:.1f} mm")
        + f", a minimum separation of {metrics['min_separation_m']:.2f} m and "
        + ("no collision." if collisions == 0 else f"{collisions} collisions.")
    )


def replace_demo_numbers(readme: str, metrics: dict) -> str:
    """``readme`` with the text between the demo-metrics markers replaced."""
    pattern = re.compile(re.escape(START) + r".*?" + re.escape(END), re.S)
    if not pattern.search(readme):
        raise SystemExit(f"README.md has no {START} ... {END} section")
    text = textwrap.fill(demo_paragraph(metrics), width=90)
    return pattern.sub(lambda _: f"{START}\n{text}\n{END}", readme)


def uhrisim(*args: str | Path) -> None:
    print("$ uhrisim", *map(str, args), flush=True)
    subprocess.run([sys.executable, "-m", "uhrisim", *map(str, args)], check=True, cwd=ROOT)


def step(out: Path, reuse: bool, *args: str | Path) -> Path:
    """Run ``uhrisim args`` into ``out`` unless ``reuse`` and it is there already."""
    if not (reuse and out.exists() and any(out.iterdir())):
        if out.exists():
            shutil.rmtree(out)
        uhrisim(*args)
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reuse", action="store_true", help="keep outputs of earlier runs")
    reuse = parser.parse_args(argv).reuse
    work = ROOT / "out" / "docs"
    work.mkdir(parents=True, exist_ok=True)
    demo = step(work / "demo", reuse, "demo", "--out", work / "demo")
    for name in ("trajectory.png", "range_bearing.png", "sonar_strip.png"):
        shutil.copy2(demo / name, IMG / name)
    metrics = json.loads((demo / "metrics.json").read_text())
    README.write_text(replace_demo_numbers(README.read_text(), metrics))
    tank = step(work / "tank", reuse, "figure", "sonar-tank", "--out", work / "tank")
    shutil.copy2(tank / "tank_vendor.png", IMG / "sonar_tank_fan.png")
    presets = step(work / "presets", reuse, "figure", "sonar-presets", "--out", work / "presets")
    for path in presets.glob("tank_*.jpg"):
        shutil.copy2(path, IMG / "presets" / path.name)
    camera = step(work / "camera", reuse, "figure", "camera", "--out", work / "camera")
    _to_jpeg(camera / "camera_grid.png", IMG / "camera_grid.jpg", width=1000)
    sweep = step(work / "sweep", reuse, "sweep", "scenarios/batch/sweep_trail_gains.yaml",
                 "--out", work / "sweep")
    shutil.copy2(sweep / "summary.png", IMG / "sweep_summary.png")
    data = step(work / "dataset", reuse, "dataset", "scenarios/batch/dataset_sonar_objects.yaml",
                "--out", work / "dataset", "--frames", "16")
    shutil.copy2(data / "preview.png", IMG / "dataset_preview.png")
    _viewer_screenshots(demo / "recording.mcap")


def _to_jpeg(source: Path, target: Path, width: int) -> None:
    import cv2

    image = cv2.imread(str(source))
    scale = width / image.shape[1]
    image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    cv2.imwrite(str(target), image, [cv2.IMWRITE_JPEG_QUALITY, 88])


def _viewer_screenshots(demo_recording: Path) -> None:
    sys.path.insert(0, str(ROOT))
    from tests.support.browser import (
        chromium_unavailable,
        mission_screenshot,
        replay_screenshot,
        team_screenshot,
    )

    why = chromium_unavailable()
    if why is not None:
        print(f"viewer screenshots skipped: {why}")
        return
    mission_screenshot(str(IMG / "viewer.png"))
    replay_screenshot(str(IMG / "viewer_replay.png"), str(demo_recording), 240.0, 300.0)
    team_screenshot(str(IMG / "viewer_team.png"))


if __name__ == "__main__":
    main()
