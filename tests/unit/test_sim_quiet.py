"""The quiet ticks' compiled stretch (uhrisim/sim/quiet.py) against the loop's own ticks:
``Simulation.run`` without hooks takes the stretches, ``Simulation.step`` never does; the
two must leave the same states, inputs, kick phases, collisions and events, bit for bit —
in the paper's mission, and where the stretch must stop and hand ticks back to the loop
(an ROV that runs into the diver from the surface, vehicles near a shallow floor)."""

from pathlib import Path

import pytest

from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import copy_scenario
from uhrisim.sim.simulation import Simulation

pytest.importorskip("numba", reason="the stretch is compiled (the [fast] extra)")

SECONDS = 8
TICKS_A_SECOND = 60


def _scenario(folder: Path, *edits: tuple[str, str]) -> Path:
    """track_and_trail.yaml copied into ``folder`` with each (old, new) text replaced."""
    path = next(p for p in copy_scenario("track_and_trail", folder) if p.suffix == ".yaml")
    text = path.read_text()
    for old, new in edits:
        assert old in text
        text = text.replace(old, new)
    path.write_text(text)
    return path


def _trace(path: Path, stretches: bool) -> tuple[list, dict[str, int]]:
    """Every second's states, inputs, kick phases, collisions and events; and how many
    ticks went which way (``stretches``: ``run``, else ``step`` tick by tick)."""
    ways = {"loop": 0, "after_moves": 0}
    rows = []
    with Simulation(load_scenario(path), raycast_sensors=False) as sim:
        assert sim._quiet is not None
        step, after_moves = sim._step, sim._after_moves

        def counted_step(build_frame):
            ways["loop"] += 1
            return step(build_frame)

        def counted_after_moves(build_frame):
            ways["after_moves"] += 1
            return after_moves(build_frame)

        sim._step, sim._after_moves = counted_step, counted_after_moves
        for _ in range(SECONDS):
            if stretches:
                sim.run(1.0)
            else:
                for _ in range(TICKS_A_SECOND):
                    sim.step()
            rows.append((sim.tick, sim.collisions,
                         [(a.state.tobytes(), a.inputs.tobytes(), a.kick_phase)
                          for a in sim.agents.values()],
                         [(e.t, e.kind, e.detail) for e in sim.events_log]))
    return rows, ways


def test_the_mission_s_quiet_ticks_go_in_stretches_with_the_same_numbers(tmp_path):
    path = _scenario(tmp_path)
    stretched, ways = _trace(path, stretches=True)
    assert stretched == _trace(path, stretches=False)[0]
    ticks = SECONDS * TICKS_A_SECOND
    # the helms' and contacts' ticks (4 Hz) are the loop's; their moves and the rest are not
    assert ways["loop"] + ways["after_moves"] == ticks // 15
    assert ways["loop"] <= 2


def test_the_loop_takes_the_ticks_where_bodies_meet_or_near_the_floor(tmp_path):
    # the ROV starts 1.2 m ahead of the diver, who swims into it; a floor 1 m below them
    path = _scenario(tmp_path / "meet",
                     ("{north: 0, east: 0, depth: 0, heading_deg: 180}",
                      "{north: -1.2, east: 10, depth: 1.5, heading_deg: 0}"))
    stretched, ways = _trace(path, stretches=True)
    assert stretched == _trace(path, stretches=False)[0]
    assert stretched[-1][1] > 0 and ways["loop"] > 0  # collisions, counted by the loop
    path = _scenario(tmp_path / "floor", ("depth: 8, roughness: 0.3", "depth: 2.5, roughness: 0.3"))
    stretched, ways = _trace(path, stretches=True)
    assert stretched == _trace(path, stretches=False)[0]
    assert ways["loop"] > SECONDS * TICKS_A_SECOND // 2  # near the floor: the loop's ticks
