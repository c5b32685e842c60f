"""The diver's assistant against a scripted diver in a small kinematic world
(tests/support/assistant_world.py: the real helm with the shipped assistant.bhv, a ROV
point obeying DESIRED_* with a first-order lag, a gripper, a diver who grips).

Each behavior: the task is done as the tree says, the guard distances hold, the speed
near the diver stays under the ceiling, and every tick's decision is traced."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from tests.support.assistant_world import DiverState, Rov, World, hovering
from uhrisim.assistant import (
    Assistant,
    AssistantConfig,
    AssistantInputs,
    DiverTrack,
    GripperStatus,
    RovNav,
)
from uhrisim.assistant.behaviours import GoTo, TreeContext
from uhrisim.assistant.geometry import bearing_deg, jaw_offset, segment_distance
from uhrisim.assistant.trees import CHEST_ABOVE_PELVIS_M
from uhrisim.core.errors import ConfigError
from uhrisim.perception.signals import Command, RecognizedSignal

CFG = AssistantConfig()
DIVER = (6.0, 2.0, 4.0)


def _guards_kept(w: World) -> None:
    body, head = w.min_separation()
    assert body >= CFG.body_guard_m and head >= CFG.head_guard_m, (body, head)


def _slow_near_the_diver(w: World) -> None:
    """Within slow_radius of the diver the helm never asks for more than near_speed
    (ahead or astern), and the ROV — slowing with its speed lag from the ceiling lowered
    slow_lead_m farther out — is within 5 % of it."""
    near = [r for r in w.records if min(r.body, r.head) < CFG.slow_radius_m]
    assert near
    assert max(abs(r.desired_speed) for r in near) <= CFG.near_speed + 1e-9
    assert max(abs(r.speed) for r in near) <= 1.05 * CFG.near_speed


def _tips(w: World) -> list[str]:
    return [a.rsplit("/", 1)[-1] for a in w.actives()]


def test_hand_over_fetches_the_tool_and_the_diver_gets_it():
    w = World(hovering(DIVER, 200.0), tools={"lift_bag": np.array([-3.0, 4.0, 6.0])},
              signals={1.0: Command("bring_tool", "lift_bag")})
    w.run(200, until=lambda w: w.assistant.ctx.task is None and w.t > 2.0)
    w.run(w.t + 1.0)
    assert w.diver_has == {"lift_bag"} and w.phase == "open"
    assert _tips(w) == ["idle", "to the tool", "face the grasp", "creep to the grasp", "grip",
                        "lift clear",
                        "stand off in front", "face him", "creep to his hand",
                        "hold still until he grips", "release", "back away", "done", "idle"]
    assert "handed over lift_bag" in w.events()
    assert "task bring_tool lift_bag done" in w.events()
    commands = [c for out in w.trace for v, c in out.posts if v == "GRIPPER_CMD"]
    assert commands == ["open", "close", "open"]
    _guards_kept(w)
    _slow_near_the_diver(w)
    # the gripper closed with the jaws on the grasp point (the world takes it within 3 cm)
    assert w.trace[-1].task == "idle"


def test_a_missed_grasp_is_tried_again():
    """The tool is nudged 5 cm as the jaws close the first time: the grasp misses, the
    fetch starts over (from a new plan) and the second grip holds it."""
    w = World(hovering(DIVER, 200.0), tools={"wrench": np.array([-2.0, 3.0, 5.0])},
              signals={1.0: Command("bring_tool", "wrench")})
    nudged = []

    def nudge(world: World) -> bool:
        if world.phase == "closing" and not nudged:
            world.tools["wrench"] = world.tools["wrench"] + (0.05, 0.0, 0.0)
            nudged.append(world.t)
        return world.holding == "wrench"

    w.run(200, until=nudge)
    assert nudged and w.holding == "wrench"
    assert "grasp missed: the gripper closed on nothing" in w.events()
    assert _tips(w).count("creep to the grasp") == 2


def test_handover_offered_again_when_the_diver_does_not_take_it():
    """The diver does not take it before 70 s: the ROV holds still for handover_wait_s,
    backs away, and offers again; a later offer is taken."""
    cfg = AssistantConfig(handover_wait_s=10.0)

    def script(t):
        return DiverState(DIVER, 200.0, grips=t > 70.0)

    w = World(script, tools={"hammer": np.array([0.0, 3.0, 4.0])}, config=cfg,
              signals={1.0: Command("bring_tool", "hammer")})
    w.run(250, until=lambda w: "hammer" in w.diver_has and w.assistant.ctx.task is None)
    assert w.diver_has == {"hammer"}
    assert any("gave up after 10 s" in e for e in w.events())
    assert _tips(w).count("creep to his hand") >= 2
    _guards_kept(w)


def test_come_here_holds_at_arms_reach_facing_the_diver():
    w = World(hovering(DIVER, 200.0), signals={1.0: Command("come_here")})
    w.run(90)
    d = np.array(DIVER)
    fwd = np.array([math.cos(math.radians(200.0)), math.sin(math.radians(200.0)), 0.0])
    goal = d + CFG.reach_m * fwd
    assert np.linalg.norm((w.rov.position - goal)[:2]) < 0.15
    assert abs(w.rov.position[2] - (d[2] - 0.3)) < 0.05
    facing = bearing_deg(w.rov.position, d)
    assert abs((w.rov.heading - facing + 180.0) % 360.0 - 180.0) < CFG.heading_tolerance_deg
    assert _tips(w)[-1] == "hold at arm's reach"
    _guards_kept(w)
    _slow_near_the_diver(w)


def test_come_here_goes_round_a_diver_who_faces_away():
    """The ROV starts behind him: it goes round his side to his front, never through him."""
    w = World(hovering((6.0, 0.0, 4.0), 0.0), signals={1.0: Command("come_here")})
    w.run(120)
    assert w.rov.position[0] > 6.5  # in front of him (he faces north)
    _guards_kept(w)


def test_from_close_behind_him_the_rov_rounds_him_on_the_stand_off_circle():
    """The ROV 1.45 m behind him, its stand-off 1.5 m (as in the assisted salvage at
    148 s, bringing the bag): the straight line to the point beside him would pass 1.06 m
    from his body, where his arms reach; it goes round on the stand-off circle instead,
    at least a guard + 0.5 m from his body until it is at his side."""
    w = World(hovering((6.0, 0.0, 4.0), 180.0), signals={1.0: Command("come_here")},
              rov=Rov(np.array([7.45, 0.05, 4.0]), 180.0),
              config=AssistantConfig(standoff_m=1.5))
    w.run(60)
    behind = [r.body for r in w.records if r.rov[0] > 6.0]
    assert min(behind) >= CFG.body_guard_m + 0.5, min(behind)
    assert w.rov.position[0] < 5.5  # in front of him (he faces south)
    _guards_kept(w)


def test_beside_him_holds_only_while_he_stays_where_he_was():
    """The assisted salvage at 144.75-155.7 s: the ROV carrying the bag got beside him
    (heading 66°) as he swam on; he swam 0.9 m farther and the ROV went straight on to
    his new front, 0.77 m past his body, across his arms. Once he has moved on, the
    transit rounds him again: it steers to a point reached on a line that keeps a guard
    + 0.5 m from his body."""
    cfg = AssistantConfig(standoff_m=1.5)
    ctx = TreeContext(cfg)

    def front(c: TreeContext) -> np.ndarray:
        return c.diver.position_ned + cfg.standoff_m * c.diver.forward

    go = GoTo("stand off in front", ctx, front, cfg.cruise_speed)
    go.initialise()

    def steer(rov, diver):
        ctx.inputs = AssistantInputs(0.0, RovNav(np.array(rov), 0.0),
                                     DiverTrack(np.array(diver), 66.0))
        return go.final(ctx), go.target(ctx)

    goal, via = steer((0.07, 1.59, 4.0), (1.44, 0.98, 4.0))  # at his right, 1.5 m out
    np.testing.assert_allclose(via, goal)  # beside him: straight on to his front
    rov, diver = np.array([0.47, 1.79, 4.0]), np.array([1.81, 1.80, 4.0])  # he swam on
    goal, via = steer(rov, diver)
    track = DiverTrack(diver, 66.0)
    line = np.linspace(rov, goal, 50)
    assert min(segment_distance(p, diver, track.neck) for p in line) < 0.8  # the old way
    line = np.linspace(rov, via, 50)
    assert min(segment_distance(p, diver, track.neck) for p in line) >= cfg.body_guard_m + 0.5


def test_follow_trails_the_swimming_diver():
    def swim(t):
        return DiverState((6.0 + 0.3 * t, 0.0, 4.0), 0.0, 0.3)

    w = World(swim, signals={1.0: Command("follow_me")})
    w.run(90)
    d = np.array(swim(w.t).position)
    behind = d - w.rov.position
    assert 2.6 < behind[0] < 3.5 and abs(behind[1]) < 0.5 and abs(behind[2]) < 0.2
    _guards_kept(w)


def test_light_here_holds_camera_and_lamps_on_the_work():
    site = np.array([7.0, 3.0, 5.0])
    w = World(hovering(DIVER, 200.0), sites={"flange": site},
              signals={1.0: Command("light_here", "flange")})
    w.run(90)
    rov = w.rov.position
    assert abs(np.linalg.norm((rov - site)[:2]) - CFG.light_standoff_m) < 0.3
    assert abs((site[2] - rov[2]) - CFG.light_above_m) < 0.05
    facing = bearing_deg(rov, site)
    assert abs((w.rov.heading - facing + 180.0) % 360.0 - 180.0) < CFG.heading_tolerance_deg
    _guards_kept(w)


def test_go_up_rises_and_stop_holds_still():
    w = World(hovering(DIVER, 200.0), signals={1.0: Command("go_up")})
    w.run(40)
    assert abs(w.rov.position[2] - CFG.surface_depth_m) < 0.05
    assert np.linalg.norm(w.rov.position[:2]) < 0.3
    w = World(hovering(DIVER, 200.0), signals={1.0: Command("follow_me"), 12.0: Command("stop")})
    w.run(14)
    here = w.rov.position.copy()
    w.run(40)
    assert np.linalg.norm(w.rov.position - here) < 0.5 and abs(w.rov.speed) < 0.01
    assert w.trace[-1].task == "stop"


def test_a_lost_diver_aborts_the_task_and_the_rov_backs_off():
    """The diver is last seen at 29.75 s: once the track is older than lost_after_s the
    task is aborted (the next tick), the helm is
    parked and the ROV backs astern, facing where he was, to lost_standoff_m; then holds."""
    def script(t):
        return DiverState(DIVER, 200.0, seen=t < 30.0)

    w = World(script, signals={1.0: Command("come_here")})
    w.run(80)
    aborted = [o.t for o in w.trace if "task come_here aborted: the diver track is lost"
               in o.events]
    assert aborted == [29.75 + CFG.lost_after_s + 0.25]
    backing = [r for r in w.records if r.override]
    assert backing and all(r.desired_speed < 0.0 for r in backing)
    assert np.linalg.norm((w.rov.position - DIVER)[:2]) >= CFG.lost_standoff_m - 0.05
    assert _tips(w)[-2:] == ["back off from where he was", "hold, lost"]
    overrides = [(o.t, v) for o in w.trace for k, v in o.posts if k == "MOOS_MANUAL_OVERRIDE"]
    assert [v for _, v in overrides] == ["false", "true", "false"]


def test_a_diver_closing_in_sets_off_the_guard_and_the_rov_backs_away():
    """The diver drifts at 0.1 m/s towards the ROV holding at arm's reach: the ROV backs
    away astern and the guard distances hold."""
    def script(t):
        n = 6.0 - 0.1 * max(0.0, t - 40.0)
        return DiverState((n, 0.0, 4.0), 180.0, 0.1 if t > 40.0 else 0.0)

    w = World(script, signals={1.0: Command("come_here")})
    w.run(80)
    assert any(e.startswith("guard: ") for e in w.events())
    assert any(r.override for r in w.records)
    _guards_kept(w)


@pytest.mark.parametrize("offset_m", [0.0, 0.5])
def test_a_diver_swimming_at_or_past_the_rov_at_0_3_m_s_does_not_break_the_guard(offset_m):
    """The diver swims at 0.3 m/s (a diver's cruising pace) straight at the idle ROV, or
    past it 0.5 m to one side: the guard looks guard_lookahead_s ahead on his track and
    the ROV backs away faster than he comes (docs/hri.md: the 0.50 m of the old
    salvage run, by a diver swimming past at 0.3 m/s)."""
    def script(t):
        n = 6.0 - 0.3 * max(0.0, t - 10.0)
        return DiverState((n, offset_m, 4.0), 180.0, 0.3 if t > 10.0 else 0.0)

    w = World(script)  # the ROV idle at the origin, facing him
    w.run(40)
    assert any(e.startswith("guard: ") for e in w.events())
    _guards_kept(w)


def test_a_diver_who_stops_under_the_idle_rov_and_rises_upright_does_not_break_the_guard():
    """The assisted salvage in 9C water (docs/hri.md): the diver swims prone at 0.3 m/s
    beneath the idle ROV (1 m below it), stops, and rises upright in 2 s to wait — his
    head swings 0.7 m up and back, faster than the ROV gets going from rest. The guards
    keep the ROV clear of him as he would be upright, so it has backed off before (as
    the guards were, his body came within 0.46 m of it)."""
    stop_s, rise_s = 10.0 + 4.0 / 0.3, 2.0

    def script(t):
        east = -4.0 + 0.3 * min(max(0.0, t - 10.0), stop_s - 10.0)
        s = min(1.0, max(0.0, (t - stop_s) / rise_s))
        return DiverState((0.0, east, 4.0), 90.0, 0.3 if 10.0 < t < stop_s else 0.0,
                          lean_deg=45.0 * (1.0 + math.cos(math.pi * s)))

    w = World(script)  # idle at the origin, 1 m above where he stops, facing him
    w.run(stop_s + rise_s + 5.0)
    assert any(e.startswith("guard: ") for e in w.events())
    _guards_kept(w)


def _asks(w: World) -> list[tuple[float, float]]:
    """(t, the diver's horizontal distance ahead, m) of each "say again?" cue."""
    return [(o.t, float(re.search(r"hovering ([0-9.]+) m", e).group(1)))
            for o in w.trace for e in o.events if e.startswith("say again?")]


def test_the_idle_rov_asks_a_hovering_diver_to_say_it_again():
    """Idle, the diver hovering 3 m ahead and nothing read for ask_after_s: the ROV
    closes in to arm's reach (reach_m, within position_tolerance_m), guards kept, then
    shows its "say again?" cue (its heading swung wag_deg off him and back, twice;
    ASSIST_QUERY = say_again meanwhile), ask_max times in a row; a command read starts
    the count again."""
    cfg = AssistantConfig(ask_after_s=5.0)
    w = World(hovering((3.0, 0.0, 3.0), 180.0), config=cfg, signals={40.0: Command("ok")})
    w.run(52)
    asks = [t for t, _ in _asks(w)]
    assert len(asks) == cfg.ask_max + 1, asks
    # closing 1.7 m at near_speed first
    assert asks[0] >= cfg.ask_after_s + 1.7 / cfg.near_speed
    assert asks[cfg.ask_max - 1] < 40.0 <= asks[-1] - 5.0
    assert all(ahead <= cfg.reach_m + cfg.position_tolerance_m for _, ahead in _asks(w))
    queries = [v for o in w.trace for k, v in o.posts if k == "ASSIST_QUERY"]
    assert queries == ["none"] + ["say_again", "none"] * (cfg.ask_max + 1)
    turned = {v for o in w.trace for k, v in o.posts if k == "HEADING_UPDATES"}
    assert {"heading=20", "heading=340"} <= turned  # he is due north: 0°
    assert set(o.task for o in w.trace) == {"idle"}
    _guards_kept(w)
    _slow_near_the_diver(w)


def test_an_rov_already_at_arms_reach_asks_where_it_is():
    """The diver hovering 1.2 m ahead (within reach_m + position_tolerance_m): the cue
    comes after ask_after_s, the ROV not moved."""
    cfg = AssistantConfig(ask_after_s=5.0)
    w = World(hovering((1.2, 0.0, 3.0), 180.0), config=cfg)
    w.run(cfg.ask_after_s + 1.0)
    ((t, ahead),) = _asks(w)
    assert t == pytest.approx(cfg.ask_after_s, abs=0.25) and ahead == 1.2
    _guards_kept(w)


def test_signals_low_confidence_unknown_tool_done_and_repeats():
    a = Assistant()
    rov = RovNav((0.0, 0.0, 3.0), 0.0)
    diver = DiverTrack((6.0, 0.0, 4.0), 180.0)

    def tick(t, *signals):
        return a.step(AssistantInputs(t, rov, diver, GripperStatus(), signals,
                                      tools={"wrench": np.array([3.0, 3.0, 6.0])}))

    def sig(text, confidence=0.9, channel="marker"):
        return RecognizedSignal(Command.parse(text), channel, confidence, 0.0)

    out = tick(0.0, sig("follow_me", 0.4))
    assert out.task == "idle" and out.events == (
        "ignored follow_me (marker, confidence 0.40): below 0.6",)
    out = tick(0.25, sig("bring_tool crowbar"))
    assert out.task == "idle" and "no tool 'crowbar' on the map" in out.events[0]
    out = tick(0.5, sig("come_here", channel="gesture"))
    assert out.task == "come_here"
    assert ("ASSIST_TASK", "come_here") in out.posts
    out = tick(0.75, sig("come_here"))
    assert out.events == ()  # the same command again: nothing restarts
    out = tick(1.0, sig("done"))
    assert out.task == "idle" and out.events[0].startswith("task come_here done")
    out = tick(1.25, sig("bring_tool wrench"))
    assert out.task == "bring_tool wrench" and out.gripper_command == "open"


def test_a_channel_it_does_not_obey_is_logged_not_acted_on():
    a = Assistant(AssistantConfig(obey=("marker",)))
    rov, diver = RovNav((0.0, 0.0, 3.0), 0.0), DiverTrack((6.0, 0.0, 4.0), 180.0)

    def tick(t, channel):
        signal = RecognizedSignal(Command("come_here"), channel, 1.0, t)
        return a.step(AssistantInputs(t, rov, diver, GripperStatus(), (signal,)))

    out = tick(0.0, "gesture")
    assert out.task == "idle" and out.events == (
        "ignored come_here (gesture, confidence 1.00): this ROV obeys marker only",)
    assert tick(0.25, "marker").task == "come_here"


def test_default_task_follow_me():
    a = Assistant(AssistantConfig(default_task="follow_me"))
    out = a.step(AssistantInputs(0.0, RovNav((0.0, 0.0, 3.0), 0.0),
                                 DiverTrack((6.0, 0.0, 4.0), 0.0)))
    assert out.task == "follow_me" and ("ASSIST_MODE", "FOLLOW") in out.posts


def test_decisions_are_traced_and_reproducible():
    """Every tick has its active path and postings; the same world twice, the same trace."""
    def run():
        return World(hovering(DIVER, 200.0), tools={"lift_bag": np.array([-3.0, 4.0, 6.0])},
                     signals={1.0: Command("bring_tool", "lift_bag")}).run(60)

    first, second = run(), run()
    assert len(first.trace) == 240  # 4 Hz for 60 s
    assert all(o.active.startswith("assistant/decide/") for o in first.trace)
    assert [(o.t, o.posts, o.active, o.events) for o in first.trace] == [
        (o.t, o.posts, o.active, o.events) for o in second.trace]
    # the posts are changes only: a variable is posted again only with a new value
    last: dict[str, object] = {}
    for o in first.trace:
        for var, value in o.posts:
            if not var.startswith("DESIRED_"):
                assert last.get(var) != value
            last[var] = value


def test_jaws_are_where_the_gripper_is():
    np.testing.assert_allclose(jaw_offset(90.0, CFG), (0.0, 0.25, 0.14), atol=1e-12)


@pytest.mark.parametrize("kw, message", [
    (dict(obey=("marker", "semaphore")), "assistant.obey: must be a list of one or more of"),
    (dict(body_guard_m=0.0), "assistant.body_guard_m: must be a finite number > 0"),
    (dict(clearance_m=0.05), "assistant.clearance_m: must exceed trigger_margin_m"),
    (dict(default_task="bring_tool"), "assistant.default_task: must be idle or a command"),
    (dict(fetch_attempts=0), "assistant.fetch_attempts: must be an integer >= 1"),
    (dict(watch_range_m=1.2), "assistant.watch_range_m: must exceed the larger guard"),
    (dict(watch_range_m=-3.0), "assistant.watch_range_m: must be a finite number > 0"),
])
def test_bad_parameters_are_one_line_errors(kw, message):
    with pytest.raises(ConfigError, match=message):
        AssistantConfig(**kw)
    with pytest.raises(ConfigError, match=re.escape(message.replace("assistant.",
                                                                     "agents[1].assistant."))):
        AssistantConfig.from_mapping(kw, "agents[1].assistant")
    with pytest.raises(ConfigError, match=r"assistant: unknown parameter\(s\) \['speed'\]"):
        AssistantConfig.from_mapping({"speed": 1})


@pytest.mark.parametrize("north_m", [1.6, 6.0])
def test_the_idle_rov_watches_the_diver_from_watch_range_level_with_his_chest(north_m):
    """With ``watch_range_m`` the idle ROV keeps that far from the diver, at his chest's
    depth, facing him all the while — the view the gesture reader was fitted on
    (docs/hri.md: the assisted salvage's gestures, unread from 1.2-2 m and 0.6 m above
    him, and from a ROV that turned away to reach its point); without it, it holds
    where it is."""
    cfg = AssistantConfig(watch_range_m=3.0, ask_after_s=1000.0)
    diver = (north_m, 0.0, 4.0)  # 1 m below the ROV, facing it
    w = World(hovering(diver, 180.0), config=cfg)
    off_him: list[float] = []
    w.run(40.0, until=lambda w: off_him.append(abs(
        (w.rov.heading - bearing_deg(w.rov.position, np.array(diver)) + 180.0) % 360.0
        - 180.0)) and False)
    ahead = math.hypot(*(np.array(diver) - w.rov.position)[:2])
    assert ahead == pytest.approx(3.0, abs=cfg.position_tolerance_m / 3.0)
    assert w.rov.position[2] == pytest.approx(4.0 - CHEST_ABOVE_PELVIS_M, abs=0.05)
    assert max(off_him) <= cfg.heading_tolerance_deg
    assert {o.task for o in w.trace} == {"idle"}
    _guards_kept(w)
    still = World(hovering(diver, 180.0), config=AssistantConfig(ask_after_s=1000.0))
    still.run(20.0)
    assert np.allclose(still.rov.position, [0.0, 0.0, 3.0], atol=0.05)
