"""Reading the diver's slate from the ROV's rendered images: ArUco detection on the
simulated pixels, how it falls with range, turbidity and lamps, the slate's pose from the
corners, the confidence, and the marker → command table."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z, rotation_zyx
from uhrisim.experiments.signal_range import CAMERA_DEPTH_M, marker_trial, slate_scene
from uhrisim.perception.markers import (
    FULL_SEARCH_EVERY,
    MarkerCommands,
    MarkerReader,
    marker_signals,
)
from uhrisim.perception.signals import Command
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.world.slate import MarkerSlate

CAMERA = np.array([0.0, 0.0, CAMERA_DEPTH_M])


def _frame(slate: MarkerSlate, range_m: float, water: str = "I", east: float = 0.0,
           **camera):
    scene = slate_scene(range_m, slate)
    scene.set_pose("slate", (range_m, east, CAMERA_DEPTH_M), rot_z(math.pi))
    cfg = dict(water=jerlov(water), tilt_deg=0.0)
    cfg.update(camera)
    cam = UnderwaterCamera(CameraConfig(**cfg), np.random.default_rng(5))
    return cam.capture(scene.raycaster(), CAMERA, np.eye(3), 0.0)


@pytest.mark.slow
def test_a_slate_at_2_m_in_clear_water_is_read_in_95_percent_of_frames():
    """Jerlov I, lamps on, sensor noise, the hand moving the slate: 3 seeds x 10 frames."""
    trials = [marker_trial(2.0, "I", True, seed, frames=10) for seed in (1, 2, 3)]
    read = sum(t.read for t in trials) / sum(t.frames for t in trials)
    assert read >= 0.95, [t.rate for t in trials]
    assert sum(t.false for t in trials) == 0
    errors = np.concatenate([t.range_errors_m for t in trials])
    assert np.abs(errors).max() < 0.05  # m, of 2 m


@pytest.mark.slow
def test_recognition_falls_with_range_and_turbidity():
    """Clear water reads far; coastal 3C only close, and better without the lamps' veil
    at 1 m; coastal 9C not even at 1 m (docs/hri.md has the whole table)."""
    def rate(r: float, water: str, lamps: bool = True) -> float:
        return marker_trial(r, water, lamps, seed=7, frames=6).rate

    assert rate(2.0, "I") == 1.0
    assert rate(15.0, "I") == 0.0
    assert rate(1.0, "3C", lamps=False) == 1.0
    assert rate(1.0, "3C", lamps=True) < rate(1.0, "3C", lamps=False)
    assert rate(2.0, "3C") < rate(2.0, "I")
    assert rate(1.0, "9C") == 0.0


def test_searching_where_the_slate_is_expected_reads_what_the_whole_picture_reads():
    """The ROV's camera (320 × 240) at 2 m in clear water, the hand moving the slate: told
    where it is within 0.15 m (each way, 1 σ, as from the diver's track), the reader
    searches only there and reads every frame the whole picture's search reads, the same
    corners to float32 rounding (the detector sees the same pixels around the marker)."""
    slate = MarkerSlate(4)
    scene = slate_scene(2.0, slate)
    caster = scene.raycaster()
    rng = np.random.default_rng(4)
    camera = UnderwaterCamera(CameraConfig(width=320, height=240, water=jerlov("I"),
                                           tilt_deg=0.0), rng)
    whole, near = MarkerReader(), MarkerReader()
    for k in range(FULL_SEARCH_EVERY):
        position = np.array([2.0, rng.uniform(-0.3, 0.3), CAMERA_DEPTH_M])
        pitch, yaw = (math.radians(rng.uniform(-a, a)) for a in (15.0, 25.0))
        scene.set_pose("slate", position, rotation_zyx(0.0, pitch, math.pi + yaw))
        frame = camera.capture(caster, CAMERA, np.eye(3), 0.1 * k)
        (a,) = whole.read(frame)
        (b,) = near.read(frame, position + rng.normal(0.0, 0.15, 3))
        assert a.marker_id == b.marker_id == 4
        np.testing.assert_allclose(b.corners, a.corners, atol=1e-3)  # px
        assert b.confidence == pytest.approx(a.confidence, abs=1e-3)
    assert near._frames_since_full == FULL_SEARCH_EVERY - 1  # the region since the first


def test_a_slate_where_none_is_expected_is_found_by_the_whole_picture_search():
    """Expected 3 m off to the side (out of view) it is read in the frames of the whole
    picture's search only; behind the camera the search is the whole picture."""
    frame = _frame(MarkerSlate(4), 2.0, noise=False)
    reader = MarkerReader()
    off = np.array([2.0, 3.0, CAMERA_DEPTH_M])
    x0, _, x1, _ = reader.search_region(frame, off)
    assert x0 == x1 == frame.rgb.shape[1]  # right of the picture: nothing to search
    read = [bool(reader.read(frame, off)) for _ in range(2 * FULL_SEARCH_EVERY + 1)]
    assert [k for k, r in enumerate(read) if r] == [0, FULL_SEARCH_EVERY, 2 * FULL_SEARCH_EVERY]
    assert reader.search_region(frame, np.array([-1.0, 0.0, CAMERA_DEPTH_M])) is None
    assert all(reader.read(frame, np.array([-1.0, 0.0, CAMERA_DEPTH_M])) for _ in range(3))


def test_pose_from_the_corners_is_where_the_slate_is():
    """An off-axis slate at 3 m: range, bearing and NED position from solvePnP with the
    camera's K against the truth; the detected corners within 1.5 px of the projected
    printed ones (the camera samples one ray per pixel, no anti-aliasing: an edge falls
    on the pixel grid; a 27-pixel marker's size is then known to about 5 %)."""
    slate = MarkerSlate(4)
    frame = _frame(slate, 3.0, east=0.6, noise=False)
    (d,) = MarkerReader().read(frame)
    assert d.marker_id == 4 and d.command == Command("light_here")
    R_slate = rot_z(math.pi)
    corners_ned = np.array([3.0, 0.6, CAMERA_DEPTH_M]) + slate.marker_corners() @ R_slate.T
    centre = corners_ned.mean(axis=0)
    offset = centre - frame.position_ned
    assert d.range_m == pytest.approx(float(np.linalg.norm(offset)), rel=0.05)
    assert d.bearing_deg == pytest.approx(math.degrees(math.atan2(offset[1], offset[0])),
                                          abs=0.3)
    assert d.elevation_deg == pytest.approx(0.0, abs=0.3)
    np.testing.assert_allclose(d.position_ned, centre, atol=0.15)
    cam = (corners_ned - frame.position_ned) @ frame.rotation_ned_from_camera
    uv = (frame.K @ np.stack([cam[:, 1], cam[:, 2], cam[:, 0]]) / cam[:, 0]).T[:, :2]
    np.testing.assert_allclose(d.corners, uv, atol=1.5)  # px


def test_confidence_is_opencvs_definition_and_falls_with_turbidity():
    """1 − the share of the code's pixels read wrong: about 1 in clear water close by,
    lower in 3C; within 0.08 of OpenCV's own detectMarkersWithConfidence (which samples
    4 px per cell without a margin) where this OpenCV has it."""
    slate = MarkerSlate(4)
    reader = MarkerReader()
    clear = _frame(slate, 2.0, "I")
    murky = _frame(slate, 1.5, "3C")
    (c,), (m,) = reader.read(clear), reader.read(murky)
    assert c.confidence > 0.98 > m.confidence > 0.8
    assert c.contrast > m.contrast
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    if not hasattr(detector, "detectMarkersWithConfidence"):
        pytest.skip("this OpenCV has no detectMarkersWithConfidence (OpenCV >= 4.13)")
    for frame, ours in ((clear, c), (murky, m)):
        grey = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)
        _, ids, theirs, _ = detector.detectMarkersWithConfidence(grey)
        assert list(ids.ravel()) == [4]
        assert ours.confidence == pytest.approx(float(np.ravel(theirs)[0]), abs=0.08)


def test_a_mirrored_print_is_not_read():
    """The marker is read upright: seen from behind the slate's back face would show a
    mirror image; a mirrored picture is not a marker of the dictionary."""
    slate = MarkerSlate(4)
    frame = _frame(slate, 2.0, noise=False)
    assert [d.marker_id for d in MarkerReader().read(frame)] == [4]
    mirrored = np.ascontiguousarray(frame.rgb[:, ::-1])
    assert 4 not in [d.marker_id for d in MarkerReader().read_image(mirrored, frame.K)]


def test_signals_carry_the_command_and_the_confidence():
    frame = _frame(MarkerSlate(13), 2.0)
    detections = MarkerReader().read(frame)
    (signal,) = marker_signals(detections, t=12.5)
    assert signal.command == Command("bring_tool", "lift_bag")
    assert (signal.channel, signal.t) == ("marker", 12.5)
    assert signal.confidence == detections[0].confidence
    assert marker_signals(detections, 12.5, min_confidence=1.01) == []
    unmapped = MarkerReader(MarkerCommands(commands={}))
    assert marker_signals(unmapped.read(frame), 12.5) == []


def test_shipped_table_and_one_line_errors():
    table = MarkerCommands.load()
    assert table.commands[1] == Command("stop")
    assert table.commands[10] == Command("bring_tool", "wrench")
    bad = [({"commands": {"60": "stop"}}, "marker id 60 is not in DICT_4X4_50"),
           ({"commands": {"x": "stop"}}, "markers.commands: marker id must be an integer"),
           ({"commands": {"3": "jump"}}, "markers.commands.3: unknown command 'jump'"),
           ({"commands": {"3": "bring_tool"}}, "markers.commands.3: bring_tool needs an"),
           ({"commands": {"3": "stop now"}}, "markers.commands.3: stop takes no argument"),
           ({"commands": {}, "dictionary": "DICT_9X9"}, "unknown ArUco dictionary"),
           ({"commands": {}, "colour": 1}, r"markers: unknown field\(s\) \['colour'\]")]
    for data, message in bad:
        with pytest.raises(ConfigError, match=message) as error:
            MarkerCommands.from_mapping(data)
        assert "\n" not in str(error.value)
