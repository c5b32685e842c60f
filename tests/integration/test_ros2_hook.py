"""The ROS 2 hook on the real track-and-trail simulation, against a probe node.

Expected numbers come from the simulation itself: each odometry message must carry the
ENU form (east, north, -depth) of the agent's NED truth at the stamped tick
(docs/conventions.md); at 60 Hz physics and 10 Hz odometry, one message per 6 ticks;
the sonar pose must be the ping's; commands published by the probe must come back as
``ros2`` posts of DESIRED_* and as an actuator override, and silence must trigger the
safe stop once ``command_timeout_s`` of simulated time has passed.
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from geometry_msgs.msg import PoseStamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.context import Context  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from rclpy.signals import SignalHandlerOptions  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import Image, PointCloud2  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from tests.support.ros2_domains import spare_domain_id  # noqa: E402
from uhrisim.bridges.ros2.hook import Ros2BridgeHook  # noqa: E402
from uhrisim.bridges.ros2.topics import QOS_SCENE  # noqa: E402
from uhrisim.core.frames import enu_from_ned, enu_rotation_from_ned, quaternion_from_matrix  # noqa: E402
from uhrisim.scenario import load  # noqa: E402
from uhrisim.sensors.sonar.sonar import cloud_hits  # noqa: E402
from uhrisim.sim import simulation  # noqa: E402

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"
#: /tf_static, latched, where tf2_msgs is built (python -m uhrisim.bridges.ros2.interfaces)
LATCHED_TF = ("/tf_static",) if importlib.util.find_spec("tf2_msgs") else ()




def test_hook_on_real_simulation(ros_env: int) -> None:
    source = load.load_scenario(SCENARIO)
    hook = Ros2BridgeHook(domain_id=ros_env, odom_rate_hz=10.0, command_timeout_s=1.0,
                          node_name="uhrisim_hook_test")
    sim = simulation.Simulation(source, hooks=[hook], seed=1)
    ctx = Context()
    rclpy.init(context=ctx, domain_id=ros_env, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("probe", context=ctx, start_parameter_services=False)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    got: dict[str, list] = {k: [] for k in ("odom", "polar", "fan", "points", "sonar_pose",
                                            "scene")}
    node.create_subscription(Odometry, "/videoray/odom", got["odom"].append, 50)
    node.create_subscription(Image, "/videoray/sonar/polar", got["polar"].append,
                             qos_profile_sensor_data)
    node.create_subscription(Image, "/videoray/sonar/fan", got["fan"].append,
                             qos_profile_sensor_data)
    node.create_subscription(PointCloud2, "/videoray/sonar/points", got["points"].append,
                             qos_profile_sensor_data)
    node.create_subscription(PoseStamped, "/videoray/sonar/pose", got["sonar_pose"].append, 50)
    node.create_subscription(MarkerArray, "/scene/markers", got["scene"].append, QOS_SCENE)
    node.create_subscription(Clock, "/clock", lambda _: None, qos_profile_sensor_data)
    pub_speed = node.create_publisher(Float64, "/videoray/cmd/desired_speed", 10)
    pub_thr = node.create_publisher(Float64MultiArray, "/videoray/cmd/thrusters", 10)

    truth: dict[tuple[int, int], np.ndarray] = {}
    pings: dict[tuple[int, int], object] = {}
    posts = []

    def step(n: int) -> None:
        for _ in range(n):
            f = sim.step()
            key = divmod(round(f.t * 1e9), 1_000_000_000)
            truth[key] = np.array(f.agents["videoray"].nav.position_ned, dtype=float)
            if "videoray/sonar" in f.pings:
                pings[divmod(round(f.pings["videoray/sonar"].t * 1e9), 1_000_000_000)] = \
                    f.pings["videoray/sonar"]
            posts.extend(f.posts)
            ex.spin_once(timeout_sec=0.0)

    try:
        sim.start()
        bridge = hook.bridge
        assert bridge is not None
        assert bridge.wait_for_subscribers(["/videoray/odom", "/videoray/sonar/polar",
                                            "/videoray/sonar/fan", "/videoray/sonar/points",
                                            "/videoray/sonar/pose", "/clock",
                                            "/videoray/cmd/desired_speed"], 120.0)
        n0 = len(got["odom"])
        clock0 = bridge.stats()["published"].get("/clock", 0)
        step(120)  # 2 s of simulation
        # /clock at its default 10 Hz, on the ticks of the 10 Hz odometry
        assert bridge.stats()["published"]["/clock"] - clock0 == 20
        end = time.monotonic() + 120.0  # only against a hang: all are reliable, matched
        while len(got["odom"]) < n0 + 20 or len(got["sonar_pose"]) < len(pings) - 1:
            assert time.monotonic() < end, (len(got["odom"]) - n0, len(got["sonar_pose"]))
            ex.spin_once(timeout_sec=0.02)

        # 120 ticks at 60 Hz, odometry gated to 10 Hz: 20 messages, one per 6 ticks
        odoms = got["odom"][n0:]
        assert len(odoms) == 20
        stamps = [(m.header.stamp.sec, m.header.stamp.nanosec) for m in odoms]
        gaps = np.diff([s + 1e-9 * ns for s, ns in stamps])
        np.testing.assert_allclose(gaps, 0.1, atol=1e-6)
        for m in odoms:
            ned = truth[(m.header.stamp.sec, m.header.stamp.nanosec)]
            p = m.pose.pose.position
            np.testing.assert_allclose([p.x, p.y, p.z], enu_from_ned(ned), atol=1e-9)
            assert m.header.frame_id == "videoray/odom" and m.child_frame_id == "videoray/base_link"

        def stamp(m) -> tuple[int, int]:
            return (m.header.stamp.sec, m.header.stamp.nanosec)

        # reliable, one pose per ping (while the probe keeps up)
        assert len(got["sonar_pose"]) >= len(pings) - 1
        step(300)  # the diver comes into the sonar's view after about 4 s
        end = time.monotonic() + 120.0  # only against a hang (the last are in the reader)
        while not any(m.width for m in got["points"]):
            assert time.monotonic() < end, "no sonar cloud with hits arrived"
            ex.spin_once(timeout_sec=0.02)
        assert got["polar"], "no sonar image"
        img = got["polar"][-1]
        ping = pings[stamp(img)]
        assert ping.polar_u8.max() > 0  # an image with echoes in it
        assert (img.height, img.width) == ping.polar_u8.shape
        np.testing.assert_array_equal(
            np.frombuffer(bytes(img.data), np.uint8).reshape(ping.polar_u8.shape), ping.polar_u8)
        fan = got["fan"][-1]
        fan_u8 = pings[stamp(fan)].fan_u8
        assert (fan.height, fan.width, fan.step, fan.encoding) == (*fan_u8.shape,
                                                                   fan_u8.shape[1], "mono8")
        np.testing.assert_array_equal(
            np.frombuffer(bytes(fan.data), np.uint8).reshape(fan_u8.shape), fan_u8)
        cloud = max(got["points"], key=lambda m: m.width)  # the ping with the most hits
        points, intensity = cloud_hits(pings[stamp(cloud)].cloud)
        assert points.shape[0] > 0 and cloud.width == points.shape[0] and cloud.is_dense
        rows = np.frombuffer(bytes(cloud.data), "<f4").reshape(-1, 4)
        flu = np.column_stack([points[:, 0], -points[:, 1], -points[:, 2], intensity])
        np.testing.assert_array_equal(rows, flu.astype("<f4"))  # sonar frame, FLU
        for m in got["sonar_pose"]:
            ping = pings[stamp(m)]
            q = m.pose.position
            np.testing.assert_allclose([q.x, q.y, q.z], enu_from_ned(ping.position_ned),
                                       atol=1e-9)
            o = m.pose.orientation
            want = quaternion_from_matrix(enu_rotation_from_ned(ping.rotation_ned_from_sonar))
            np.testing.assert_allclose([o.x, o.y, o.z, o.w], want, atol=1e-12)

        assert got["scene"], "no scene markers"
        tri = [m for m in got["scene"][-1].markers if m.type == Marker.TRIANGLE_LIST]
        assert tri and all(len(m.points) % 3 == 0 and len(m.points) <= 3 * 20_000
                           for m in tri)

        # commands in: re-send until the simulation has them (best-effort, discovery)
        for _ in range(200):
            pub_speed.publish(Float64(data=0.25))
            pub_thr.publish(Float64MultiArray(data=[40.0, 30.0, -10.0]))
            step(1)
            if any(p.source == "ros2" and p.var == "DESIRED_SPEED" for p in posts):
                break
            time.sleep(0.005)
        ros_posts = [p for p in posts if p.source == "ros2"]
        assert next(p.value for p in ros_posts if p.var == "DESIRED_SPEED") == 0.25
        step(2)
        override = sim.agents["videoray"].actuator_override
        assert override is not None and list(override) == [40.0, 30.0, -10.0]
        assert any("external commands active" in e.detail for e in sim.events_log)

        # silence: after 1 s of simulated time the hook stops the vehicle once
        n_posts = len(posts)
        step(75)
        # (commands still in flight when the loop above stopped sending may come first)
        stop = [p for p in posts[n_posts:] if p.source == "ros2"]
        assert (stop[-2].var, stop[-2].value) == ("DESIRED_SPEED", 0.0)
        assert stop[-1].var == "DESIRED_DEPTH"
        assert stop[-1].value == pytest.approx(float(truth[divmod(
            round(stop[-1].t * 1e9), 1_000_000_000)][2]), abs=0.05)  # hold the depth
        assert sum("safe stop" in e.detail for e in sim.events_log) == 1
        summary = hook.summary()["ros2"]
        assert summary["posted"] >= 1 and summary["published"]["/videoray/odom"] >= 20
    finally:
        hook.on_end(sim, None)
        ex.shutdown()
        node.destroy_node()
        ctx.try_shutdown()


def test_unsubscribed_topics_cost_nothing(ros_env: int) -> None:
    """With nobody subscribed, the hook writes only the latched topics, the helm modes and
    the sonar mount on /tf_static: no odometry, /tf, clock, helm values or sonar products,
    and no fan image is formed (the costly product)."""
    # a domain of its own: no reader left from the module's other test may match here
    hook = Ros2BridgeHook(domain_id=spare_domain_id(ros_env), node_name="uhrisim_lazy_test",
                          publish_scene=False)
    pings = []

    class Keep:
        def on_start(self, sim) -> None: ...
        def on_end(self, sim, error) -> None: ...
        def on_tick(self, frame) -> None:
            pings.extend(frame.pings.values())

    sim = simulation.Simulation(load.load_scenario(SCENARIO), hooks=[hook, Keep()], seed=1)
    with sim:
        sim.run(1.0)
        published = hook.bridge.stats()["published"]
    assert len(pings) == 15
    assert all("_fan_images" not in vars(p) for p in pings)  # never formed
    assert set(published) == {"/videoray/helm/mode", "/diver/helm/mode", *LATCHED_TF}
    assert all(published[topic] == 1 for topic in LATCHED_TF)


def test_ros_shut_down_under_the_bridge_does_not_stop_the_simulation(
    ros_env: int, caplog: pytest.LogCaptureFixture
) -> None:
    """ROS shut down in the middle of a run (the bridge's context, as another library's
    shutdown would): every write fails from then on, the run goes to its end with the
    same states as without a bridge, and each failing topic is counted and logged once
    (not once a message)."""

    class Last:
        def __init__(self, shut_at: float | None = None) -> None:
            self.shut_at, self.position, self.events = shut_at, None, []

        def on_start(self, sim) -> None: ...
        def on_end(self, sim, error) -> None: ...
        def on_tick(self, frame) -> None:
            self.position = frame.agents["videoray"].nav.position_ned.copy()
            self.events += [e for e in frame.events if e.kind == "bridge"]
            if self.shut_at is not None and frame.t >= self.shut_at:
                hook.bridge._context.try_shutdown()  # fault injection
                self.shut_at = None

    hook = Ros2BridgeHook(domain_id=spare_domain_id(ros_env), node_name="uhrisim_shutdown_test",
                          publish_scene=False)
    shut, plain = Last(shut_at=0.5), Last()
    source = load.load_scenario(SCENARIO)
    with (caplog.at_level("WARNING", logger="uhrisim.bridges.ros2.bridge"),
          simulation.Simulation(source, hooks=[hook, shut], seed=1) as sim):
        sim.run(2.0)
        stats = hook.bridge.stats()
    with simulation.Simulation(load.load_scenario(SCENARIO), hooks=[plain], seed=1) as sim:
        sim.run(2.0)
    np.testing.assert_array_equal(shut.position, plain.position)
    # nobody subscribed: only the latched helm modes and /tf_static went out; once ROS
    # is gone each write is tried (the publisher cannot tell whether someone listens)
    # and fails
    assert set(stats["published"]) == {"/videoray/helm/mode", "/diver/helm/mode",
                                       *LATCHED_TF}
    assert stats["failed"]["/clock"] == 15  # 0.6 ... 2.0 s at 10 Hz
    assert stats["failed"]["/videoray/odom"] == 15 and stats["failed"]["/videoray/pose"] == 15
    warned = [r.getMessage() for r in caplog.records if "failed" in r.getMessage()]
    assert sorted(w.split()[4] for w in warned) == sorted(stats["failed"])
    # and the recording says so: an event on each tick where topics first failed (each
    # topic fails on its first write after 0.5 s), every failing topic named once
    assert all(0.5 < e.t <= 0.75 for e in shut.events)
    named = [t.rstrip(",") for e in shut.events for t in e.detail.split() if t[0] == "/"]
    assert sorted(named) == sorted(stats["failed"])


def test_an_agent_driven_from_ros_whose_commands_never_come_is_said(
        ros_env: int, caplog: pytest.LogCaptureFixture) -> None:
    """ros2_external_helm.yaml's ROV (driver: external) with no controller: after the watch's
    silence a warning names the command topics and whether a node publishes on them; once
    commands come, the watch counts them and the warnings stop."""
    from uhrisim.scenario.schema import HelmWatchSection

    source = load.load_scenario(SCENARIO.parent / "ros2_external_helm.yaml")
    hook = Ros2BridgeHook(["videoray"], domain_id=ros_env, node_name="uhrisim_watch_test",
                          publish_scene=False,
                          helm_watch=HelmWatchSection(silence_s=5.0, repeat_s=100.0))
    ctx = Context()
    rclpy.init(context=ctx, domain_id=ros_env, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("controller", context=ctx, start_parameter_services=False)
    try:
        with (caplog.at_level("WARNING", logger="uhrisim.bridges.ros2.hook"),
              simulation.Simulation(source, hooks=[hook], raycast_sensors=False) as sim):
            sim.run(5.5)
            speed = node.create_publisher(Float64, "/videoray/cmd/desired_speed", 10)
            deadline = time.monotonic() + 120.0  # discovery: ms to seconds
            while not hook.bridge.command_source("videoray")[1]:
                assert time.monotonic() < deadline, "the publisher was never matched"
                time.sleep(0.05)
            sim.run(5.5)  # silent publisher: the watch's second kind of line
            watch = hook.watches["videoray"]
            deadline = time.monotonic() + 120.0
            while watch.n_commands == 0:
                assert time.monotonic() < deadline, "no command ever reached the bridge"
                speed.publish(Float64(data=0.3))
                sim.step()
                time.sleep(0.01)
            summary = hook.summary()["ros2"]["helm"]["videoray"]
    finally:
        node.destroy_node()
        ctx.try_shutdown()
    said = [r.getMessage() for r in caplog.records]
    assert said == [
        "ROS 2 agent 'videoray': no commands since the start (5 s): no node publishes on "
        "/videoray/cmd/* (is the controller running, on this ROS_DOMAIN_ID, in this "
        "namespace?)",
        "ROS 2 agent 'videoray': no commands since the start (6 s): a node publishes on "
        "/videoray/cmd/* but sends nothing"], said  # at the first check after 5.5 s
    assert summary["first_command_s"] > 11.0 and summary["warnings"] == 2
