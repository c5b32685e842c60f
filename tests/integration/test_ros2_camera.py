"""The camera through the ROS 2 bridge: the real simulation (camera_trail scenario) with
the bridge hook, and a plain-rclpy subscriber in another process
(tests/support/ros2_camera_listener.py). Expected numbers come from the simulation's own
frames: the received image is the frame rendered at its stamp (byte checksum), the
CameraInfo carries the camera's K, the depth image is 32FC1 of the same size, the label
image is the frame's labels + 1.

As a ROS user places a pixel (issue 16): back-projected with K and its depth into
``<agent>/camera_optical`` (x right, y down, z forward), then through ``map -> <agent>/odom
-> <agent>/base_link`` (/tf at the picture's stamp) and ``base_link -> camera_optical``
(/tf_static, the mount), it must land within 1 cm of where the simulation's camera saw
the surface along that pixel's ray (its range image, the pinhole ray from the camera's
pose); and that chain must be the ``camera/pose`` it publishes."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")
pytest.importorskip("tf2_msgs", reason="tf2_msgs not built: python -m "
                    "uhrisim.bridges.ros2.interfaces")

from tests.support.children import Child
from uhrisim.bridges.ros2.hook import Ros2BridgeHook
from uhrisim.core.frames import enu_from_ned
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "camera_trail.yaml"


def _matrix(q: list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _compose(chain: list) -> tuple[np.ndarray, np.ndarray]:
    """``(translation, rotation)`` of the last child frame of ``chain`` (parent first,
    rows ``[parent, child, t, q]``) in its first parent."""
    rotation, position = np.eye(3), np.zeros(3)
    for _parent, _child, t, q in chain:
        position = position + rotation @ np.asarray(t)
        rotation = rotation @ _matrix(q)
    return position, rotation


def test_camera_frames_reach_another_process(ros_env: int, tmp_path: Path) -> None:
    # reliable sensor topics (the bridge's reliable_sensors) and a reliable subscriber, so
    # that every picture counts; with the default best effort a loaded machine drops some
    # of these 230 kB messages (fragments lost), by design of the sensor-data QoS
    hook = Ros2BridgeHook(domain_id=ros_env, odom_rate_hz=None, node_name="uhrisim_cam_test",
                          agents=["videoray"], accept=(), reliable_sensors=True)
    sim = Simulation(load_scenario(SCENARIO), hooks=[hook], seed=1)
    child = Child("ros2_camera_listener.py", ["--agent", "videoray", "--reliable"], tmp_path)
    frames = {}
    try:
        sim.start()
        bridge = hook.bridge
        assert bridge is not None
        child.expect("READY")
        topics = [f"/videoray/camera/{k}" for k in ("image_raw", "camera_info", "depth",
                                                    "labels", "pose")] + ["/tf", "/tf_static"]
        assert bridge.wait_for_subscribers(topics, 120.0)  # the writers matched the readers
        for _ in range(round(1.0 / sim.dt)):  # 1 s: 10 camera frames, paced at real time
            tick = sim.step()
            if tick.images:
                image = tick.images["videoray/camera"]
                frames[divmod(round(image.t * 1e9), 1_000_000_000)] = image
            time.sleep(sim.dt)
        # the listener answers once it has every picture still in flight
        result = child.result(counts=dict.fromkeys(topics[:5], len(frames)))
    finally:
        child.finish()
        sim.close()
    assert len(frames) == 10
    image = result["/videoray/camera/image_raw"]
    info = result["/videoray/camera/camera_info"]
    depth = result["/videoray/camera/depth"]
    labels = result["/videoray/camera/labels"]
    assert image["count"] == info["count"] == depth["count"] == labels["count"] == 10
    assert result["/videoray/camera/pose"]["count"] == 10
    first = image["first"]
    sent = frames[tuple(first["stamp"])]
    assert first["frame_id"] == "videoray/camera_optical"
    assert (first["height"], first["width"], first["encoding"], first["step"]) == (
        240, 320, "rgb8", 960)
    assert first["checksum"] == int(sent.rgb.astype(np.int64).sum() % 1_000_003)
    np.testing.assert_allclose(np.array(info["first"]["k"]).reshape(3, 3), sent.K)
    assert info["first"]["distortion_model"] == "plumb_bob"
    d = depth["first"]
    assert (d["encoding"], d["step"], d["nbytes"]) == ("32FC1", 4 * 320, 4 * 320 * 240)
    lab = labels["first"]
    assert (lab["encoding"], lab["frame_id"]) == ("mono8", "videoray/camera_optical")
    sent = frames[tuple(lab["stamp"])]
    assert lab["checksum"] == int((sent.labels.astype(np.int64) + 1).sum() % 1_000_003)

    # /tf_static: the mounts, each once (the diver has no sensor)
    tf = result["tf"]
    static = {(p, c): row for row in tf["static"] for p, c in [row[:2]]}
    assert set(static) == {("videoray/base_link", "videoray/sonar"),
                           ("videoray/base_link", "videoray/camera_optical")}
    mount = static[("videoray/base_link", "videoray/camera_optical")]
    assert not any(row[1].endswith("camera_optical") for rows in tf["dynamic"].values()
                   for row in rows)  # on /tf_static, so not on /tf
    fx, fy, cx, cy = sent.K[0, 0], sent.K[1, 1], sent.K[0, 2], sent.K[1, 2]
    placed = 0
    for stamp, samples in tf["depth"].items():
        sec, nanosec = (int(x) for x in stamp.split("."))
        frame = frames[(sec, nanosec)]
        dynamic = {(p, c): row for row in tf["dynamic"][stamp] for p, c in [row[:2]]}
        chain = [dynamic[("map", "videoray/odom")],
                 dynamic[("videoray/odom", "videoray/base_link")], mount]
        position, rotation = _compose(chain)  # camera_optical in map
        pose = tf["poses"][stamp]
        assert pose["frame_id"] == "map"
        np.testing.assert_allclose(position, pose["position"], atol=1e-9)
        np.testing.assert_allclose(rotation, _matrix(pose["orientation"]), atol=1e-9)
        # the pixels as a ROS user back-projects them: K^-1 (u, v, 1) x depth
        u, v, z = np.asarray(samples).T
        p_optical = np.stack([(u - cx) / fx * z, (v - cy) / fy * z, z], axis=1)
        got = p_optical @ rotation.T + position
        # where the camera saw the surface: its range along the pinhole ray of the pixel,
        # camera frame x forward, y right, z down, from its pose (NED)
        ui, vi = u.astype(int), v.astype(int)
        ray = np.stack([np.ones_like(u), (u - cx) / fx, (v - cy) / fy], axis=1)
        ray /= np.linalg.norm(ray, axis=1, keepdims=True)
        hit_ned = frame.position_ned + (frame.range_m[vi, ui][:, None] * ray) @ (
            frame.rotation_ned_from_camera.T)
        np.testing.assert_allclose(got, enu_from_ned(hit_ned), atol=0.01)  # within 1 cm
        placed += len(samples)
    assert len(tf["depth"]) == 10 and placed > 100, "too few pixels placed through /tf"
