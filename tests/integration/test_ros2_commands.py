"""Commands from a separate plain-rclpy process are checked against the vehicle's envelope,
and a stale thruster command stops the ROV without turning (issue 16).

The simulation (scenarios/ros2_external_helm.yaml: the VideoRay, no helm of its own,
10 m flat floor) runs here, paced at real time, with the ROS 2 hook; the commands come
from tests/support/ros2_command_plan.py in its own process. Expected numbers: the
VideoRay's top speed is its thrust-drag balance at full forward thrust
(``command_envelope``), the deepest allowed depth the 10 m floor less the 0.5 m default
clearance.
"""

from __future__ import annotations

import json
import math
import queue
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from tests.support.children import Child
from uhrisim.bridges.ros2.hook import DEPTH_CLEARANCE_M, Ros2BridgeHook, command_envelope
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.pacing import Pacer
from uhrisim.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "ros2_external_helm.yaml"
FLOOR_DEPTH = 10.0  # m, the scenario's flat floor


def _fly(ros_env: int, tmp_path: Path, plan: list, node: str, after_done_s: float,
         rosout: bool = False, timeout_s: float = 1.0):
    """Run the scenario paced at real time while the plan is published; go on
    ``after_done_s`` simulated seconds after the commander is done. Returns the hook,
    the frames' (t, nav, desired) and the commander's stdout lines."""
    hook = Ros2BridgeHook(domain_id=ros_env, node_name=node,
                          command_timeout_s=timeout_s)
    sim = Simulation(load_scenario(SCENARIO), raycast_sensors=False, hooks=[hook])
    args = ["--agent", "videoray", "--plan", json.dumps(plan), "--bridge-node", node]
    commander = Child("ros2_command_plan.py", [*args, "--rosout"] if rosout else args,
                      tmp_path)
    track = []
    lines: list[str] = []

    def seen(prefix: str) -> bool:  # every line kept, for the /rosout ones
        while True:
            try:
                line = commander.lines.get_nowait()
            except queue.Empty:
                return any(x.startswith(prefix) for x in lines)
            if line is not None:
                lines.append(line)

    try:
        sim.start()
        pacer = Pacer(real_time_factor=1.0)
        pacer.reset(sim.t)
        ready = done = None
        deadline = time.monotonic() + 600.0  # the commander's start and discovery: a busy
        while True:  # machine takes its time; the plan runs on the simulation's clock
            assert time.monotonic() < deadline and commander.proc.poll() in (None, 0), \
                f"the commander never finished: {commander.stderr_path.read_text()[-2000:]}"
            frame = sim.step()
            snap = frame.agents["videoray"]
            track.append((frame.t, snap.nav, (snap.desired_heading_deg, snap.desired_speed,
                                              snap.desired_depth)))
            pacer.wait(frame.t)
            if ready is None and seen("READY"):
                ready = frame.t
            if ready is not None and done is None and seen("DONE"):
                done = frame.t
            if done is not None and frame.t > done + after_done_s:
                break
        assert commander.finish(timeout=60.0) == 0
        seen("")
    finally:
        sim.close()
        if commander.proc.poll() is None:
            commander.proc.kill()
    return hook, sim, track, lines


def test_bad_commands_are_refused_or_clamped_counted_and_on_rosout(ros_env: int,
                                                                  tmp_path: Path) -> None:
    """1e6 m/s and 1e6 m are clamped to the envelope; -5 m/s, NaN and thruster arrays of
    the wrong length are refused; all counted per topic and reason, and reported on
    /rosout (rate-limited). The ROV stays controlled: it turns to the commanded 45 deg and
    dives, no faster than it can and no deeper than the floor less the clearance."""
    plan = [[4.0, {"desired_heading": [45.0, math.nan], "desired_speed": [1e6, -5.0],
                   "desired_depth": [1e6], "thrusters": [[1.0, 2.0], [1.0, math.nan, 2.0]]}]]
    hook, sim, track, lines = _fly(ros_env, tmp_path, plan, "uhrisim_cmd_test", 3.0,
                                   rosout=True)
    envelope = command_envelope(sim.agents["videoray"])
    assert 1.0 < envelope.max_speed < 2.5 and not envelope.reverse  # VideoRay Pro 4
    stats = hook.summary()["ros2"]
    reasons = stats["command_rejections"]
    assert set(reasons["/videoray/cmd/desired_speed"]) == {
        "outside the speed envelope", "negative speed (the controller cannot reverse)"}
    assert set(reasons["/videoray/cmd/desired_heading"]) == {"not finite"}
    assert set(reasons["/videoray/cmd/desired_depth"]) == {
        "below the floor less the clearance"}
    assert set(reasons["/videoray/cmd/thrusters"]) == {"wrong length", "not finite"}
    n_refused = sum(n for topic in reasons.values() for why, n in topic.items()
                    if why in ("not finite", "wrong length") or why.startswith("negative"))
    assert stats["rejected_commands"] == n_refused > 4 * 20  # ~20 Hz for 4 s, 4 kinds
    assert stats["clamped_commands"] == sum(n for t in reasons.values()
                                            for n in t.values()) - n_refused

    # what reached the simulation: the clamped values, never the refused ones
    desired = np.array([d for _, _, d in track])
    commanded = desired[np.argmax(desired[:, 1] > 0)]
    assert commanded[0] == pytest.approx(45.0)
    assert commanded[1] == pytest.approx(envelope.max_speed)
    assert commanded[2] == pytest.approx(FLOOR_DEPTH - DEPTH_CLEARANCE_M)
    assert np.all(np.isfinite(desired)) and desired[:, 1].min() >= 0.0
    # controlled: heading on 45 deg, never faster than the envelope, never below the floor
    heading = np.array([math.degrees(nav.yaw) % 360.0 for _, nav, _ in track])
    surge = np.array([nav.velocity_body[0] for _, nav, _ in track])
    depth = np.array([nav.position_ned[2] for _, nav, _ in track])
    assert surge.max() <= envelope.max_speed * 1.001  # (thruster coupling: a hair over)
    assert depth.max() < FLOOR_DEPTH - DEPTH_CLEARANCE_M + 0.05
    in_force = np.array([d[1] > 0 for _, _, d in track])
    t = np.array([t for t, _, _ in track])
    late = in_force & (t > t[in_force][0] + 3.0)
    assert late.any() and np.abs(heading[late] - 45.0).max() < 5.0

    # on /rosout, from the bridge's node, rate-limited: in 4 s one line per topic and
    # reason (then one every 5 s), not one per rejection
    rosout = [line for line in lines if line.startswith("ROSOUT") and "command on " in line]
    assert any("/videoray/cmd/desired_speed refused: negative speed" in x for x in rosout)
    assert any("/videoray/cmd/thrusters refused: wrong length" in x for x in rosout)
    assert any("/videoray/cmd/desired_depth clamped: below the floor" in x for x in rosout)
    assert all(line.split()[1] == "30" for line in rosout)  # WARN
    assert len(rosout) == sum(len(t) for t in reasons.values()) == 6


def test_stale_thruster_command_stops_without_turning(ros_env: int, tmp_path: Path) -> None:
    """Thrusters turn the ROV away from its start heading (90 deg, still its DESIRED_HEADING)
    and then drive it straight; when the commander stops, the safe stop holds the heading
    of that moment: the yaw rate stays under 0.1 rad/s while the ROV stops at its depth."""
    plan = [[0.8, {"thrusters": [[60.0, -60.0, 0.0]]}], [2.0, {"thrusters": [[80.0, 80.0, 0.0]]}]]
    _hook, sim, track, _ = _fly(ros_env, tmp_path, plan, "uhrisim_stale_test", 6.0)
    events = [e for e in sim.events_log if e.kind == "bridge" and "safe stop" in e.detail]
    assert len(events) == 1
    t_stale = events[0].t
    t = np.array([t for t, _, _ in track])
    yaw_rate = np.array([nav.yaw_rate for _, nav, _ in track])
    heading = np.array([math.degrees(nav.yaw) % 360.0 for _, nav, _ in track])
    surge = np.array([nav.velocity_body[0] for _, nav, _ in track])
    at_stale = np.searchsorted(t, t_stale)
    assert abs(heading[at_stale] - 90.0) > 20.0  # turned well away from the old heading
    before = (t > t_stale - 1.0) & (t < t_stale)  # driving straight, and going
    assert surge[before].min() > 0.3
    after = t >= t_stale
    assert np.abs(yaw_rate[after]).max() < 0.1
    assert abs(heading[-1] - heading[at_stale]) < 2.0
    assert abs(surge[-1]) < 0.1  # stopped
    desired = track[-1][2]
    assert desired[0] == pytest.approx(heading[at_stale], abs=0.5) and desired[1] == 0.0


def _lapse(sim: Simulation, topic: str) -> float:
    """The simulated time (s) of the one ``bridge`` event saying nothing was accepted on
    ``/videoray/cmd/<topic>``."""
    times = [e.t for e in sim.events_log
             if e.kind == "bridge" and f"/videoray/cmd/{topic}" in e.detail]
    assert len(times) == 1, [e.detail for e in sim.events_log]
    return times[0]


def _rosout_says(lines: list[str], *words: str) -> bool:
    return any(line.startswith("ROSOUT 30") and all(w in line for w in words)
               for line in lines)


@pytest.mark.parametrize("case", ["refused", "stopped", "never"])
def test_speed_ages_on_its_own(ros_env: int, tmp_path: Path, case: str) -> None:
    """Heading and depth stay fresh while the speed is refused (-5 m/s: the VideoRay
    cannot reverse), stops being sent, or was never sent: one command timeout (1 s
    simulated) after the last speed accepted (or the first command) the desired speed
    is 0 and the ROV slows to a stop, said in the recording and on /rosout."""
    fresh = {"desired_heading": [90.0], "desired_depth": [2.0]}
    go = [1.5, {**fresh, "desired_speed": [0.8]}]
    plans = {"refused": [go, [4.0, {**fresh, "desired_speed": [-5.0]}]],
             "stopped": [go, [4.0, fresh]],
             "never": [[4.0, fresh]]}
    _hook, sim, track, lines = _fly(ros_env, tmp_path, plans[case], f"uhrisim_speed_{case}",
                                   0.5, rosout=True)
    t_lapse = _lapse(sim, "desired_speed")
    assert not any("safe stop" in e.detail for e in sim.events_log if e.t < t_lapse + 1.0)
    t = np.array([t for t, _, _ in track])
    desired = np.array([d for _, _, d in track])
    surge = np.array([nav.velocity_body[0] for _, nav, _ in track])
    after = t > t_lapse + 1.0 / 20.0  # the fallback acts on the next tick
    assert np.all(desired[after, 1] == 0.0)
    if case != "never":
        moving = t < t_lapse - 0.5
        assert desired[moving, 1].max() == pytest.approx(0.8) and surge.max() > 0.3
        accepted = [e.t for e in sim.events_log if "external commands active" in e.detail]
        assert 0.9 < t_lapse - (accepted[0] + 1.5) < 1.4  # 1 s after the last 0.8 m/s
    assert surge[-1] < surge[np.searchsorted(t, t_lapse)] - 0.1 or surge.max() < 0.05
    assert np.all(np.abs(desired[after, 0] - 90.0) < 1e-9)  # the others still in force
    assert _rosout_says(lines, "/videoray/cmd/desired_speed", "speed 0")


@pytest.mark.parametrize(("topic", "sent_s", "timeout_s"),
                         [("desired_heading", 0.2, 0.5), ("desired_depth", 1.5, 1.0)])
def test_heading_and_depth_hold_where_they_are(ros_env: int, tmp_path: Path, topic: str,
                                               sent_s: float, timeout_s: float) -> None:
    """The ROV turns to 260 deg (from 90) or dives to 6 m (from 2); the heading or depth
    then stops being sent while the rest stays fresh: one timeout later (0.5 s for the
    heading: the ROV turns fast) the desired
    heading or depth is the vehicle's own at that moment (not the old target), and it
    holds there; said in the recording and on /rosout."""
    target = {"desired_heading": 260.0, "desired_depth": 6.0}
    fresh = {"desired_heading": [90.0], "desired_speed": [0.3], "desired_depth": [2.0]}
    fresh[topic] = [target[topic]]
    rest = {k: v for k, v in fresh.items() if k != topic}
    plan = [[sent_s, fresh], [5.0, rest]]  # it turns or dives, then holds
    _hook, sim, track, lines = _fly(ros_env, tmp_path, plan, f"uhrisim_hold_{topic}",
                                    0.5, rosout=True, timeout_s=timeout_s)
    t_lapse = _lapse(sim, topic)
    t = np.array([t for t, _, _ in track])
    column = {"desired_heading": 0, "desired_depth": 2}[topic]
    desired = np.array([d[column] for _, _, d in track])
    if topic == "desired_heading":
        actual = np.array([math.degrees(nav.yaw) % 360.0 for _, nav, _ in track])
        unit = "deg"
    else:
        actual = np.array([nav.position_ned[2] for _, nav, _ in track])
        unit = "m"
    at = np.searchsorted(t, t_lapse)
    held = desired[np.searchsorted(t, t_lapse + 0.1)]
    assert held == pytest.approx(actual[at], abs=0.1)  # where it was, to the log's digits
    start = {"desired_heading": 90.0, "desired_depth": 2.0}[topic]
    assert abs(held - start) > 0.1 * abs(target[topic] - start)  # it had moved ...
    assert abs(held - target[topic]) > 0.1 * abs(target[topic] - start)  # ... not arrived
    t_end = min((e.t for e in sim.events_log if "safe stop" in e.detail),  # commander ends
                default=math.inf)
    after = (t > t_lapse + 0.1) & (t < t_end)
    assert np.all(desired[after] == held)
    tolerance = {"desired_heading": 15.0, "desired_depth": 0.6}[topic]
    assert abs(actual[-1] - held) < tolerance  # it stays near where it was
    assert _rosout_says(lines, f"/videoray/cmd/{topic}", f"hold {topic.split('_')[1]}", unit)
