"""ROS 2 bridge in one process: a probe node in its own rclpy Context talks to the
bridge over DDS (loopback only, private domain). Checks message contents against
hand-worked frame conversions, the command path (validation, clipping, timeout in
simulation time) and the error paths."""

from __future__ import annotations

import json
import math
import os
import secrets
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.context import Context  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from rclpy.signals import SignalHandlerOptions  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray, String  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from uhrisim.bridges.ros2 import AgentBridgeSpec, Ros2Bridge  # noqa: E402
from uhrisim.core.errors import BridgeError, ConfigError  # noqa: E402


@pytest.fixture(scope="module")
def agent() -> str:
    # A unique namespace, so a run that happens to draw the same domain id never mixes.
    return f"rov_{secrets.token_hex(3)}"


@pytest.fixture(scope="module")
def bridge(ros_env: int, agent: str):
    b = Ros2Bridge(
        [AgentBridgeSpec(agent, odom_rate_hz=None, sonar_rate_hz=None)],
        node_name=f"uhrisim_{agent}",
        domain_id=ros_env,
        command_timeout_s=1.0,
    )
    b.start()
    yield b
    b.close()


class Probe:
    """A plain rclpy node in its own context, spun by hand."""

    def __init__(self, domain: int) -> None:
        self.ctx = Context()
        rclpy.init(
            context=self.ctx, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO
        )
        self.node = rclpy.create_node("probe", context=self.ctx, start_parameter_services=False)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)
        self.got: dict[str, list] = {}

    def sub(self, typ, topic: str, qos=10) -> None:
        self.got[topic] = []
        self.node.create_subscription(typ, topic, self.got[topic].append, qos)

    def spin_until(self, cond: Callable[[], bool], timeout: float = 120.0) -> bool:
        """Spin until ``cond()``; the bound is only against a hang (DDS discovery on a
        busy machine: seconds)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if cond():
                return True
            self.ex.spin_once(timeout_sec=0.02)
        return cond()

    def close(self) -> None:
        self.ex.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()


@pytest.fixture(scope="module")
def probe(ros_env: int):
    p = Probe(ros_env)
    yield p
    p.close()


def _wait_matched(bridge: Ros2Bridge, topics: list[str]) -> None:
    """Until the bridge's writers have matched the probe's readers on ``topics`` (the
    graph shows a reader earlier: a message written in between is lost to it)."""
    assert bridge.wait_for_subscribers(topics, timeout_s=120.0), topics


def test_scene_helm_clock_and_image_contents(bridge: Ros2Bridge, probe: Probe, agent: str):
    probe.sub(MarkerArray, "/scene/markers", qos=bridge_scene_qos())
    probe.sub(Float64, f"/{agent}/helm/desired_heading")
    probe.sub(Float64, f"/{agent}/helm/desired_speed")
    probe.sub(Float64, f"/{agent}/helm/desired_depth")
    probe.sub(String, f"/{agent}/helm/mode")
    probe.sub(Clock, "/clock", qos=qos_profile_sensor_data)
    probe.sub(Image, f"/{agent}/sonar/polar", qos=qos_profile_sensor_data)
    _wait_matched(bridge, ["/scene/markers", f"/{agent}/helm/mode", "/clock",
                                  f"/{agent}/sonar/polar"])

    pile = {"ns": "piles", "id": 3, "type": "cylinder", "position_ned": [10.0, -2.0, 5.0],
            "scale": [0.5, 0.5, 10.0], "color": (0.2, 0.3, 0.4, 1.0)}
    path = {"ns": "path", "id": 0, "type": "line_strip",
            "points_ned": [[0.0, 0.0, 1.0], [3.0, 4.0, 2.0]], "scale": [0.05, 0, 0]}
    polar = (np.arange(64 * 32, dtype=np.uint16) % 251).astype(np.uint8).reshape(64, 32)
    g = probe.got

    def everything_arrived() -> bool:
        return bool(g["/scene/markers"] and g[f"/{agent}/helm/mode"]
                    and g[f"/{agent}/sonar/polar"] and len(g["/clock"]) >= 3)

    # Best-effort sensor topics may drop a message on a loaded machine: publish the same
    # three messages again until all have arrived (each round is identical).
    for _ in range(20):
        for t in (2.25, 2.5, 2.75):
            bridge.write_clock(t)  # a new time each: three clocks a round
        bridge.write_scene_markers(2.25, [pile, path])
        bridge.write_helm_topics(agent, 2.5, 45.0, 0.8, None, "MODE@ACTIVE:TRAIL")
        bridge.write_sonar(agent, "sonar", 2.75, polar, None, None, None,
                           ((0.0, 0.0, 0.0), np.eye(3)))
        if probe.spin_until(everything_arrived, timeout=0.5):
            break
    assert everything_arrived()

    m_pile, m_path = g["/scene/markers"][0].markers
    assert (m_pile.ns, m_pile.id, m_pile.type) == ("piles", 3, Marker.CYLINDER)
    assert m_pile.header.frame_id == "map"
    assert (m_pile.header.stamp.sec, m_pile.header.stamp.nanosec) == (2, 250_000_000)
    # NED (10, -2, 5) -> ENU (east -2, north 10, up -5)
    p = m_pile.pose.position
    assert (p.x, p.y, p.z) == pytest.approx((-2.0, 10.0, -5.0))
    assert (m_pile.scale.x, m_pile.scale.y, m_pile.scale.z) == pytest.approx((0.5, 0.5, 10.0))
    assert m_pile.color.b == pytest.approx(0.4)
    assert m_path.type == Marker.LINE_STRIP
    # the points in the marker's own frame, placed by its pose: NED -> ENU in the world
    q = m_path.pose.orientation
    x, y, z, w = q.x, q.y, q.z, q.w
    rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    pos = m_path.pose.position
    world = np.array([[p.x, p.y, p.z] for p in m_path.points]) @ rot.T + [pos.x, pos.y, pos.z]
    np.testing.assert_allclose(world, [(0.0, 0.0, -1.0), (4.0, 3.0, -2.0)], atol=1e-12)

    assert g[f"/{agent}/helm/desired_heading"][-1].data == 45.0
    assert g[f"/{agent}/helm/desired_speed"][-1].data == 0.8
    assert g[f"/{agent}/helm/desired_depth"] == []  # None is not published
    assert g[f"/{agent}/helm/mode"][-1].data == "MODE@ACTIVE:TRAIL"
    clocks = [(c.clock.sec, c.clock.nanosec) for c in g["/clock"]]
    run = [(2, 250_000_000), (2, 500_000_000), (2, 750_000_000)]  # one per new time
    assert any(clocks[i:i + 3] == run for i in range(len(clocks) - 2)), clocks

    img = g[f"/{agent}/sonar/polar"][-1]
    assert (img.height, img.width, img.step, img.encoding) == (64, 32, 32, "mono8")
    assert img.header.frame_id == f"{agent}/sonar"
    np.testing.assert_array_equal(np.frombuffer(bytes(img.data), np.uint8).reshape(64, 32), polar)


def bridge_scene_qos():
    from uhrisim.bridges.ros2.topics import QOS_SCENE

    return QOS_SCENE


def test_helm_mode_is_latched_and_sent_on_change(ros_env: int, probe: Probe) -> None:
    """/helm/mode goes out when the mode changes, transient-local: a node subscribing
    after the mode was set still receives it; repeating the same mode sends nothing."""
    name = f"rov_{secrets.token_hex(3)}"
    with Ros2Bridge([AgentBridgeSpec(name)], node_name=f"uhrisim_{name}",
                    domain_id=ros_env) as b:
        b.write_helm_topics(name, 1.0, 10.0, 0.5, 2.0, "MODE@ACTIVE:LOITER")
        b.write_helm_topics(name, 1.25, 11.0, 0.5, 2.0, "MODE@ACTIVE:LOITER")
        topic = f"/{name}/helm/mode"
        assert b.stats()["published"][topic] == 1
        probe.sub(String, topic, qos=bridge_scene_qos())  # subscribes after the fact
        got = probe.got[topic]
        assert probe.spin_until(lambda: len(got) == 1)
        assert got[0].data == "MODE@ACTIVE:LOITER"
        b.write_helm_topics(name, 1.5, 12.0, 0.5, 2.0, "MODE@ACTIVE:TRAIL")
        assert probe.spin_until(lambda: len(got) == 2)
        assert got[1].data == "MODE@ACTIVE:TRAIL" and b.stats()["published"][topic] == 2


def test_only_subscribed_volatile_topics_are_written(ros_env: int, probe: Probe) -> None:
    """A volatile topic nobody subscribes to is not written (nobody could receive it);
    once a node subscribes it is; the latched mode always is. The odometry's rate gate
    says it is not due while nobody would receive it."""
    from nav_msgs.msg import Odometry

    name = f"rov_{secrets.token_hex(3)}"
    with Ros2Bridge([AgentBridgeSpec(name, odom_rate_hz=None)], node_name=f"uhrisim_{name}",
                    domain_id=ros_env) as b:
        assert not b.odometry_due(name, 0.1)  # due, but nobody would get it
        b.write_odometry(name, 0.1, [1.0, 2.0, 3.0], 0.5, [0.2, 0.0, 0.0], 0.0)
        assert not b.odometry_due(name, 0.15)
        b.write_helm_topics(name, 0.1, 10.0, 0.5, 2.0, "MODE@ACTIVE:LOITER")
        b.write_sonar(name, "sonar", 0.1, np.zeros((4, 3), np.uint8),
                      np.zeros((5, 6), np.uint8), np.zeros((2, 3)), None,
                      ([0, 0, 0], np.eye(3)))
        ours = {k: v for k, v in b.stats()["published"].items() if name in k}
        assert ours == {f"/{name}/helm/mode": 1}
        # bad input is refused whether or not anyone would have received it
        with pytest.raises(ConfigError, match="uint8"):
            b.write_sonar(name, "sonar", 0.3, None, np.zeros((5, 6)), None, None,
                          ([0, 0, 0], np.eye(3)))
        with pytest.raises(ConfigError, match="finite"):
            b.write_odometry(name, 0.3, [np.nan, 0.0, 0.0], 0.0, [0.0, 0.0, 0.0], 0.0)
        probe.sub(Odometry, f"/{name}/odom")
        _wait_matched(b, [f"/{name}/odom"])
        assert b.odometry_due(name, 0.2)
        b.write_odometry(name, 0.2, [1.0, 2.0, 3.0], 0.5, [0.2, 0.0, 0.0], 0.0)
        ours = {k: v for k, v in b.stats()["published"].items() if name in k}
        assert ours == {f"/{name}/helm/mode": 1, f"/{name}/odom": 1}  # not the pose
        assert probe.spin_until(lambda: len(probe.got[f"/{name}/odom"]) == 1)


def test_a_reliable_subscriber_to_a_best_effort_topic_is_reported(
        bridge: Ros2Bridge, probe: Probe, agent: str) -> None:
    """A default (reliable) subscription to the best-effort sonar images and /clock gets
    nothing; the bridge sees the incompatible subscriber, counts it per topic and says
    what to do (on /rosout), instead of staying silent (issue 16)."""
    topics = [f"/{agent}/sonar/polar", "/clock"]
    probe.sub(Image, topics[0], qos=10)  # rclpy's default: reliable
    probe.sub(Clock, topics[1], qos=10)

    def reported() -> bool:
        return all(bridge.stats()["incompatible_qos"].get(t, 0) >= 1 for t in topics)

    assert probe.spin_until(reported)


def test_commands_validation_and_sim_time_timeout(bridge: Ros2Bridge, probe: Probe, agent: str):
    pubs = {k: probe.node.create_publisher(Float64, f"/{agent}/cmd/{k}", 10)
            for k in ("desired_heading", "desired_speed", "desired_depth")}
    thr = probe.node.create_publisher(Float64MultiArray, f"/{agent}/cmd/thrusters", 10)
    assert probe.spin_until(lambda: all(p.get_subscription_count() > 0
                                        for p in [*pubs.values(), thr]))

    c0 = bridge.commands(agent, 5.0)  # nothing received yet: not external control
    assert not c0.received and not c0.stale and c0.desired_speed is None

    before = bridge.stats()["rejected_commands"]

    def sent() -> bool:  # re-send until all arrived (best-effort, discovery settling)
        c = bridge.commands(agent, 5.0)
        if None not in (c.thrusters, c.desired_depth, c.desired_heading_deg, c.desired_speed):
            return True
        pubs["desired_heading"].publish(Float64(data=370.0))  # wraps to 10 deg
        pubs["desired_speed"].publish(Float64(data=0.6))
        pubs["desired_depth"].publish(Float64(data=-1.0))  # above the surface -> 0
        thr.publish(Float64MultiArray(data=[200.0, -20.0, 30.0]))  # port clipped to 150
        return False

    assert probe.spin_until(sent)
    c = bridge.commands(agent, 5.5)
    assert c.desired_heading_deg == pytest.approx(10.0)
    assert c.desired_speed == 0.6 and c.desired_depth == 0.0
    assert c.thrusters == (150.0, -20.0, 30.0)
    assert not c.stale and c.age_s == pytest.approx(0.5)

    def sent_bad() -> bool:
        if bridge.stats()["rejected_commands"] >= before + 2:
            return True
        thr.publish(Float64MultiArray(data=[1.0, 2.0]))  # wrong length: rejected
        thr.publish(Float64MultiArray(data=[1.0, math.nan, 2.0]))  # non-finite: rejected
        return False

    assert probe.spin_until(sent_bad)
    assert bridge.commands(agent, 5.5).thrusters == (150.0, -20.0, 30.0)

    # Timeout in simulation time: received at t = 5.0 (the newest time the bridge knew),
    # fresh up to 6.0, gone after it.
    assert bridge.commands(agent, 6.0).desired_speed == 0.6
    late = bridge.commands(agent, 6.01)
    assert late.stale and late.desired_speed is None and late.thrusters is None
    assert late.age_s == pytest.approx(1.01)


def test_lockstep_round_is_answered_by_a_whole_command_group(ros_env: int,
                                                             probe: Probe) -> None:
    """A lockstep round counts as answered once every topic of one accepted command
    group has arrived since it began: two of the three desired values are not enough,
    the thrusters alone are; nothing new means silence."""
    name = f"l_{secrets.token_hex(3)}"
    with Ros2Bridge([AgentBridgeSpec(name, sonars=())], domain_id=ros_env,
                    reliable_commands=True) as b:
        desired = {k: probe.node.create_publisher(Float64, f"/{name}/cmd/{k}", 10)
                   for k in ("desired_heading", "desired_speed", "desired_depth")}
        thrusters = probe.node.create_publisher(Float64MultiArray, f"/{name}/cmd/thrusters", 10)
        assert not b.wait_for_controller(name, 0.1)  # nobody reads the odometry yet
        probe.sub(Odometry, f"/{name}/odom")
        assert b.wait_for_controller(name, 120.0)
        # every one of our writers has matched the bridge's reader (the controller's match
        # is one topic's): reliable, so no command written from now on is lost
        assert probe.spin_until(lambda: all(p.get_subscription_count() > 0
                                            for p in [*desired.values(), thrusters]))

        assert not b.begin_round(name)  # nothing answered before
        desired["desired_heading"].publish(Float64(data=10.0))
        desired["desired_speed"].publish(Float64(data=0.5))
        assert b.wait_answers([name], 0.5) == [name]
        desired["desired_depth"].publish(Float64(data=2.0))
        assert b.wait_answers([name], 5.0) == []
        assert b.begin_round(name)
        thrusters.publish(Float64MultiArray(data=[1.0, 2.0, 3.0]))
        assert b.wait_answers([name], 5.0) == []
        assert b.begin_round(name)
        assert b.wait_answers([name], 0.2) == [name]
        assert not b.begin_round(name)
        c = b.commands(name, 0.0)
        assert (c.desired_heading_deg, c.desired_speed, c.desired_depth, c.thrusters) == (
            10.0, 0.5, 2.0, (1.0, 2.0, 3.0))


def test_wall_clock_timeout(ros_env: int, probe: Probe) -> None:
    name = f"w_{secrets.token_hex(3)}"
    with Ros2Bridge([AgentBridgeSpec(name, sonars=(), accept=("desired",))],
                    domain_id=ros_env, command_timeout_s=0.2, timeout_clock="wall") as b:
        pub = probe.node.create_publisher(Float64, f"/{name}/cmd/desired_speed", 10)

        def sent() -> bool:  # re-send until it arrives: discovery may still be settling
            if b.commands(name, 0.0).desired_speed == 0.3:
                return True
            pub.publish(Float64(data=0.3))
            return False

        assert probe.spin_until(sent)
        # sim time standing still does not keep it fresh in wall mode
        assert probe.spin_until(lambda: b.commands(name, 0.0).stale, timeout=5.0)
        assert b.subscriber_count(f"/{name}/cmd/thrusters") == 0  # not accepted: no sub


def test_error_paths(ros_env: int, bridge: Ros2Bridge, agent: str) -> None:
    idle = Ros2Bridge([AgentBridgeSpec("idle")], domain_id=ros_env)
    with pytest.raises(BridgeError, match="start"):
        idle.write_odometry("idle", 0.0, [0, 0, 0], 0.0, [0, 0, 0], 0.0)
    idle.close()
    with pytest.raises(BridgeError):
        idle.start()
    with pytest.raises(ConfigError, match="unknown agent"):
        bridge.write_odometry("nobody", 0.0, [0, 0, 0], 0.0, [0, 0, 0], 0.0)
    with pytest.raises(ConfigError, match="uint8"):
        bridge.write_sonar(agent, "sonar", 0.0, np.zeros((4, 4)), None, None, None,
                           ((0, 0, 0), np.eye(3)))
    with pytest.raises(ConfigError, match="type"):
        bridge.write_scene_markers(0.0, [{"ns": "a", "id": 0, "type": "torus",
                                          "position_ned": [0, 0, 0]}])
    with pytest.raises(ConfigError, match="ns"):
        bridge.write_scene_markers(0.0, [{"id": 0, "type": "box"}])
    with pytest.raises(ConfigError, match="unique"):
        Ros2Bridge([AgentBridgeSpec("a"), AgentBridgeSpec("a")])
    with pytest.raises(ConfigError, match="command_timeout_s"):
        Ros2Bridge([AgentBridgeSpec("a")], command_timeout_s=0.0)
    camera = Ros2Bridge([AgentBridgeSpec("cam", sonars=(), cameras=("camera",))],
                        domain_id=ros_env, node_name="uhrisim_cam_errors")
    camera.start()
    try:
        rgb, pose = np.zeros((4, 6, 3), np.uint8), ((0.0, 0.0, 0.0), np.eye(3))
        with pytest.raises(ConfigError, match=r"labels_u8 must have shape \(4, 6\)"):
            camera.write_camera("cam", "camera", 0.0, rgb, None, np.zeros((6, 4), np.uint8),
                                np.eye(3), pose)
        with pytest.raises(ConfigError, match=r"labels_u8.*uint8"):
            camera.write_camera("cam", "camera", 0.0, rgb, None, np.zeros((4, 6)), np.eye(3),
                                pose)
    finally:
        camera.close()


def test_start_applies_localhost_default(ros_env: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_AUTOMATIC_DISCOVERY_RANGE")
    with Ros2Bridge([AgentBridgeSpec(f"e_{secrets.token_hex(3)}", sonars=())],
                    domain_id=ros_env):
        assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"


def test_clock_follows_sim_time_and_can_be_throttled(ros_env: int) -> None:
    """/clock goes out once per new simulation time; with clock_rate_hz=10 over 1.00 s
    of 0.01 s ticks the rate gate lets through t = 0.0, 0.1, ..., 1.0: 11 messages."""
    name = f"c_{secrets.token_hex(3)}"
    with Ros2Bridge([AgentBridgeSpec(name, sonars=())], domain_id=ros_env,
                    clock_rate_hz=10.0, publish_unsubscribed=True) as b:
        for k in range(101):
            b.write_clock(k * 0.01)
            b.write_clock(k * 0.01)  # same time again: nothing new
        assert b.stats()["published"]["/clock"] == 11
    with Ros2Bridge([AgentBridgeSpec(name, sonars=())], domain_id=ros_env,
                    publish_unsubscribed=True) as b:
        for k in range(50):
            b.write_clock(k * 0.01)
            b.write_odometry(name, k * 0.01, [0, 0, 0], 0.0, [0, 0, 0], 0.0)
            b.write_clock(k * 0.01)  # the same time again: nothing new
        assert b.stats()["published"]["/clock"] == 50


def test_bench_quick_is_consistent(ros_env: int) -> None:
    """The quick benchmark runs and its overhead figure is 15 x sonar + 10 x nav cost."""
    from uhrisim.bench import ros2 as bench

    r = bench.run(quick=True)
    json.dumps(r)  # JSON-serialisable
    ws = r["without_subscriber"]
    expected = (15.0 * ws["write_sonar"]["mean_us"]
                + 10.0 * ws["write_odometry"]["mean_us"]) * 1e-6
    assert r["loop_overhead"]["fraction_of_one_core"] == pytest.approx(expected)
    assert isinstance(r["meets_target"], bool)
    assert ws["write_odometry_throttled_tick"]["median_us"] < ws["write_odometry"]["median_us"]
    assert r["config"]["sonar_set_bytes"] == 2000 * 256 + 600 * 1000 + 16 * 4096


def test_live_messages_equal_recordings(tmp_path: Path) -> None:
    """The bytes the MCAP recorder writes for some truth, decoded by rclpy's own CDR
    deserializer, equal field for field (floats exactly) the messages the bridge
    publishes for the same truth: live topics and recordings cannot disagree on frames,
    units or stamps. The recorder is an independent implementation (uhrisim.record,
    checked against mcap_ros2's encoder). (Bytes are not compared: Fast CDR leaves
    alignment padding uninitialised.)"""
    from mcap.reader import make_reader
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import PointCloud2

    from tests.support.ros2_reference import image_msg, odometry_msg, pointcloud_msg
    from uhrisim.record.mcap_recorder import McapRecorder
    from uhrisim.ros import cdr

    rng = np.random.default_rng(7)
    poses = [(rng.uniform(-50, 50, 3), rng.uniform(-4, 4), rng.uniform(-1, 1, 3),
              rng.uniform(-0.5, 0.5), 0.1 * k + 0.05) for k in range(5)]
    path = tmp_path / "odom.mcap"
    rec = McapRecorder(path)
    for pos, yaw, vel, r, t in poses:
        rec.write_odometry("rov", t, pos, yaw, vel, r)
    rec.close()
    with open(path, "rb") as f:
        recorded = [bytes(m.data) for _, ch, m in make_reader(f).iter_messages()
                    if ch.topic == "/rov/odom"]
    assert len(recorded) == len(poses)
    for (pos, yaw, vel, r, t), raw in zip(poses, recorded, strict=True):
        assert deserialize_message(raw, Odometry) == odometry_msg("rov", t, pos, yaw, vel, r)

    img = rng.integers(0, 256, (37, 53), dtype=np.uint8)
    raw_img = cdr.encode_image(2, 500_000_000, "rov/sonar", img)
    assert deserialize_message(raw_img, Image) == image_msg(img, 2.5, "rov/sonar")
    pts = rng.uniform(-5, 5, (11, 3))
    inten = rng.uniform(0, 1, 11)
    xyzi = np.column_stack([pts[:, 0], -pts[:, 1], -pts[:, 2], inten])  # FRD -> FLU
    raw_cloud = cdr.encode_pointcloud2(3, 0, "rov/sonar", xyzi)
    assert deserialize_message(raw_cloud, PointCloud2) == pointcloud_msg(
        3.0, "rov/sonar", pts, inten)


def test_preserialised_odometry_and_pose_equal_the_messages() -> None:
    """write_odometry sends odometry and pose as bytes packed by precompiled structs; rclpy's
    own deserializer reads them back as exactly the messages odometry_msg builds (floats
    exactly, every stamp and frame id), for random poses, stamps and agent names."""
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message

    from tests.support.ros2_reference import odometry_msg
    from uhrisim.ros.cdr import OdometryEncoder, PoseStampedEncoder
    from uhrisim.ros.convert import odom_fields_from_ned, stamp_from_sim_time
    from uhrisim.ros.topics import WORLD_FRAME

    rng = np.random.default_rng(11)
    for agent in ("rov", "videoray", "diver_2"):
        odometry = OdometryEncoder(f"{agent}/odom", f"{agent}/base_link")
        pose = PoseStampedEncoder(WORLD_FRAME)
        for _ in range(20):
            pos, yaw, vel = rng.uniform(-50, 50, 3), rng.uniform(-4, 4), rng.uniform(-1, 1, 3)
            r, t = rng.uniform(-0.5, 0.5), rng.uniform(0.0, 1e5)
            f = odom_fields_from_ned(pos, yaw, vel, r)
            sec, nanosec = stamp_from_sim_time(t)
            expected = odometry_msg(agent, t, pos, yaw, vel, r)
            raw = odometry(sec, nanosec, f.position_enu, f.orientation_xyzw, f.linear_flu,
                           f.angular_flu)
            assert deserialize_message(raw, Odometry) == expected
            want_pose = PoseStamped(header=expected.header, pose=expected.pose.pose)
            want_pose.header.frame_id = WORLD_FRAME  # the pose in the world; odometry in odom
            raw_pose = pose(sec, nanosec, f.position_enu, f.orientation_xyzw)
            assert deserialize_message(raw_pose, PoseStamped) == want_pose


def test_preserialised_clock_and_helm_messages_equal_rclpy() -> None:
    """/clock and the helm topics go out as bytes packed without building messages;
    they are exactly rclpy's own serialisation of the messages, and read back equal."""
    from rclpy.serialization import deserialize_message, serialize_message

    from uhrisim.ros.convert import stamp_from_sim_time
    from uhrisim.ros.messages import clock, float64, string

    rng = np.random.default_rng(5)
    for t in [0.0, 0.5, 1e-9, 59.99999999, *rng.uniform(0.0, 1e6, 50).tolist()]:
        want = Clock()
        want.clock.sec, want.clock.nanosec = stamp_from_sim_time(t)
        raw = clock(*stamp_from_sim_time(t))
        assert raw == serialize_message(want)
        assert deserialize_message(raw, Clock) == want
    for v in [0.0, -0.0, 1.5, -1e300, 359.99, *rng.uniform(-1e3, 1e3, 50).tolist()]:
        assert float64(v) == serialize_message(Float64(data=v))
        assert deserialize_message(float64(v), Float64) == Float64(data=v)
    for text in ["", "a", "ab", "abc", "MODE@ACTIVE:TRAIL", "ÅØ ünïcødé", "x" * 257]:
        assert deserialize_message(string(text), String) == String(data=text)
        assert string(text) == serialize_message(String(data=text))
