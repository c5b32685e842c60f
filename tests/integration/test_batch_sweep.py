"""Sweeps on a real local Ray (one per module, 2 CPUs, loopback only): a 2×2×2 sweep gives
8 rows with the right parameters, applied in each run; an interrupted and restarted sweep
skips the runs that finished (and reruns the one whose metrics were cut short); a run
with a value the scenario refuses, or that cannot be built, is a failed row with its
one-line error while the others finish. The ``uhrisim sweep`` command SIGKILLed with its
own local Ray and started again skips the runs that finished; with ``--address`` it joins
an existing Ray. The local Ray listens on loopback only.

Runs are 3 simulated seconds of the paper's mission without sonar or recording.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("ray")
pa_parquet = pytest.importorskip("pyarrow.parquet")

from uhrisim.batch.cluster import LOOPBACK, start_local_ray  # noqa: E402
from uhrisim.batch.sweep import RUNS_DIR, run_sweep  # noqa: E402
from uhrisim.scenario.shipped import shipped_scenario  # noqa: E402

HEADING = "agents.videoray.controller.heading"
RANGE = "metrics.range"


@pytest.fixture(scope="module")
def local_ray():
    import ray

    start_local_ray(2)
    yield ray
    ray.shutdown()


def write_sweep(folder: Path, grid: dict, seeds=(1, 2), **extra) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    sweep = {"scenario": str(shipped_scenario()), "duration": 3.0, "raycast_sensors": False,
             "figures": False, "set": {"recording.enabled": False}, "grid": grid,
             "seeds": list(seeds)} | extra
    path = folder / "sweep.yaml"
    path.write_text(json.dumps(sweep))  # JSON is YAML
    return path


def test_local_ray_listens_on_loopback_only(local_ray):
    import psutil

    nodes = local_ray.nodes()
    assert [n["NodeManagerAddress"] for n in nodes] == [LOOPBACK]
    ray_pids = {p.pid for p in psutil.process_iter(["cmdline"])
                if any("ray" in part for part in (p.info["cmdline"] or [])[:2])}
    listening = [c for c in psutil.net_connections("inet")
                 if c.status == psutil.CONN_LISTEN and c.pid in ray_pids]
    assert listening
    assert {c.laddr.ip.removeprefix("::ffff:") for c in listening} == {LOOPBACK}


def test_a_2x2x2_sweep_gives_8_rows_with_their_parameters(local_ray, tmp_path):
    grid = {HEADING: [0.5, 2.0], RANGE: [2.0, 3.0]}
    out = tmp_path / "out"
    result = run_sweep(write_sweep(tmp_path, grid), out, workers=2)
    table = pa_parquet.read_table(out / "results.parquet").to_pylist()
    assert len(table) == 8 and result.failed == 0 and result.skipped == 0
    expected = set(itertools.product(grid[HEADING], grid[RANGE], (1, 2)))
    assert {(r[HEADING], r[RANGE], r["seed"]) for r in table} == expected
    assert all(r["status"] == "ok" and r["error"] is None for r in table)
    csv_lines = (out / "results.csv").read_text().splitlines()
    assert len(csv_lines) == 9 and csv_lines[0].startswith(f"run,status,seed,{HEADING},{RANGE}")
    for row in table:  # each run ran with its own values: metrics.json says so
        metrics = json.loads((out / RUNS_DIR / row["run"] / "metrics.json").read_text())
        assert metrics["seed"] == row["seed"] and metrics["trail_range_m"] == row[RANGE]
        assert metrics["simulated_s"] == pytest.approx(3.0, abs=0.05)
        assert row["min_separation_m"] == metrics["min_separation_m"]
        assert not list((out / RUNS_DIR / row["run"]).glob("*.png"))  # figures: false
    # the heading gain steers the ROV: the same seed and range, another gain, another path
    by_key = {(r[HEADING], r[RANGE], r["seed"]): r["min_separation_m"] for r in table}
    assert by_key[(0.5, 2.0, 1)] != by_key[(2.0, 2.0, 1)]
    assert (out / "summary.png").stat().st_size > 10_000


def test_an_interrupted_sweep_restarts_where_it_stopped(local_ray, tmp_path):
    path = write_sweep(tmp_path, {HEADING: [0.5, 1.0], RANGE: [2.0, 3.0]})
    out = tmp_path / "out"
    finished_before: list[int] = []

    def stop_after_three(done: int, total: int) -> None:
        finished_before.append(done)
        if done >= 3:
            raise KeyboardInterrupt  # as Ctrl-C would, with runs still in flight

    with pytest.raises(KeyboardInterrupt):
        run_sweep(path, out, workers=2, progress=stop_after_three)
    complete = {p.parent.name: p.stat().st_mtime_ns for p in (out / RUNS_DIR).glob(
        "*/metrics.json") if json.loads(p.read_text()).get("completed")}
    assert len(complete) >= 3 and not (out / "results.parquet").exists()
    cut = sorted(complete)[0]  # a metrics.json cut short by a kill mid-write
    metrics = out / RUNS_DIR / cut / "metrics.json"
    metrics.write_text(metrics.read_text()[:40])
    result = run_sweep(path, out, workers=2)
    assert len(result.rows) == 8 and result.failed == 0
    assert result.skipped == len(complete) - 1
    for run, mtime in complete.items():  # finished runs untouched, the cut one run again
        again = (out / RUNS_DIR / run / "metrics.json").stat().st_mtime_ns
        assert (again == mtime) == (run != cut)
    assert json.loads(metrics.read_text())["completed"] is True
    third = run_sweep(path, out, workers=2)
    assert third.skipped == 8 and all(r["run_wall_s"] is None for r in third.rows)


def test_failed_runs_are_recorded_and_the_others_finish(local_ray, tmp_path):
    # -1 is refused by the schema (a gain >= 0); a diver 50 m down starts below the floor
    # (8 m): refused when the run builds, inside its Ray task
    grid = {HEADING: [1.0, -1.0], "agents.diver.start.depth": [1.5, 50.0]}
    result = run_sweep(write_sweep(tmp_path, grid, seeds=(1,)), tmp_path / "out", workers=2)
    rows = {(r[HEADING], r["agents.diver.start.depth"]): r for r in result.rows}
    assert len(rows) == 4 and result.failed == 3
    assert rows[(1.0, 1.5)]["status"] == "ok"
    assert rows[(1.0, 1.5)]["min_separation_m"] > 0
    for key in [(-1.0, 1.5), (-1.0, 50.0)]:
        error = rows[key]["error"]
        assert rows[key]["status"] == "failed" and "\n" not in error
        assert "agents[1].controller.heading: must be in [0, 10000] 1/deg, got -1.0" in error
        folder = tmp_path / "out" / RUNS_DIR / rows[key]["run"]
        assert (folder / "error.txt").read_text() == error + "\n"
        assert json.loads((folder / "run.json").read_text())["parameters"][HEADING] == -1.0
    built = rows[(1.0, 50.0)]
    assert built["status"] == "failed" and "\n" not in built["error"]
    assert "below the sea floor" in built["error"]
    assert (tmp_path / "out" / RUNS_DIR / built["run"] / "error.txt").read_text().strip() == \
        built["error"]


def test_a_sigkilled_sweep_command_restarts_where_it_stopped(tmp_path):
    """The command itself, with the local Ray it starts, SIGKILLed (its whole process
    group) after two runs finished; started again, it runs only the others."""
    path = write_sweep(tmp_path, {RANGE: [2.0, 3.0, 4.0, 5.0]}, duration=20.0)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "uhrisim", "sweep", str(path), "--out", str(out),
               "--workers", "2"]
    first = subprocess.Popen(command, start_new_session=True, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 180.0
        while len(list((out / RUNS_DIR).glob("*/metrics.json"))) < 2:
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.1)
    finally:
        os.killpg(first.pid, signal.SIGKILL)
        first.wait()
    complete = {p.parent.name: p.stat().st_mtime_ns for p in (out / RUNS_DIR).glob(
        "*/metrics.json") if json.loads(p.read_text()).get("completed")}  # never a part
    assert 2 <= len(complete) < 8 and not (out / "results.csv").exists()
    again = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    # (a worker busy when its driver died may still finish its run before it exits)
    summary = re.search(r"8 runs: 8 ok \((\d+) already done\), 0 failed", again.stdout)
    assert summary and len(complete) <= int(summary[1]) < 8, again.stdout
    for run, mtime in complete.items():
        assert (out / RUNS_DIR / run / "metrics.json").stat().st_mtime_ns == mtime
    assert len((out / "results.csv").read_text().splitlines()) == 9


def test_a_task_that_raises_is_reported_and_the_others_finish(local_ray):
    from uhrisim.batch.cluster import run_tasks

    def halve(x: int) -> float:
        if x == 3:
            raise ValueError("three is odd here")
        return x / 2

    results, errors = {}, {}
    run_tasks(halve, [1, 2, 3, 4], 2, results.__setitem__, errors.__setitem__)
    assert results == {0: 0.5, 1: 1.0, 3: 2.0}
    assert list(errors) == [2] and type(errors[2]) is ValueError
    assert "three is odd here" in str(errors[2])
    with pytest.raises(ValueError, match="three is odd here"):  # the task's own error
        run_tasks(halve, [3], 1, results.__setitem__)


def test_an_interruption_returns_only_once_the_cancelled_tasks_have_ended(local_ray,
                                                                         tmp_path):
    """A callback that raises (as Ctrl-C would) while tasks run: ``run_tasks`` cancels them
    and returns only once their code has stopped, so nothing of the sweep writes on: each
    cancelled task's beat (a byte appended every millisecond; "queued" is submitted as
    "quick" ends and may have started) is as long when ``run_tasks`` has returned as once
    its worker process has ended."""
    import psutil

    from uhrisim.batch.cluster import run_tasks

    def beat(name: str) -> Path:
        return tmp_path / f"{name}.beat"

    def task(name: str) -> str:
        (tmp_path / f"{name}.pid").write_text(str(os.getpid()))
        if name == "quick":  # returns once the slow task runs, whose result never comes
            while not beat("slow").exists():
                time.sleep(0.01)
            return name
        with beat(name).open("ab", buffering=0) as out:
            while True:
                out.write(b".")
                time.sleep(0.001)

    def interrupt(index: int, result: str) -> None:
        raise KeyboardInterrupt

    def beats(name: str) -> int:
        return beat(name).stat().st_size if beat(name).exists() else -1

    with pytest.raises(KeyboardInterrupt):
        run_tasks(task, ["quick", "slow", "queued"], 2, interrupt)
    at_return = {name: beats(name) for name in ("slow", "queued")}
    assert at_return["slow"] > 0
    for name in at_return:
        pid = tmp_path / f"{name}.pid"
        if pid.exists():
            with contextlib.suppress(psutil.NoSuchProcess):  # bounded only against a hang
                psutil.Process(int(pid.read_text())).wait(timeout=120)
    assert {name: beats(name) for name in at_return} == at_return


@pytest.mark.parametrize("how", ["host:port", "auto"])
def test_the_command_joins_an_existing_ray(local_ray, tmp_path, how):
    """``uhrisim sweep --address`` in another process joins this module's Ray (a cluster
    of one node) as a second driver, runs there, and leaves it running."""
    gcs = local_ray.get_runtime_context().gcs_address
    assert gcs.startswith(f"{LOOPBACK}:")
    env = os.environ | ({"RAY_ADDRESS": gcs} if how == "auto" else {})
    path = write_sweep(tmp_path, {RANGE: [2.0, 3.0]}, seeds=(1,), figures=True)
    done = subprocess.run([sys.executable, "-m", "uhrisim", "sweep", str(path), "--out",
                           str(tmp_path / "out"), "--address", gcs if how != "auto" else how],
                          capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    assert "2 runs: 2 ok (0 already done), 0 failed" in done.stdout
    table = pa_parquet.read_table(tmp_path / "out" / "results.parquet").to_pylist()
    assert sorted(r[RANGE] for r in table) == [2.0, 3.0]
    for row in table:  # figures: true (the default) draws each run's figures
        assert (tmp_path / "out" / RUNS_DIR / row["run"] / "trajectory.png").stat().st_size
    assert local_ray.get(local_ray.remote(lambda: 42).remote()) == 42  # still running


def test_limit_runs_the_first_planned_runs_and_a_full_sweep_then_skips_them(local_ray,
                                                                           tmp_path):
    grid = {RANGE: [2.0, 3.0]}
    path, out = write_sweep(tmp_path, grid, seeds=(1, 2, 3)), tmp_path / "out"
    seen: list[tuple[int, int]] = []
    small = run_sweep(path, out, workers=2, limit=2, progress=lambda d, t: seen.append((d, t)))
    assert {r["run"] for r in small.rows} == {p.name for p in (out / RUNS_DIR).iterdir()}
    assert len(small.rows) == 2 and small.planned == 6 and small.failed == 0
    assert {(r[RANGE], r["seed"]) for r in small.rows} == {(2.0, 1), (2.0, 2)}
    assert seen[0] == (0, 2) and seen[-1] == (2, 2)
    whole = run_sweep(path, out, workers=2)
    assert len(whole.rows) == 6 and whole.skipped == 2
