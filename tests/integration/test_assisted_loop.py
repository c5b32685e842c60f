"""The diver's assistant in the simulation loop (docs/hri.md, "In the simulation loop"):
the diver's slate rendered by the ROV's own camera, read by the marker reader, the
assistant fetching a dive light through the helm's variables and the gripper's GRIPPER,
and the diver taking it — in a small mid-water world, kept short (camera 320 × 240 at
2 Hz, no sonar)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.assistance import REPEATS_MAX
from uhrisim.sim.simulation import Simulation

SCENARIO = """\
name: assisted_handover
seed: 3
duration: 75
physics_rate_hz: 60
world:
  seafloor: {{type: flat, depth: 8, extent: 30}}
  sites:
    - {{type: platform, name: stand1, at: {{north: 1.0, east: 2.5, depth: 5.3}}, size: [0.4, 0.4]}}
  tools:
    - {{kind: light, name: light1, at: {{north: 1.0, east: 2.5}}, onto: stand1}}
agents:
  - name: diver
    model: diver
    body: figure
    start: {{north: 0, east: 0, depth: 5.0, heading_deg: 0}}
    driver: orders
    orders:
      - {{signal: bring_tool light, channel: marker}}
      - {{wait_until: light1, state: "held_by:diver/right_hand", timeout_s: {wait}}}
  - name: rov1
    model: videoray
    start: {{north: 2.5, east: 0.0, depth: 4.6, heading_deg: 180}}
    control_rate_hz: 20
    gripper: {{command: open}}
    sensors:
      - {{type: camera, preset: videoray-pro4, rate_hz: 2, width: 320, height: 240,
         tilt_deg: 10, water: {{jerlov: {water}}}}}
    assistant: {{diver: diver, track: truth, channels: [marker]{extra}}}
"""


def _run(tmp_path: Path, water: str, wait: float, seconds: float, extra: str = ""):
    path = tmp_path / "assisted.yaml"
    path.write_text(SCENARIO.format(water=water, wait=wait,
                                    extra=extra))
    sim = Simulation(load_scenario(path))
    sim.run(seconds)
    return sim, sim.assistance.summary()["assistant"]["rov1"]


@pytest.fixture(scope="module")
def clear(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("clear"), "I", 80, 72.0)


def test_the_slate_is_read_and_the_light_handed_over_through_the_loop(clear):
    sim, m = clear
    assert m["signals"]["marker"] == {"issued": 1, "recognized": 1, "missed": 0, "false": 0}
    assert m["latency_s"]["each"][0] <= 3.0  # while the slate is held up (3 s)
    assert m["handovers"] == {"attempted": 1, "succeeded": 1}
    assert sim.team.workspace.held_by("diver/right_hand") == "light1"
    assert m["steps"] == {"done": 2, "failed": 0, "orders": 2}
    assert m["task_completion_s"] is not None and m["diver_waiting_s"] > 10.0
    # the same decisions an outside planner would post, on the ROV's community
    assert {"ASSIST_MODE", "ASSIST_TASK", "GRIPPER"} <= set(sim.agents["rov1"].community.values())
    assert any(e.kind == "assistant" and "handed over" in e.detail for e in sim.events_log)


def test_the_guards_hold_and_nothing_collides(clear):
    sim, m = clear
    sep = m["min_separation_m"]
    assert sep["body"] >= sep["body_guard"] and sep["head"] >= sep["head_guard"]
    assert m["collisions"] == 0 and sim.collisions == 0


def test_in_turbid_water_the_slate_is_missed_the_rov_asks_again_and_the_run_ends_safely(
        tmp_path):
    """9C: the slate is missed; the idle ROV, with the diver hovering 2.5 m before it,
    closes in to arm's reach and shows its "say again?" cue (asked sooner than the
    default, to keep the test short); he repeats the slate, at most REPEATS_MAX times,
    missed each time; his wait fails; nothing is touched."""
    sim, m = _run(tmp_path, "9C", 12, 26.0, ", params: {ask_after_s: 4}")
    assert m["asked_again"] > REPEATS_MAX and m["signals_repeated"] == REPEATS_MAX
    cues = [float(re.search(r"hovering ([0-9.]+) m", e.detail).group(1))
            for e in sim.events_log if e.kind == "assistant" and "say again? (" in e.detail]
    assert len(cues) == m["asked_again"] and max(cues) <= 1.3  # reach_m + its tolerance
    assert m["signals"]["marker"] == {"issued": 1 + REPEATS_MAX, "recognized": 0,
                                      "missed": 1 + REPEATS_MAX, "false": 0}
    assert any(e.kind == "teamwork" and "repeats bring_tool light (marker)" in e.detail
               for e in sim.events_log)
    assert m["handovers"]["attempted"] == 0
    assert {out.task for out in sim.assistance.vehicles[0].assistant.trace} == {"idle"}
    assert m["steps"]["failed"] == 1 and m["task_completion_s"] is None
    sep = m["min_separation_m"]
    assert sep["body"] >= sep["body_guard"] and sim.collisions == 0


def test_a_bad_assistant_section_is_refused_at_its_line(tmp_path):
    with pytest.raises(ConfigError, match=r"assisted\.yaml:\d+.*body_guard_m"):
        _run(tmp_path, "I", 10, 0.1, ", params: {body_guard_m: -1}")
    with pytest.raises(ConfigError, match=r"assisted\.yaml:\d+.*no tool 'light9'"):
        _run(tmp_path, "I", 10, 0.1, ", tools: {light: light9}")
