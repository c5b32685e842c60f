"""The paper's mission with the VideoRay's camera: stepped by the simulation at its rate,
recorded as sensor_msgs/Image + CameraInfo (+ depth, labels, pose, the mount on
/tf_static) and read back with an independent reader (rosbags); the same seed gives the
same images."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uhrisim.app.runner import run_scenario
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "camera_trail.yaml"
RUN_S = 2.0


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return run_scenario(SCENARIO, tmp_path_factory.mktemp("camera"), duration=RUN_S)


def test_camera_steps_at_its_rate_beside_the_sonar():
    sim = Simulation(load_scenario(SCENARIO))
    frames, pings = [], 0
    for _ in range(round(1.0 / sim.dt)):
        tick = sim.step()
        pings += len(tick.pings)
        if tick.images:
            frames.append(tick.images["videoray/camera"])
    assert len(frames) == 10 and pings == 15  # 10 Hz camera, 15 Hz sonar, for 1 s
    assert [round(f.t, 6) for f in frames] == [round(0.1 * k, 6) for k in range(1, 11)]
    first = frames[0]
    assert first.rgb.shape == (240, 320, 3) and first.rgb.dtype == np.uint8
    # the camera never sees its own vehicle
    assert "rov" not in {first.label_names[i] for i in np.unique(first.labels) if i >= 0}


def _matrix(q) -> np.ndarray:
    """Rotation matrix of a geometry_msgs Quaternion."""
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _stamp(header) -> tuple[int, int]:
    return header.stamp.sec, header.stamp.nanosec


def test_recording_reads_back_as_image_and_camera_info(run):
    from rosbags.highlevel import AnyReader

    images, infos, depths, labels, poses, statics = [], [], [], [], [], []
    tf = {}  # (stamp, child) -> transform of /tf
    with AnyReader([run.out_dir / "recording.mcap"]) as reader:
        for connection, _, raw in reader.messages():
            topic = connection.topic
            if not topic.startswith(("/videoray/camera", "/tf")):
                continue
            msg = reader.deserialize(raw, connection.msgtype)
            if topic == "/videoray/camera/image_raw":
                assert connection.msgtype == "sensor_msgs/msg/Image"
                images.append(msg)
            elif topic == "/videoray/camera/camera_info":
                assert connection.msgtype == "sensor_msgs/msg/CameraInfo"
                infos.append(msg)
            elif topic == "/videoray/camera/depth":
                depths.append(msg)
            elif topic == "/videoray/camera/labels":
                labels.append(msg)
            elif topic == "/videoray/camera/pose":
                assert connection.msgtype == "geometry_msgs/msg/PoseStamped"
                poses.append(msg)
            elif topic == "/tf_static":
                statics += msg.transforms
            elif topic == "/tf":
                tf.update({(_stamp(t.header), t.child_frame_id): t for t in msg.transforms})
    # 10 Hz for 2 s, every 10th frame recorded (recording.camera_every: 10)
    assert len(images) == len(infos) == len(depths) == len(labels) == len(poses) == 2
    img, info, depth = images[0], infos[0], depths[0]
    assert (img.height, img.width, img.encoding, img.step) == (240, 320, "rgb8", 960)
    assert img.header.frame_id == info.header.frame_id == "videoray/camera_optical"
    stamps = [(m.header.stamp.sec, m.header.stamp.nanosec) for m in images]
    assert stamps == [(0, 100_000_000), (1, 100_000_000)]  # frames 1 and 11
    k = np.array(info.k).reshape(3, 3)
    f = 160.0 / np.tan(np.radians(40.0))  # preset: 80 deg horizontal field of view
    np.testing.assert_allclose(k, [[f, 0, 159.5], [0, f, 119.5], [0, 0, 1]])
    np.testing.assert_allclose(np.array(info.p).reshape(3, 4)[:, :3], k)
    assert depth.encoding == "32FC1" and depth.step == 4 * 320
    z = np.frombuffer(bytes(depth.data), "<f4").reshape(240, 320)
    assert np.isfinite(z).mean() > 0.05 and np.nanmin(z) > 0.0
    lab = np.frombuffer(bytes(labels[0].data), np.uint8).reshape(240, 320)
    assert np.array_equal(np.isfinite(z), lab > 0)  # depth where something was seen
    # the optical z axis (forward) in ENU matches the camera's forward axis: vehicle
    # heading rotated down by the 5 deg tilt
    z_axis = _matrix(poses[0].pose.orientation)[:, 2]
    assert z_axis[2] == pytest.approx(-np.sin(np.radians(5.0)), abs=1e-6)  # looks down 5°
    # the mount is on /tf_static (once; the sonar's beside it) and not on /tf (issue 16)
    (mount,) = [t for t in statics if t.child_frame_id == "videoray/camera_optical"]
    assert mount.header.frame_id == "videoray/base_link"
    assert not any(child == "videoray/camera_optical" for _, child in tf)
    # map -> odom -> base_link (/tf at the picture's stamp) -> camera_optical (/tf_static)
    # is the camera pose the simulation reports
    for pose in poses:
        chain = [tf[(_stamp(pose.header), "videoray/odom")],
                 tf[(_stamp(pose.header), "videoray/base_link")], mount]
        rotation, position = np.eye(3), np.zeros(3)
        for link in chain:
            tr = link.transform
            t = np.array([tr.translation.x, tr.translation.y, tr.translation.z])
            position = position + rotation @ t
            rotation = rotation @ _matrix(tr.rotation)
        p = pose.pose.position
        np.testing.assert_allclose(position, [p.x, p.y, p.z], atol=1e-9)
        np.testing.assert_allclose(rotation, _matrix(pose.pose.orientation), atol=1e-9)


def test_same_seed_same_images_as_recorded(run):
    from rosbags.highlevel import AnyReader

    sim = Simulation(load_scenario(SCENARIO))
    for _ in range(round(0.1 / sim.dt)):
        tick = sim.step()
    shot = tick.images["videoray/camera"].rgb
    with AnyReader([run.out_dir / "recording.mcap"]) as reader:
        connection = next(c for c in reader.connections
                          if c.topic == "/videoray/camera/image_raw")
        _, _, raw = next(iter(reader.messages(connections=[connection])))
        msg = reader.deserialize(raw, connection.msgtype)
    np.testing.assert_array_equal(np.asarray(msg.data).reshape(240, 320, 3), shot)


@pytest.mark.parametrize(
    ("camera", "field"),
    [
        ("{type: camera, width: 0}", "sensors[1].width"),
        ("{type: camera, hfov_deg: 180}", "sensors[1].hfov_deg"),
        ("{type: camera, water: {attenuation: [0.4, -0.1, 0.5]}}",
         "sensors[1].water.attenuation[1]"),
        ("{type: camera, water: {jerlov: 5C}}", "sensors[1].water.jerlov"),
        ("{type: camera, rate_hz: 7}", "rate_hz: rate 7 Hz is not a whole number"),
    ],
)
def test_bad_camera_settings_are_one_line_errors(tmp_path, camera, field):
    from typer.testing import CliRunner

    from uhrisim.cli import app

    text = SCENARIO.read_text()
    start = text.index("      - type: camera")
    end = text.index("\n\n", start)
    path = tmp_path / "bad.yaml"
    path.write_text(text[:start] + f"      - {camera}" + text[end:])
    (tmp_path / "videoray_trail.bhv").write_text((SCENARIO.parent / "videoray_trail.bhv")
                                                 .read_text())
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "out"),
                                      "--duration", "0.1"])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and field in lines[0], lines


def test_recorded_camera_frames_replay_in_the_viewer(run):
    """The viewer's replay reads the recorded rgb8 pictures back, and a frame at a time
    carries the latest picture at or before it, once."""
    from uhrisim.viz.viewer.replay import ReplayPlayer, load_replay

    data = load_replay(run.out_dir / "recording.mcap")
    ts, images = data.shots["videoray/camera"]
    np.testing.assert_allclose(ts, [0.1, 1.1])
    assert images[0].shape == (240, 320, 3) and images[0].dtype == np.uint8
    player = ReplayPlayer(data, server=None)  # type: ignore[arg-type]
    (shot,) = player.frame_at(1.5)["camera"]
    assert (shot["agent"], shot["sensor"]) == ("videoray", "camera")
    assert shot["t"] == pytest.approx(1.1)
    assert shot["image"] is images[1]
    assert player.frame_at(1.6)["camera"] is None  # already sent
    assert player.frame_at(0.05)["camera"] is None  # nothing recorded yet
