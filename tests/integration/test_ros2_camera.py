"""The camera through the ROS 2 bridge: the real simulation (camera_trail scenario) with
the bridge hook, and a plain-rclpy subscriber in another process
(tests/support/ros2_camera_listener.py). Expected numbers come from the simulation's own
frames: the received image is the frame rendered at its stamp (byte checksum), the
CameraInfo carries the camera's K, and the depth image is 32FC1 of the same size."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from tests.support.children import Child
from uhrisim.bridges.ros2.hook import Ros2BridgeHook
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "camera_trail.yaml"


def test_camera_frames_reach_another_process(ros_env: int, tmp_path: Path) -> None:
    # reliable sensor topics (the bridge's reliable_sensors) and a reliable subscriber, so
    # that every picture counts; with the default best effort a loaded machine drops some
    # of these 230 kB messages (fragments lost), by design of the sensor-data QoS
    hook = Ros2BridgeHook(domain_id=ros_env, odom_rate_hz=10.0, node_name="uhrisim_cam_test",
                          agents=["videoray"], accept=(), reliable_sensors=True)
    sim = Simulation(load_scenario(SCENARIO), hooks=[hook], seed=1)
    child = Child("ros2_camera_listener.py", ["--agent", "videoray", "--reliable"], tmp_path)
    frames = {}
    try:
        sim.start()
        bridge = hook.bridge
        assert bridge is not None
        child.expect("READY", timeout=40.0)
        topics = [f"/videoray/camera/{k}" for k in ("image_raw", "camera_info", "depth")]
        assert bridge.wait_for_subscribers(topics, 20.0)
        time.sleep(0.5)  # let the writers match the readers the graph already shows
        for _ in range(round(1.0 / sim.dt)):  # 1 s: 10 camera frames, paced at real time
            tick = sim.step()
            if tick.images:
                image = tick.images["videoray"]
                frames[divmod(round(image.t * 1e9), 1_000_000_000)] = image
            time.sleep(sim.dt)
        time.sleep(1.0)  # in flight
        child.send("STOP")
        result = json.loads(child.expect("RESULT"))
        assert child.finish() == 0
    finally:
        child.finish()
        sim.close()
    assert len(frames) == 10
    image = result["/videoray/camera/image_raw"]
    info = result["/videoray/camera/camera_info"]
    depth = result["/videoray/camera/depth"]
    assert image["count"] == info["count"] == depth["count"] == 10
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
