"""McapRecorder: write synthetic runs, read them back with independent readers.

Independent readers: ``rosbags.highlevel.AnyReader`` (its own MCAP parser and CDR
deserialiser, types taken from the schemas in the file) and ``mcap``'s seeking reader
with ``mcap_ros2.decoder.DecoderFactory``. Expected values come from the geometry of
NED/ENU and FRD/FLU (REP-103), computed here by hand, not from uhrisim.core.frames.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from uhrisim.core.errors import ConfigError, UhrisimError
from uhrisim.core.frames import rotation_zyx
from uhrisim.record import McapRecorder, iter_messages, read_odometry, summarize
from uhrisim.ros.convert import optical_rotation

AGENTS = ("rov", "diver", "rov2")
N = 200  # messages of each kind per agent


def yaw_enu_of(q) -> float:
    """Yaw about ENU z (counter-clockwise from east) of a yaw-only quaternion."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def rotate(q, v):
    """Rotate vector v by unit quaternion q (x, y, z, w): v' = q v q*."""
    qv = np.array([q.x, q.y, q.z])
    t = 2.0 * np.cross(qv, v)
    return np.asarray(v) + q.w * t + np.cross(qv, t)


def synthetic_run(path: Path, chunk_size: int = 64 * 1024) -> None:
    rng = np.random.default_rng(7)
    polar = rng.integers(0, 256, (64, 32), dtype=np.uint8)
    fan = rng.integers(0, 256, (40, 50), dtype=np.uint8)
    with McapRecorder(path, chunk_size=chunk_size, metadata={"run": {"seed": "7"}}) as rec:
        rec.write_scene_markers(0.0, [
            {"ns": "piling", "id": 1, "type": "cylinder", "position_ned": (10, 20, 5),
             "scale": (0.5, 0.5, 10), "color": (0.4, 0.3, 0.2, 1.0)},
            {"ns": "seafloor", "id": 2, "type": "box", "position_ned": (0, 0, 12),
             "scale": (100, 100, 0.1)},
        ])
        for i in range(N):
            t = 0.1 * i
            for k, agent in enumerate(AGENTS):
                rec.write_odometry(agent, t, (i * 0.01, k, 2.0), 0.01 * i, (0.5, 0.0, 0.0), 0.01)
                rec.write_sonar(agent, "sonar", t, polar, fan, rng.normal(size=(5, 3)),
                                np.arange(5.0), ((i * 0.01, k, 2.0), np.eye(3)))
                rec.write_helm_decision(agent, t, 90.0, 0.5, 2.0 if k else None,
                                        {"trail": 80.0, "avoid": 20.0}, "TRAIL", ["trail"])
                rec.write_variable(agent, t, "NAV_SPEED", 0.5, "nav")
            if i % 50 == 0:
                rec.write_event(t, "collision", f"tick {i}")


@pytest.fixture(scope="module")
def run_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    synthetic_run(path)
    return path


def expected_counts() -> dict[str, tuple[str, int]]:
    exp = {"/scene/markers": ("visualization_msgs/msg/MarkerArray", 1),
           "/events": ("uhrisim_msgs/msg/Event", N // 50),
           "/tf": ("tf2_msgs/msg/TFMessage", 2 * N * len(AGENTS))}
    for a in AGENTS:
        exp[f"/{a}/odom"] = ("nav_msgs/msg/Odometry", N)
        exp[f"/{a}/pose"] = ("geometry_msgs/msg/PoseStamped", N)  # as the live bridge
        exp[f"/{a}/sonar/pose"] = ("geometry_msgs/msg/PoseStamped", N)
        exp[f"/{a}/sonar/polar"] = ("sensor_msgs/msg/Image", N)
        exp[f"/{a}/sonar/fan"] = ("sensor_msgs/msg/Image", N)
        exp[f"/{a}/sonar/points"] = ("sensor_msgs/msg/PointCloud2", N)
        exp[f"/{a}/helm/decision"] = ("uhrisim_msgs/msg/HelmDecision", N)
        exp[f"/{a}/vars"] = ("uhrisim_msgs/msg/Variable", N)
    return exp


def test_rosbags_reads_every_topic_with_expected_type_and_count(run_file: Path) -> None:
    counts: Counter[str] = Counter()
    types: dict[str, str] = {}
    with AnyReader([run_file]) as reader:
        for conn, _ts, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)  # every message decodes
            counts[conn.topic] += 1
            types[conn.topic] = conn.msgtype
    assert {t: (types[t], counts[t]) for t in counts} == expected_counts()


def test_mcap_seeking_reader_with_ros2_decoder(run_file: Path) -> None:
    with run_file.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics.message_count == sum(
            c for _, c in expected_counts().values())
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        assert meta == {"run": {"seed": "7"}}
    with run_file.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _s, channel, message, decoded in reader.iter_decoded_messages(topics=["/rov2/odom"]):
            # header.stamp, log_time and publish_time are all the simulation time
            stamp_ns = decoded.header.stamp.sec * 10**9 + decoded.header.stamp.nanosec
            assert stamp_ns == message.log_time == message.publish_time
            assert channel.message_encoding == "cdr"


def test_own_summary_agrees(run_file: Path) -> None:
    s = summarize(run_file)
    assert s.topics == expected_counts()
    assert not s.truncated
    assert s.first_ns == 0 and s.last_ns == round(0.1 * (N - 1) * 1e9)


def test_known_ned_pose_comes_out_right_in_enu(tmp_path: Path) -> None:
    path = tmp_path / "pose.mcap"
    with McapRecorder(path) as rec:
        # north 3, east 4, depth 2, heading 90° (facing east); surge 1, sway 0.5 to
        # starboard, heave 0.2 down; yaw rate 0.1 rad/s clockwise from above.
        rec.write_odometry("rov", 1.5, (3.0, 4.0, 2.0), math.pi / 2, (1.0, 0.5, 0.2), 0.1)
        # heading 0 (north) and 45° for the yaw mapping yaw_enu = pi/2 - heading.
        rec.write_odometry("a", 2.0, (0.0, 0.0, 0.0), 0.0, (0, 0, 0), 0.0)
        rec.write_odometry("b", 2.0, (0.0, 0.0, 0.0), math.radians(45.0), (0, 0, 0), 0.0)
    with AnyReader([path]) as reader:
        msgs = {c.topic: reader.deserialize(raw, c.msgtype)
                for c, _t, raw in reader.messages() if c.topic.endswith("/odom")}
    m = msgs["/rov/odom"]
    assert m.header.frame_id == "rov/odom" and m.child_frame_id == "rov/base_link"  # REP 105
    assert (m.header.stamp.sec, m.header.stamp.nanosec) == (1, 500_000_000)
    p = m.pose.pose.position
    assert (p.x, p.y, p.z) == pytest.approx((4.0, 3.0, -2.0), abs=1e-12)
    assert yaw_enu_of(m.pose.pose.orientation) == pytest.approx(0.0, abs=1e-12)
    lin, ang = m.twist.twist.linear, m.twist.twist.angular
    assert (lin.x, lin.y, lin.z) == pytest.approx((1.0, -0.5, -0.2), abs=1e-12)  # FLU
    assert (ang.x, ang.y, ang.z) == pytest.approx((0.0, 0.0, -0.1), abs=1e-12)  # CCW +
    assert yaw_enu_of(msgs["/a/odom"].pose.pose.orientation) == pytest.approx(math.pi / 2)
    assert yaw_enu_of(msgs["/b/odom"].pose.pose.orientation) == pytest.approx(math.pi / 4)
    # The body's forward axis, rotated into ENU, points east for heading 90°.
    assert rotate(m.pose.pose.orientation, [1, 0, 0]) == pytest.approx([1, 0, 0], abs=1e-12)
    # ... and tf carries the same transform, as REP 105's chain map -> odom -> base_link
    # (map -> odom the identity: ground truth does not drift)
    with AnyReader([path]) as reader:
        tfs = [reader.deserialize(raw, c.msgtype) for c, _t, raw in reader.messages()
               if c.topic == "/tf"]
    to_odom, tr = tfs[0].transforms
    assert (to_odom.header.frame_id, to_odom.child_frame_id) == ("map", "rov/odom")
    assert (to_odom.transform.translation.x, to_odom.transform.rotation.w) == (0.0, 1.0)
    assert (tr.header.frame_id, tr.child_frame_id) == ("rov/odom", "rov/base_link")
    assert (tr.transform.translation.x, tr.transform.translation.y) == pytest.approx((4, 3))


def test_read_odometry_inverts_the_conversion(tmp_path: Path) -> None:
    path = tmp_path / "odo.mcap"
    rng = np.random.default_rng(1)
    rows = []
    with McapRecorder(path) as rec:
        for i in range(50):
            pos = rng.normal(size=3) * 10
            yaw = rng.uniform(-math.pi, math.pi)
            vel = rng.normal(size=3)
            r = rng.normal()
            rec.write_odometry("rov", 0.2 * i, pos, yaw, vel, r)
            rows.append((0.2 * i, *pos, yaw, *vel, r))
    tr = read_odometry(path)["rov"]
    a = np.array(rows)
    np.testing.assert_allclose(tr["t"], a[:, 0], atol=1e-9)
    np.testing.assert_allclose(np.c_[tr.x_north, tr.y_east, tr.depth], a[:, 1:4], atol=1e-12)
    dyaw = (tr.yaw - a[:, 4] + math.pi) % (2 * math.pi) - math.pi
    np.testing.assert_allclose(dyaw, 0.0, atol=1e-12)
    np.testing.assert_allclose(np.c_[tr.u, tr.v, tr.w, tr.r], a[:, 5:9], atol=1e-12)
    assert len(tr) == 50


def test_sonar_images_points_and_frame(tmp_path: Path) -> None:
    path = tmp_path / "sonar.mcap"
    polar = np.arange(256 * 30, dtype=np.uint32).reshape(256, 30).astype(np.uint8)
    fan = np.tri(40, 60, dtype=np.uint8) * 200
    pts_frd = np.array([[10.0, 2.0, 1.0], [5.0, -3.0, 0.5]])
    tilt, heading = math.radians(20.0), math.radians(30.0)
    r_ned = rotation_zyx(0.0, -tilt, heading)  # pitch < 0 is nose down: tilt 20° down
    with McapRecorder(path) as rec:
        rec.write_sonar("rov", "sonar", 3.0, polar, fan, pts_frd, np.array([0.25, 0.75]),
                        ((1.0, 2.0, 3.0), r_ned))
    got = {m.topic: m.message for m in iter_messages(path)}
    img = got["/rov/sonar/polar"]
    assert (img.height, img.width, img.step, img.encoding) == (256, 30, 30, "mono8")
    np.testing.assert_array_equal(np.frombuffer(img.data, np.uint8).reshape(256, 30), polar)
    img = got["/rov/sonar/fan"]
    np.testing.assert_array_equal(np.frombuffer(img.data, np.uint8).reshape(40, 60), fan)
    assert img.header.frame_id == "rov/sonar"
    cloud = got["/rov/sonar/points"]
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "intensity"]
    xyzi = np.frombuffer(cloud.data, "<f4").reshape(-1, 4)
    # FRD (fwd, starboard, down) → FLU (fwd, port, up)
    np.testing.assert_allclose(xyzi, [[10, -2, -1, 0.25], [5, 3, -0.5, 0.75]], atol=1e-6)
    tf = got["/tf"].transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("map", "rov/sonar")
    tr = tf.transform.translation
    assert (tr.x, tr.y, tr.z) == pytest.approx((2.0, 1.0, -3.0))
    # The sonar looks 30° east of north, 20° down: in ENU that's
    # (cos20 sin30, cos20 cos30, -sin20).
    fwd = rotate(tf.transform.rotation, [1.0, 0.0, 0.0])
    expected = [math.cos(tilt) * math.sin(heading), math.cos(tilt) * math.cos(heading),
                -math.sin(tilt)]
    assert fwd == pytest.approx(expected, abs=1e-12)


def test_camera_mount_on_tf_static_and_pose_not_on_tf(tmp_path: Path) -> None:
    """A camera tilted 20° down, 0.3 m ahead and 0.1 m below base_link: its optical frame
    (x right, y down, z forward; REP-103) on /tf_static, worked out by hand in FLU; the
    picture's topics carry that frame, and /tf gets no map -> camera_optical (issue 16)."""
    tilt = math.radians(20.0)
    mount = rotation_zyx(0.0, -tilt, 0.0)  # camera (fwd, right, down) -> body FRD
    rgb = np.zeros((4, 6, 3), np.uint8)
    labels = np.arange(24, dtype=np.uint8).reshape(4, 6)
    k = [[5.0, 0.0, 2.5], [0.0, 5.0, 1.5], [0.0, 0.0, 1.0]]
    heading = math.radians(90.0)  # the vehicle faces east: base_link = ENU axes
    pose = ((1.0, 2.0, 3.0), rotation_zyx(0.0, 0.0, heading) @ mount)
    paths = {name: tmp_path / f"{name}.mcap" for name in ("mounted", "unmounted")}
    with McapRecorder(paths["mounted"]) as rec:
        rec.write_static_transforms(0.0, [("rov/base_link", "rov/camera_optical",
                                           (0.3, 0.0, 0.1), optical_rotation(mount))])
        rec.write_camera("rov", "camera", 0.5, rgb, None, labels, k, pose)
    with McapRecorder(paths["unmounted"]) as rec:
        rec.write_camera("rov", "camera", 0.5, rgb, None, None, k, pose)
    got = {m.topic: m.message for m in iter_messages(paths["mounted"])}
    assert set(got) == {"/tf_static", "/rov/camera/image_raw", "/rov/camera/camera_info",
                        "/rov/camera/labels", "/rov/camera/pose"}
    (tf,) = got["/tf_static"].transforms
    assert (tf.header.frame_id, tf.child_frame_id) == ("rov/base_link", "rov/camera_optical")
    tr, q = tf.transform.translation, tf.transform.rotation
    assert (tr.x, tr.y, tr.z) == pytest.approx((0.3, 0.0, -0.1))  # FLU: z up
    s20, c20 = math.sin(tilt), math.cos(tilt)
    assert rotate(q, [0, 0, 1]) == pytest.approx([c20, 0.0, -s20], abs=1e-12)  # forward
    assert rotate(q, [1, 0, 0]) == pytest.approx([0.0, -1.0, 0.0], abs=1e-12)  # right
    assert rotate(q, [0, 1, 0]) == pytest.approx([-s20, 0.0, -c20], abs=1e-12)  # down
    for topic in ("/rov/camera/image_raw", "/rov/camera/camera_info", "/rov/camera/labels"):
        assert got[topic].header.frame_id == "rov/camera_optical"
    np.testing.assert_array_equal(
        np.frombuffer(got["/rov/camera/labels"].data, np.uint8).reshape(4, 6), labels)
    # the picture's pose: ENU (2, 1, -3), looking east and 20° down
    cam = got["/rov/camera/pose"]
    assert cam.header.frame_id == "map"
    p = cam.pose.position
    assert (p.x, p.y, p.z) == pytest.approx((2.0, 1.0, -3.0))
    assert rotate(cam.pose.orientation, [0, 0, 1]) == pytest.approx([c20, 0.0, -s20],
                                                                      abs=1e-12)
    # without a mount on /tf_static the frame goes on /tf, with the same pose
    got = {m.topic: m.message for m in iter_messages(paths["unmounted"])}
    assert "/rov/camera/labels" not in got
    (tf,) = got["/tf"].transforms
    assert (tf.header.frame_id, tf.child_frame_id) == ("map", "rov/camera_optical")
    q, q_pose = tf.transform.rotation, cam.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (q_pose.x, q_pose.y, q_pose.z, q_pose.w)


def test_helm_variable_event_and_markers(tmp_path: Path) -> None:
    path = tmp_path / "misc.mcap"
    with McapRecorder(path) as rec:
        rec.write_helm_decision("rov", 1.0, 270.0, 0.8, None, {"trail": 60.5, "avoid": 12.25},
                                "TRAIL", ["trail", "avoid"])
        rec.write_helm_decision("rov", 2.0, 10.0, 0.0, 4.5, {}, "IDLE", [])
        rec.write_helm_decision("rov", 3.0, None, None, None, {"a": 1.0}, "STOP", [],
                                total=0.5, all_stop_reason="no decision")
        rec.write_variable("rov", 1.0, "DEPLOY", True, "pMarineViewer")
        rec.write_variable("rov", 1.0, "MODE", "ACTIVE:TRAIL", "helm")
        rec.write_event(1.25, "collision", "rov/piling_1")
        rec.write_scene_markers(0.0, [
            {"ns": "piling", "id": 1, "type": "box", "position_ned": (10.0, 20.0, 5.0),
             "scale": (1, 2, 3), "color": (1, 0, 0, 1)},
            {"ns": "path", "id": 2, "type": "line_strip",
             "points_ned": [[0.0, 0.0, 1.0], [3.0, 4.0, 2.0]], "position_ned": (1, 1, 1),
             "rotation": rotation_zyx(0.0, 0.0, 0.7)},
            {"ns": "rov", "id": 3, "type": "mesh", "mesh_resource": "package://uhrisim/rov.stl"},
            {"ns": "rock", "id": 4, "type": "triangle_list", "position_ned": (5, 5, 5),
             "points_ned": [[5, 5, 5], [6, 5, 5], [5, 6, 5]]},
        ])
    got: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for c, _t, raw in reader.messages():
            got.setdefault(c.topic, []).append(reader.deserialize(raw, c.msgtype))
    d0, d1, d2 = got["/rov/helm/decision"]
    assert (d0.heading_deg, d0.speed, d0.has_depth, d0.mode) == (270.0, 0.8, False, "TRAIL")
    assert (d0.has_heading, d0.has_speed, d0.all_stop_reason) == (True, True, "")
    assert (d2.has_heading, d2.has_speed, d2.has_depth) == (False, False, False)
    assert (d2.total, d2.all_stop_reason) == (0.5, "no decision")
    assert [(c.name, c.value) for c in d0.contributions] == [("trail", 60.5), ("avoid", 12.25)]
    assert d0.total == 72.75 and list(d0.active_behaviors) == ["trail", "avoid"]
    assert (d1.has_depth, d1.depth, d1.total, d1.contributions) == (True, 4.5, 0.0, [])
    v0, v1 = got["/rov/vars"]
    assert (v0.name, v0.kind, v0.double_value, v0.source) == ("DEPLOY", 0, 1.0, "pMarineViewer")
    assert (v1.kind, v1.string_value) == (1, "ACTIVE:TRAIL")
    (ev,) = got["/events"]
    assert (ev.kind, ev.detail, ev.header.stamp.nanosec) == ("collision", "rov/piling_1", 250e6)
    box, line, mesh, tri = got["/scene/markers"][0].markers
    assert (box.type, box.header.frame_id) == (1, "map")
    assert (box.pose.position.x, box.pose.position.y, box.pose.position.z) == (20, 10, -5)
    # identity FRD→NED: body x north ⇒ ENU yaw +90°
    assert yaw_enu_of(box.pose.orientation) == pytest.approx(math.pi / 2)
    assert (box.scale.x, box.scale.y, box.scale.z) == (1, 2, 3)
    assert (box.color.r, box.color.a) == (1.0, 1.0)
    # line points are in the marker's frame; mapped back to world they are the ENU points
    world = [np.array([line.pose.position.x, line.pose.position.y, line.pose.position.z])
             + rotate(line.pose.orientation, [p.x, p.y, p.z]) for p in line.points]
    np.testing.assert_allclose(world, [[0, 0, -1], [4, 3, -2]], atol=1e-12)
    assert (mesh.type, mesh.mesh_resource) == (10, "package://uhrisim/rov.stl")
    # triangle vertices relative to the marker origin, in its FLU frame (x north → ENU y)
    assert tri.type == 11
    local = [(p.x, p.y, p.z) for p in tri.points]
    np.testing.assert_allclose(local, [[0, 0, 0], [1, 0, 0], [0, -1, 0]], atol=1e-12)


def test_same_calls_give_byte_identical_files(tmp_path: Path) -> None:
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    synthetic_run(a, chunk_size=8192)
    synthetic_run(b, chunk_size=8192)
    assert a.read_bytes() == b.read_bytes()
    # and the content depends on what was written
    c = tmp_path / "c.mcap"
    with McapRecorder(c, chunk_size=8192) as rec:
        rec.write_odometry("rov", 0.0, (0, 0, 0), 0.0, (0, 0, 0), 0.0)
    with McapRecorder(b, chunk_size=8192) as rec:
        rec.write_odometry("rov", 0.0, (0, 0, 1e-9), 0.0, (0, 0, 0), 0.0)
    assert c.read_bytes() != b.read_bytes()


def test_close_is_idempotent_and_writes_after_close_fail(tmp_path: Path) -> None:
    rec = McapRecorder(tmp_path / "x.mcap")
    rec.write_event(0.0, "start", "")
    rec.flush()
    rec.close()
    rec.close()
    assert rec.closed
    with pytest.raises(UhrisimError, match="closed"):
        rec.write_event(1.0, "late", "")
    assert summarize(tmp_path / "x.mcap").topics == {"/events": ("uhrisim_msgs/msg/Event", 1)}


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda r: r.write_odometry("rov 1", 0, (0, 0, 0), 0, (0, 0, 0), 0), "not a ROS name"),
        (lambda r: r.write_odometry("rov", -1, (0, 0, 0), 0, (0, 0, 0), 0), "time must be"),
        (lambda r: r.write_odometry("rov", 0, (0, 0), 0, (0, 0, 0), 0), "position_ned"),
        (lambda r: r.write_odometry("rov", 0, (0, 0, 0), math.nan, (0, 0, 0), 0), "finite"),
        (lambda r: r.write_sonar("rov", "sonar", 0, np.zeros((4, 4)), None, None, None,
                                 ((0, 0, 0), np.eye(3))), "uint8"),
        (lambda r: r.write_sonar("rov", "sonar", 0, None, None, np.zeros((3, 2)), None,
                                 ((0, 0, 0), np.eye(3))), r"\(N, 3\)"),
        (lambda r: r.write_sonar("rov", "sonar", 0, None, None, None, None,
                                 ((0, 0, 0), 2 * np.eye(3))), "rotation"),
        (lambda r: r.write_variable("rov", 0, "X", [1], "me"), "number or a string"),
        (lambda r: r.write_scene_markers(0, [{"ns": "a", "id": 1, "type": "cone"}]), "cone"),
        (lambda r: r.write_scene_markers(0, [{"ns": "a", "id": 1, "type": "box", "colour": 1}]),
         "unknown keys"),
        (lambda r: r.write_scene_markers(0, [{"ns": "a", "id": 1, "type": "line_strip"}]),
         "needs points_ned"),
        (lambda r: r.write_scene_markers(0, [{"ns": "a", "id": 1, "type": "triangle_list",
                                              "points_ned": [[0, 0, 0], [1, 0, 0]]}]), "3k"),
    ],
)
def test_bad_input_raises_config_error(tmp_path: Path, call, match: str) -> None:
    with McapRecorder(tmp_path / "bad.mcap") as rec, pytest.raises(ConfigError, match=match):
        call(rec)


def test_bad_constructor_arguments(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="compression"):
        McapRecorder(tmp_path / "a.mcap", compression="gzip")
    with pytest.raises(ConfigError, match="chunk_size"):
        McapRecorder(tmp_path / "a.mcap", chunk_size=0)
    with pytest.raises(UhrisimError, match="cannot open"):
        McapRecorder(tmp_path / "no" / "such" / "dir.mcap")
