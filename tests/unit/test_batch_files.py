"""Sweep and dataset files: dotted paths held to the scenario schema, the plan of a sweep
(grid × list × random × seeds, hashes), and bad files refused in one line before Ray
starts (``uhrisim sweep`` / ``uhrisim dataset``: one ``error:`` line, exit status 2)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from tests.support.cli import one_line_error
from tests.support.ports import held_port
from uhrisim.batch.params import Draw, apply_path, check_path, split_path
from uhrisim.batch.sweep import load_sweep
from uhrisim.cli import app
from uhrisim.core.errors import ConfigError
from uhrisim.scenario.shipped import shipped_scenario

BASE = yaml.safe_load(shipped_scenario().read_text())
cli = CliRunner()


def sweep_file(folder: Path, **fields) -> Path:
    path = folder / "sweep.yaml"
    path.write_text(json.dumps({"scenario": str(shipped_scenario())} | fields))
    return path


@pytest.mark.parametrize("path", [
    "duration", "agents.videoray.controller.heading", "agents[1].controller.heading",
    "agents.1.start.depth", "world.water.temperature_c", "world.seafloor.roughness",
    "agents.videoray.sensors.0.range_max_m", "agents.diver.helm.behaviors.1.speed",
    "recording.enabled", "metrics.range",
])
def test_known_paths(path):
    check_path(path, BASE)


@pytest.mark.parametrize(("path", "message"), [
    ("agents.videoray.controler.heading", "unknown key 'controler'; did you mean 'controller'?"),
    ("agents.videoroy.start.depth", "no item named 'videoroy'; did you mean 'videoray'?"),
    ("agents.5.start", "index 5 is past the 2 items there"),
    ("durration", "did you mean 'duration'?"),
    ("duration.value", "'value' goes inside a value that has no keys"),
    ("world.seafloor.slope", "unknown key 'slope'"),  # the base floor is procedural
    ("agents..start", "not a dotted path"),
])
def test_unknown_paths_name_the_key(path, message):
    with pytest.raises(ConfigError, match=message.replace("?", r"\?").replace("[", r"\[")):
        check_path(path, BASE)


def test_apply_path_sets_values_and_creates_sections():
    data = json.loads(json.dumps(BASE))
    apply_path(data, "agents.videoray.controller.heading", 2.5)
    apply_path(data, "agents[0].start.depth", 3.0)
    apply_path(data, "bridges.ros2.odom_rate_hz", 20.0)  # no bridges section in the file
    assert data["agents"][1]["controller"] == {"preset": "mission", "heading": 2.5}
    assert data["agents"][0]["start"]["depth"] == 3.0
    assert data["bridges"] == {"ros2": {"odom_rate_hz": 20.0}}
    assert split_path("a[2].b") == ["a", 2, "b"]


def test_draws_are_in_range_and_reproducible():
    rng = np.random.default_rng(0)
    u = [Draw(uniform=(1.0, 2.0)).sample(rng) for _ in range(200)]
    logs = [Draw(log_uniform=(0.1, 10.0)).sample(rng) for _ in range(200)]
    ints = {Draw(integers=(3, 5)).sample(rng) for _ in range(200)}
    assert 1.0 <= min(u) <= max(u) <= 2.0 and 0.1 <= min(logs) <= max(logs) <= 10.0
    assert ints == {3, 4, 5}  # both ends included
    assert abs(np.median(np.log10(logs))) < 0.25  # log-uniform: median near 10^0
    with pytest.raises(ValueError, match="exactly one"):
        Draw(uniform=(0, 1), choice=("a",))


def test_a_plan_crosses_grid_list_random_and_seeds(tmp_path):
    path = sweep_file(tmp_path, grid={"metrics.range": [2.0, 3.0]},
                      list=[{"world.water.temperature_c": 5}, {"world.water.temperature_c": 25}],
                      random={"count": 3, "seed": 4, "parameters": {
                          "agents.videoray.controller.heading": {"uniform": [0.5, 2.0]}}},
                      seeds={"count": 2, "start": 10})
    plan = load_sweep(path)
    assert len(plan.runs) == 2 * 2 * 3 * 2
    assert plan.parameters == ["metrics.range", "world.water.temperature_c",
                               "agents.videoray.controller.heading"]
    assert {r.seed for r in plan.runs} == {10, 11}
    assert len({r.run_id for r in plan.runs}) == len(plan.runs)  # distinct scenarios
    again = load_sweep(path)  # the same file: the same runs, the same identities
    assert [r.run_id for r in again.runs] == [r.run_id for r in plan.runs]
    assert [r.parameters for r in again.runs] == [r.parameters for r in plan.runs]
    # a default written out is the same resolved scenario: the same identity
    explicit = load_sweep(sweep_file(tmp_path, set={"agents.videoray.controller.speed_weight":
                                                    None}, seeds=[10]))
    implicit = load_sweep(sweep_file(tmp_path, seeds=[10]))
    assert explicit.runs[0].run_id == implicit.runs[0].run_id


@pytest.mark.parametrize(("fields", "parts"), [
    ({"grid": {"agents.videoray.controler.heading": [1, 2]}},
     ["sweep.yaml:", "did you mean 'controller'?"]),
    ({"grid": {"metrics.range": []}}, ["metrics.range: an empty list of values gives no runs"]),
    ({"grid": {}}, ["the grid is empty"]),
    ({"list": []}, ["list: give at least one point"]),
    ({"grid": {"duration": [1, 2]}, "set": {"duration": 3}}, ["duration is in both set and grid"]),
    ({"random": {"count": 2, "parameters": {"metrics.range": {"uniform": [3, 2]}}}},
     ["low 3.0 is above high 2.0"]),
    ({"seeds": [-1]}, ["seeds"]),
    ({"grids": {}}, ["unknown key 'grids'; did you mean 'grid'?"]),
])
def test_bad_sweep_files_are_one_line_errors(tmp_path, fields, parts):
    out = tmp_path / "out"
    result = cli.invoke(app, ["sweep", str(sweep_file(tmp_path, **fields)), "--out", str(out)])
    one_line_error(result, *parts)
    assert not out.exists()


def test_a_missing_base_scenario_is_one_line(tmp_path):
    path = tmp_path / "sweep.yaml"
    path.write_text("scenario: nowhere.yaml\n")
    one_line_error(cli.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "o")]),
                   "nowhere.yaml: scenario file not found")


@pytest.mark.parametrize(("address", "part"), [
    ("ray://127.0.0.1:{port}", "cannot reach Ray at ray://127.0.0.1:{port}"),
    ("127.0.0.1:{port}", "cannot reach Ray at 127.0.0.1:{port}"),
    ("ray://127.0.0.1", "is not 'auto', 'ray://host:port' or 'host:port'"),
    ("http://x:1", "is not 'auto'"),
])
def test_unreachable_or_malformed_addresses_are_one_line(tmp_path, address, part):
    # a loopback port nothing listens on: held bound (not listening) all along, so that no
    # other process can start listening there in between (a connection is refused)
    with held_port() as probe:
        port = probe.getsockname()[1]
        address, part = address.format(port=port), part.format(port=port)
        path = sweep_file(tmp_path, grid={"metrics.range": [2.0]})
        result = cli.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "o"),
                                  "--address", address])
    one_line_error(result, "--address", part)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(("edit", "parts"), [
    ({"frames": 0}, ["frames: Input should be greater than or equal to 1"]),
    ({"objects": {"kinds": [{"type": "cylinder", "radius": 0.3}]}}, ["a cylinder needs height"]),
    ({"objects": {"kinds": [{"type": "box", "size": [1, 1, 1], "material": ["gold"]}]}},
     ["unknown material 'gold'"]),
    ({"sonar": {"settings": {"rays_per_bean": 8}}}, ["sonar.settings", "rays_per_bean"]),
    ({"sonar": {"settings": {"tilt_deg": 8}}}, ["tilt_deg is drawn by the dataset itself"]),
    ({"sonar": {"range_max_m": 500}}, ["range_max_m", "beyond the P900-45 maximum"]),
    ({"objects": {"kinds": [{"type": "mesh", "file": "none.obj"}]}}, ["none.obj"]),
])
def test_bad_dataset_files_are_one_line_errors(tmp_path, edit, parts):
    spec = {"name": "bad", "frames": 2, "objects": {"kinds": [{"type": "diver"}]}} | edit
    path = tmp_path / "dataset.yaml"
    path.write_text(json.dumps(spec))
    out = tmp_path / "out"
    one_line_error(cli.invoke(app, ["dataset", str(path), "--out", str(out)]), *parts)
    assert not out.exists()


def test_the_shipped_examples_and_the_readme_sweep_load(tmp_path):
    from uhrisim.batch.dataset import load_dataset

    plan = load_sweep(shipped_scenario("batch/sweep_trail_gains.yaml"))
    assert len(plan.runs) == 3 * 3 * 2 and not any(r.error for r in plan.runs)
    assert all(r.data["agents"][1]["contacts"]["position_noise_std"] == 0.2 for r in plan.runs)
    dataset = load_dataset(shipped_scenario("batch/dataset_sonar_objects.yaml"))
    assert dataset.spec.classes == ["diver", "rov", "piling", "crate", "buoy", "tyre"]
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    block = next(b for b in re.findall(r"```yaml\n(.*?)```", readme, flags=re.S)
                 if b.startswith("scenario:"))
    sweep = yaml.safe_load(block) | {"scenario": str(shipped_scenario())}
    (tmp_path / "readme.yaml").write_text(json.dumps(sweep))
    assert [r.parameters for r in load_sweep(tmp_path / "readme.yaml").runs] == [
        r.parameters for r in plan.runs]


def test_confidence_intervals_and_bins_of_the_summary_figure():
    from scipy import stats

    from uhrisim.batch.figures import BINS, _groups, mean_ci95

    mean, half = mean_ci95(np.array([1.0, 2.0, 3.0, 4.0, np.nan]))
    # by hand: s = sqrt(5/3), t(0.975, 3) = 3.1824
    assert mean == 2.5 and half == pytest.approx(3.1824463 * np.sqrt(5 / 3) / 2, rel=1e-6)
    assert mean_ci95(np.array([7.0])) == (7.0, 0.0)
    sample = np.random.default_rng(1).normal(10.0, 2.0, 4000)
    m, h = mean_ci95(sample)
    assert h == pytest.approx(stats.sem(sample) * 1.96, rel=0.01) and abs(m - 10.0) < h * 2
    groups, xs, labels = _groups([0.5, 2.0, 0.5, 1.0, 2.0])  # a grid: one group a value
    assert xs == [0.5, 1.0, 2.0] and [g.tolist() for g in groups] == [[0, 2], [3], [1, 4]]
    drawn = list(np.linspace(0.0, 1.0, 60))  # random draws: equal-count bins
    groups, xs, _ = _groups(drawn)
    assert len(groups) == BINS and {g.size for g in groups} == {10} and xs == sorted(xs)
    groups, xs, labels = _groups(["P900-90", "P900-45", "P900-90"])  # categories
    assert labels == ["P900-90", "P900-45"] and xs == [0.0, 1.0]


def test_the_sweep_summary_is_a_grid_labelled_in_words_with_units(tmp_path):
    import cv2

    from uhrisim.batch.figures import human_label, plot_sweep_summary, summary_figure

    assert human_label("range_error_m.rms") == "range error RMS (m)"
    assert human_label("min_separation_m") == "minimum separation (m)"
    assert human_label("agents.videoray.controller.heading") == "videoray controller heading"
    assert human_label("perception.held_pct") == "perception held (%)"
    rng = np.random.default_rng(0)
    rows = [{"run": f"r{i}", "status": "ok", "seed": i % 3, "gain": g,
             "time_to_acquire_s": 10 + g + rng.random(), "min_separation_m": 1 + rng.random(),
             "range_error_m.rms": 0.2 * g + rng.random() / 10, "collisions": i % 2,
             "bearing_error_deg.rms": 5 + rng.random()}
            for i, g in enumerate([0.5, 1.0, 2.0] * 3)]
    fig = summary_figure(rows, ["gain"], "trail gains")
    panels = [ax for ax in fig.axes if ax.axison]
    assert len(panels) == 5
    assert {ax.get_title() for ax in panels} == {
        "time to acquire (s)", "minimum separation (m)", "collisions",
        "range error RMS (m)", "bearing error RMS (deg)"}
    assert {ax.get_xlabel() for ax in panels} == {"gain"}
    # laid out as a grid (3 across), not one tall column
    width, height = fig.get_size_inches()
    assert width > height
    image = cv2.imread(str(plot_sweep_summary(rows, ["gain"], tmp_path / "s.png")))
    assert image.shape[1] > image.shape[0]
