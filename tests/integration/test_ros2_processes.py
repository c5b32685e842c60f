"""ROS 2 bridge against separate processes (plain rclpy scripts in tests/support/).

The simulation is a small stand-in loop (100 Hz ticks paced to the wall clock by
``Pacer``) that publishes a known NED pose; the lead's end-to-end test with the real
simulation comes on top of this. Every process runs with loopback-only discovery and
a private random domain id. Expected numbers:

* frames: NED (north 3, east 4, depth 2), heading 90 deg -> ENU (4, 3, -2), q = identity;
* rates: 10 Hz odometry and 15 Hz sonar set by the bridge's rate gates in sim time,
  sim paced at real time, so the receive rate is 10 / 15 Hz of wall time too;
* commands published by a second process come out of ``commands()``, then go stale
  ``command_timeout_s`` (sim) after the publisher stops;
* a SIGKILLed subscriber does not slow or block the publishing loop.
"""

from __future__ import annotations

import math
import os
import secrets
import signal
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from tests.support.children import Child
from uhrisim.bridges.ros2 import AgentBridgeSpec, Pacer, Ros2Bridge

DT = 0.01  # stand-in physics tick (s)
ODOM_HZ, SONAR_HZ = 10.0, 15.0
POS_NED = np.array([3.0, 4.0, 2.0])
YAW = math.pi / 2  # heading 90 deg: facing east
VEL_FRD = np.array([0.5, 0.0, 0.0])
YAW_RATE = 0.1
POLAR = (np.arange(512 * 256, dtype=np.int64) % 253).astype(np.uint8).reshape(512, 256)
FAN = np.full((300, 400), 7, dtype=np.uint8)
PTS_FRD = np.array([[5.0, 1.0, 0.5], [6.0, -2.0, 0.25]] * 100)
INTENSITY = np.linspace(0.0, 1.0, 200)


@dataclass
class LoopResult:
    t_end: float
    wall_s: float
    max_call_s: float
    sim_over_wall: float


def run_loop(bridge: Ros2Bridge, agent: str, t0: float, duration: float,
             on_tick=None) -> LoopResult:
    """Stand-in simulation: 100 Hz ticks paced at real time, writing the known pose and
    sonar products whenever the bridge's rate gates say they are due (10 / 15 Hz)."""
    pacer = Pacer(1.0)
    pacer.reset(t0)
    n = round(duration / DT)
    max_call = 0.0
    w0 = time.monotonic()
    for k in range(n):
        t = t0 + k * DT
        c0 = time.perf_counter()
        bridge.write_clock(t)
        if bridge.odometry_due(agent, t):
            bridge.write_odometry(agent, t, POS_NED, YAW, VEL_FRD, YAW_RATE)
        if bridge.sonar_due(agent, "sonar", t):
            bridge.write_sonar(agent, "sonar", t, POLAR, FAN, PTS_FRD, INTENSITY,
                               (POS_NED, np.eye(3)))
        max_call = max(max_call, time.perf_counter() - c0)
        if on_tick is not None:
            on_tick(t)
        pacer.wait(t0 + (k + 1) * DT)
    wall = time.monotonic() - w0
    return LoopResult(t0 + n * DT, wall, max_call, n * DT / wall)


def _make_bridge(domain: int, reliable_sensors: bool = False) -> tuple[Ros2Bridge, str]:
    agent = f"rov_{secrets.token_hex(3)}"
    b = Ros2Bridge(
        [AgentBridgeSpec(agent, sonar_rate_hz=SONAR_HZ, odom_rate_hz=ODOM_HZ)],
        node_name=f"uhrisim_{agent}",
        domain_id=domain,
        command_timeout_s=1.0,
        reliable_sensors=reliable_sensors,
    )
    b.start()
    return b, agent


def _wait_for_subscribers(bridge: Ros2Bridge, topics: list[str], timeout: float = 120.0) -> None:
    assert bridge.wait_for_subscribers(topics, timeout), f"no subscriber on {topics}"


def _topics(agent: str) -> list[str]:
    return [f"/{agent}/odom", f"/{agent}/pose", f"/{agent}/sonar/polar",
            f"/{agent}/sonar/fan", f"/{agent}/sonar/points"]


def test_external_subscriber_rates_and_frames(ros_env: int, tmp_path: Path) -> None:
    bridge, agent = _make_bridge(ros_env)
    child = Child("ros2_listener.py", ["--agent", agent], tmp_path)
    try:
        child.expect("READY")
        _wait_for_subscribers(bridge, _topics(agent))
        before = bridge.stats()["published"]
        loop = run_loop(bridge, agent, t0=0.0, duration=2.0)
        after = bridge.stats()["published"]
        sent = {t: after.get(t, 0) - before.get(t, 0) for t in _topics(agent)}
        rec = child.result(counts=sent)  # once the messages in flight are in
    finally:
        child.finish()
        bridge.close()
    # rate gates on 200 ticks of 0.01 s: odom at t = 0, 0.1, ..., 1.9 (20); sonar 30
    assert sent[f"/{agent}/odom"] == 20 and sent[f"/{agent}/sonar/polar"] == 30
    assert loop.sim_over_wall > 0.8  # the paced loop kept (nearly) real time

    for topic, rate in [(f"/{agent}/odom", ODOM_HZ), (f"/{agent}/pose", ODOM_HZ),
                        (f"/{agent}/sonar/polar", SONAR_HZ), (f"/{agent}/sonar/fan", SONAR_HZ),
                        (f"/{agent}/sonar/points", SONAR_HZ)]:
        r = rec[topic]
        n = len(r["stamp"])
        reliable = topic.endswith(("odom", "pose"))
        # reliable topics lose nothing after matching; best effort over loopback ~nothing
        assert n >= (sent[topic] if reliable else 0.9 * sent[topic]), (topic, n, sent[topic])
        stamps = np.array(r["stamp"])
        assert np.all(np.diff(stamps) > 0)  # in order, no duplicates
        # sim-time spacing: exactly 1/rate on average (first..last over the gaps)
        assert (stamps[-1] - stamps[0]) / (n - 1) == pytest.approx(1.0 / rate, rel=0.05)
        # wall-clock receive rate of the external process, paced sim: within 15 %
        wall = np.array(r["wall"])
        assert (n - 1) / (wall[-1] - wall[0]) == pytest.approx(rate, rel=0.15)

    odom = rec[f"/{agent}/odom"]["first"]
    assert odom["frame_id"] == f"{agent}/odom" and odom["child_frame_id"] == f"{agent}/base_link"
    assert odom["stamp"] == [0, 0]
    np.testing.assert_allclose(odom["position"], [4.0, 3.0, -2.0], atol=1e-12)
    np.testing.assert_allclose(odom["orientation"], [0.0, 0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(odom["linear"], [0.5, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(odom["angular"], [0.0, 0.0, -0.1], atol=1e-12)
    pose = rec[f"/{agent}/pose"]["first"]
    np.testing.assert_allclose(pose["position"], [4.0, 3.0, -2.0], atol=1e-12)
    assert pose["frame_id"] == "map"

    polar = rec[f"/{agent}/sonar/polar"]["first"]
    assert (polar["height"], polar["width"], polar["step"]) == (512, 256, 256)
    assert polar["encoding"] == "mono8" and polar["frame_id"] == f"{agent}/sonar"
    assert polar["checksum"] == int(POLAR.sum(dtype=np.int64) % 1_000_003)
    fan = rec[f"/{agent}/sonar/fan"]["first"]
    assert (fan["height"], fan["width"], fan["nbytes"]) == (300, 400, 120_000)
    pts = rec[f"/{agent}/sonar/points"]["first"]
    assert pts["width"] == 200 and pts["point_step"] == 16
    assert pts["fields"] == [["x", 0, 7], ["y", 4, 7], ["z", 8, 7], ["intensity", 12, 7]]
    # first FRD point (5, 1, 0.5) -> FLU (5, -1, -0.5), intensity 0
    np.testing.assert_allclose(pts["first_point"], [5.0, -1.0, -0.5, 0.0])


def test_external_commands_then_stale(ros_env: int, tmp_path: Path) -> None:
    bridge, agent = _make_bridge(ros_env)
    child = Child(
        "ros2_commander.py",
        ["--agent", agent, "--heading", "45", "--speed", "0.5", "--depth", "3",
         "--thrusters", "10", "-20", "30", "--rate", "20", "--duration", "1.0"],
        tmp_path,
    )
    seen: list[tuple[float, object]] = []
    done_at: list[float] = []

    def on_tick(t: float) -> None:
        seen.append((t, bridge.commands(agent, t)))
        if not done_at and child.poll_line("DONE") is not None:
            done_at.append(t)

    try:
        child.expect("READY")
        run_loop(bridge, agent, t0=0.0, duration=2.8, on_tick=on_tick)
        assert child.finish() == 0
    finally:
        child.finish()
        bridge.close()
    assert done_at, "commander never finished"
    fresh = [c for _, c in seen if c.thrusters is not None]
    # 1.0 s of 20 Hz commands, ~1.0 s of paced sim time: well over 50 ticks see them all
    complete = [c for c in fresh if c.has_desired and None not in (
        c.desired_heading_deg, c.desired_speed, c.desired_depth)]
    assert len(complete) > 50
    for c in fresh:  # each field ages on its own; one published a moment earlier
        assert c.desired_heading_deg in (None, 45.0) and c.desired_speed in (None, 0.5)
        assert c.desired_depth in (None, 3.0) and c.thrusters == (10.0, -20.0, 30.0)
        assert not c.stale
    # receipt (sim) time of each fresh command = t - age; the last one came before DONE
    last_rx = max(t - c.age_s for t, c in seen if c.thrusters is not None)
    assert done_at[0] - 0.25 <= last_rx <= done_at[0] + DT  # 20 Hz sender, polled per tick
    # stale from the first tick more than command_timeout_s (1.0 s sim) after it, for good
    first_stale = min(t for t, c in seen if c.stale)
    assert 1.0 < first_stale - last_rx <= 1.0 + DT + 1e-9
    after = [c for t, c in seen if t >= first_stale]
    assert all(c.stale and c.desired_speed is None and c.thrusters is None for c in after)
    assert all(c.age_s > 1.0 for c in after)


@pytest.mark.parametrize("reliable_sensors", [False, True], ids=["best_effort", "reliable"])
def test_killed_subscriber_does_not_block(ros_env: int, tmp_path: Path,
                                          reliable_sensors: bool) -> None:
    bridge, agent = _make_bridge(ros_env, reliable_sensors=reliable_sensors)
    qos = "reliable" if reliable_sensors else "best_effort"
    child = Child("ros2_listener.py", ["--agent", agent, "--sensor-qos", qos], tmp_path)
    try:
        child.expect("READY")
        _wait_for_subscribers(bridge, _topics(agent))
        first = run_loop(bridge, agent, t0=0.0, duration=0.5)
        os.kill(child.proc.pid, signal.SIGKILL)
        assert child.finish() == -signal.SIGKILL
        before = bridge.stats()["published"]
        second = run_loop(bridge, agent, t0=first.t_end, duration=2.0)
        after = bridge.stats()["published"]
    finally:
        child.finish()
        bridge.close()
    # every due message went out after the kill: 20 odom and 30 (+-1 for the tick
    # grid) sonar in 2 s of sim
    assert after[f"/{agent}/odom"] - before[f"/{agent}/odom"] == 20
    assert abs(after[f"/{agent}/sonar/polar"] - before[f"/{agent}/sonar/polar"] - 30) <= 1
    # the loop kept (nearly) real time and no publish call blocked
    assert second.sim_over_wall > 0.8, second
    assert second.max_call_s < 0.25, second


def test_docs_example_node_drives_rov_to_point(ros_env: int, tmp_path: Path) -> None:
    """The example node of docs/bridges-ros2.md closes the loop through the bridge.

    A stand-in kinematic vehicle (NED, compass yaw; turn rate <= 60 deg/s, speed lag
    0.5 s, depth rate <= 0.5 m/s) follows ``commands()``; a missing or stale command
    means stop and hold depth. The node, which sees only ENU odometry, is sent to
    ENU (x 6, y 8) = 6 m east, 8 m north, depth 2 m: a frame mix-up anywhere would
    send the vehicle elsewhere."""
    agent = f"rov_{secrets.token_hex(3)}"
    bridge = Ros2Bridge([AgentBridgeSpec(agent, sonars=(), odom_rate_hz=20.0)],
                        domain_id=ros_env, command_timeout_s=1.0)
    bridge.start()
    child = Child("ros2_goto_point.py", ["--agent", agent, "--x", "6", "--y", "8",
                                         "--depth", "2", "--hold", "0.3"], tmp_path)
    n = e = d = psi = u = 0.0
    dt, t = 0.05, 0.0
    pacer = Pacer(5.0)
    pacer.reset(0.0)
    arrived_t = exit_t = first_cmd_t = None
    try:
        while t < 90.0:  # discovery may take a few wall seconds (x5 in sim time)
            c = bridge.commands(agent, t)
            if first_cmd_t is None and c.received:
                first_cmd_t = t
            if c.stale or c.desired_speed is None:
                u_des, d_des, hd = 0.0, d, None
            else:
                u_des = c.desired_speed
                d_des = d if c.desired_depth is None else c.desired_depth
                hd = c.desired_heading_deg
            if hd is not None:
                err = (math.radians(hd) - psi + math.pi) % (2 * math.pi) - math.pi
                psi += max(-math.radians(60) * dt, min(math.radians(60) * dt, err))
            u += (u_des - u) * dt / 0.5
            d += max(-0.5 * dt, min(0.5 * dt, d_des - d))
            n += u * math.cos(psi) * dt
            e += u * math.sin(psi) * dt
            t += dt
            bridge.write_clock(t)
            if bridge.odometry_due(agent, t):
                bridge.write_odometry(agent, t, [n, e, d], psi, [u, 0.0, 0.0], 0.0)
            if arrived_t is None and child.poll_line("ARRIVED") is not None:
                arrived_t = t
            if exit_t is None and child.proc.poll() is not None:
                exit_t = t
            if exit_t is not None and t > exit_t + 1.5:
                break
            pacer.wait(t)
        final = bridge.commands(agent, t)
    finally:
        rc = child.finish()
        bridge.close()
    assert rc == 0 and arrived_t is not None, child.stderr_path.read_text()[-2000:]
    # a 10 m straight run at <= 1 m/s, plus the turn and the slow-down
    assert first_cmd_t is not None and 10.0 < arrived_t - first_cmd_t < 30.0
    assert math.hypot(n - 8.0, e - 6.0) < 1.0
    assert d == pytest.approx(2.0, abs=0.05)
    # the node exited: its commands went stale and the safe stop took the speed to ~0
    assert final.stale and abs(u) < 0.05
