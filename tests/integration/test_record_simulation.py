"""Recording a real simulation run through its publish hook.

Checks that the recording holds one odometry message per agent per tick, one sonar
image pair per ping, that the last recorded pose is the simulation's last pose, and
that two runs of the same scenario and seed give byte-identical files (docs/design.md
habit 5: the recorder puts no wall-clock time into the file).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uhrisim.record import McapRecordingHook, read_odometry, summarize
from uhrisim.scenario import load
from uhrisim.sim import simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"
DURATION_S = 1.0


def record(path: Path, seed: int = 3):
    if not SCENARIO.exists():
        pytest.skip(f"{SCENARIO} not present")
    source = load.load_scenario(SCENARIO)
    hook = McapRecordingHook(path)
    sim = simulation.Simulation(source, hooks=[hook], seed=seed)
    frames = []
    sim.start()
    ticks = round(DURATION_S / sim.dt)
    error = None
    try:
        for _ in range(ticks):
            frames.append(sim.step())
    except BaseException as exc:  # pragma: no cover - reported by the raise below
        error = exc
        raise
    finally:
        for h in sim.hooks:
            h.on_end(sim, error)
    return sim, frames


def test_recording_matches_the_run(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _sim, frames = record(path)
    s = summarize(path)
    assert not s.truncated
    agents = list(frames[-1].agents)
    for name in agents:
        assert s.topics[f"/{name}/odom"] == ("nav_msgs/msg/Odometry", len(frames))
    n_pings = {}
    for f in frames:
        for key in f.pings:  # "<agent>/<sonar>": the sonar's topics
            n_pings[key] = n_pings.get(key, 0) + 1
    for key, n in n_pings.items():
        assert s.topics[f"/{key}/fan"][1] == n
        assert s.topics[f"/{key}/polar"][1] == n
    tracks = read_odometry(path)
    last = frames[-1]
    for name in agents:
        nav = last.agents[name].nav
        tr = tracks[name]
        assert tr.t[-1] == pytest.approx(last.t, abs=1e-9)
        np.testing.assert_allclose([tr.x_north[-1], tr.y_east[-1], tr.depth[-1]],
                                   nav.position_ned, atol=1e-9)
        assert tr.yaw[-1] == pytest.approx(nav.yaw, abs=1e-9)


def test_same_seed_same_bytes(tmp_path: Path) -> None:
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    record(a)
    record(b)
    assert a.read_bytes() == b.read_bytes()
