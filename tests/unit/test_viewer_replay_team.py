"""A replay's tools and sites from recorded /tf poses and teamwork events (docs/viewer.md).

A hand-made ``ReplayData`` (what ``load_replay`` reads from a recording: the teamwork
layout, object poses, event lines as ``WorldEvent.line`` writes them) played at chosen
times: holders follow grasp/release/hand-over, a flange's bolts and cover, a hatch's
moves, a bag's inflation and the load it is on, a load's rise; and the event lines parse
back to the events that made them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from uhrisim.viz.viewer.replay import ReplayData, ReplayPlayer
from uhrisim.world.events import WorldEvent, parse_line

EVENTS = [
    WorldEvent(1.0, "grasp", "wrench1", "diver1/right_hand"),
    WorldEvent(2.0, "grasp_failed", "bag1", "diver1/left_hand", False, "out of reach (1.2 m)"),
    WorldEvent(3.0, "bolt_removed", "flange1", "diver1/left_hand", detail={"bolt": 0}),
    WorldEvent(4.0, "bolt_removed", "flange1", "diver1/left_hand", detail={"bolt": 1}),
    WorldEvent(5.0, "cover_removed", "flange1", "diver1/left_hand"),
    WorldEvent(6.0, "hatch_opening", "hatch1", "diver1/left_hand"),
    WorldEvent(7.0, "hatch_opened", "hatch1"),
    WorldEvent(8.0, "grasp", "wrench1", "rov1/gripper"),  # a hand-over: both hold it,
    WorldEvent(8.0, "handover", "wrench1", "diver1/right_hand"),
    WorldEvent(8.0, "release", "wrench1", "diver1/right_hand"),  # then the giver lets go
    WorldEvent(9.0, "bag_attached", "bag1", "diver1/right_hand", reason="on valve1"),
    WorldEvent(10.0, "bag_inflating", "bag1", "diver1/right_hand"),
    WorldEvent(12.0, "bag_full", "bag1", detail={"litres": 100.0}),
]
LAYOUT = {
    "objects": {"wrench1": {"name": "wrench1", "kind": "wrench", "held_by": []},
                "light1": {"name": "light1", "kind": "light", "held_by": ["rov1/gripper"]},
                "bag1": {"name": "bag1", "kind": "lift_bag", "held_by": []},
                "valve1": {"name": "valve1", "kind": "load", "held_by": []},
                "crate1": {"name": "crate1", "kind": "load", "held_by": []}},
    "flanges": {"flange1": {"position": [3.0, 0.0, 11.0], "bolts": 4}},
    "hatches": {"hatch1": {"position": [5.0, 5.0, 11.0], "open_angle_deg": 110.0}},
    "bags": {"bag1": {"capacity_litres": 100.0}},
}


class _Sink:
    def publish(self, frame) -> None: ...


def _still(north: float, east: float, depth: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([0.0, 20.0]), np.array([[north, east, depth]] * 2)


@pytest.fixture(scope="module")
def player() -> ReplayPlayer:
    t = np.array([0.0, 20.0])
    track = {"t": t, "north": np.zeros(2), "east": np.zeros(2), "depth": np.full(2, 10.0),
             "heading_deg": np.zeros(2), "speed": np.zeros(2)}
    objects = {"wrench1": (t, np.array([[1.0, 1.0, 11.0], [2.0, 3.0, 9.0]])),
               "light1": _still(0.0, -2.0, 9.0), "bag1": _still(4.0, 2.0, 11.0),
               "valve1": (t, np.array([[4.0, 2.1, 11.5], [4.0, 2.1, 10.5]])),
               "crate1": _still(-6.0, 0.0, 11.5)}
    data = ReplayData(tracks={"diver1": track}, kinds={"diver1": "diver"}, pings={},
                      variables={}, scene={}, t_start=0.0, t_end=20.0, sonar_fov_deg={},
                      sonar_range={},
                      team_events=[(e.t, "teamwork", e.line()) for e in EVENTS],
                      layout=LAYOUT, objects=objects)
    return ReplayPlayer(data, _Sink())  # type: ignore[arg-type]


def _team(player: ReplayPlayer, t: float) -> tuple[dict, dict]:
    team = player.frame_at(t)["team"]
    return ({o["name"]: o for o in team["objects"]}, {s["name"]: s for s in team["sites"]})


def test_event_lines_parse_back():
    for event in EVENTS:
        back = parse_line(event.line())
        assert back is not None
        assert (back.t, back.kind, back.subject, back.actor, back.ok, back.reason) == (
            event.t, event.kind, event.subject, event.actor, event.ok, event.reason)
    assert parse_line("not an event") is None


def test_poses_and_holders(player):
    objects, _ = _team(player, 0.5)
    assert objects["light1"]["held_by"] == ["rov1/gripper"]  # held from the start
    assert objects["wrench1"]["held_by"] == [] and objects["wrench1"]["kind"] == "wrench"
    objects, _ = _team(player, 5.0)  # between /tf samples: linear
    w = objects["wrench1"]
    assert (w["north"], w["east"], w["depth"]) == pytest.approx((1.25, 1.5, 10.5))
    assert w["held_by"] == ["diver1/right_hand"]
    assert objects["bag1"]["held_by"] == []  # the failed grasp holds nothing
    objects, _ = _team(player, 8.5)
    assert objects["wrench1"]["held_by"] == ["rov1/gripper"]


def test_site_states_as_the_events_tell(player):
    _, sites = _team(player, 0.5)
    assert sites["flange1"]["text"] == "0/4 bolts out" and sites["flange1"]["cover_on"]
    assert sites["hatch1"]["text"] == "closed" and sites["hatch1"]["angle_deg"] == 0.0
    assert sites["bag1"]["text"] == "not inflated" and sites["bag1"]["litres"] is None
    _, sites = _team(player, 4.5)
    assert sites["flange1"]["text"] == "2/4 bolts out"
    _, sites = _team(player, 6.5)
    assert sites["flange1"]["text"] == "2/4 bolts out, cover off"
    assert sites["hatch1"]["text"] == "opening" and not sites["hatch1"]["open"]
    _, sites = _team(player, 11.0)
    assert sites["hatch1"]["text"] == "open" and sites["hatch1"]["angle_deg"] == 110.0
    # the bag is on the load its event names
    assert sites["bag1"]["text"] == "inflating on valve1"
    assert sites["bag1"]["attached_to"] == "valve1" and sites["bag1"]["litres"] is None
    _, sites = _team(player, 15.0)
    assert sites["bag1"]["text"] == "100/100 L on valve1"
    assert sites["valve1"]["height_m"] == pytest.approx(0.75)  # 11.5 -> 10.75 m deep
    assert sites["crate1"]["height_m"] == 0.0


def test_bag_without_a_named_load_goes_on_the_nearest(player):
    """A recording made before bag_attached named the load: the load nearest the bag."""
    data = player.data
    events = [(t, k, d.replace(" (on valve1)", "")) for t, k, d in data.team_events]
    old = ReplayPlayer(replace(data, team_events=events), _Sink())  # type: ignore[arg-type]
    _, sites = _team(old, 11.0)
    assert sites["bag1"]["attached_to"] == "valve1"  # 0.14 m away; crate1 is 10 m away


def test_recorded_gas_and_lid_angle_are_drawn(player):
    """``team_state`` records (a bag's gas, a hatch lid's angle between closed and open)
    set the sites between the teamwork events, and stay out of the panel's log."""
    from uhrisim.sim.teamwork import site_state_detail

    states = [(6.5, "team_state", site_state_detail("hatch1", "angle", 42.0)),
              (10.5, "team_state", site_state_detail("bag1", "gas", 12.0))]
    data = player.data
    live = ReplayPlayer(replace(data, team_events=sorted(data.team_events + states)),
                        _Sink())  # type: ignore[arg-type]
    _, sites = _team(live, 6.6)
    assert sites["hatch1"]["angle_deg"] == 42.0 and sites["hatch1"]["text"] == "opening"
    _, sites = _team(live, 11.0)
    assert sites["bag1"]["litres"] == 12.0 and sites["bag1"]["text"] == "12/100 L on valve1"
    assert all(e["kind"] != "team_state" for e in live.frame_at(11.0)["team"]["log"])
