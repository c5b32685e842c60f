"""The paper's feature step: corners and edges of the sonar image → obstacle points."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.perception.features import FeatureParams, extract_features, valid_mask
from uhrisim.sensors.sonar import ImagingSonar, SonarConfig
from uhrisim.sensors.sonar.config import ECHOES_ONLY
from uhrisim.world.paper_scenes import single_piling_scene


def _ping(mode: str, with_floor: bool, speckle: bool = True, seed: int = 3):
    # The echoes alone (ECHOES_ONLY): the grey, speckled noise and reverberation of the
    # default image give the corner detector features anywhere in the fan.
    # 0.4 m piling whose centre is 12 m away at bearing 6°; level sonar at 4 m depth.
    paper = single_piling_scene(12.0, 6.0, width=0.4, with_floor=with_floor)
    cfg = SonarConfig(
        tilt_deg=10.0, mount_position_frd=(0.0, 0.0, 0.0), range_max_m=20.0, mode=mode,
        speckle=speckle, labels=True, **ECHOES_ONLY,
    )  # fmt: skip
    pose = paper.sonar_poses["origin"]
    sonar = ImagingSonar(cfg, np.random.default_rng(seed))
    return sonar.ping(paper.scene.raycaster("embree"), pose.position_ned, pose.rotation, 2.0)


# Nearest face of the piling, horizontal NED (its centre minus half the width, bearing 6°).
B = math.radians(6.0)
FACE_NE = np.array([11.8 * math.cos(B), 11.8 * math.sin(B)])


@pytest.mark.parametrize("mode", ["physical", "2013"])
def test_features_sit_on_the_piling(mode: str) -> None:
    ping = _ping(mode, with_floor=False)
    f = extract_features(ping)
    assert len(f.corners_ned) >= 1 and len(f.edges_ned) >= 1
    # Without a floor the piling is the only object: every feature lies on it or on its
    # beam-pattern wings. Range: the 20° aperture (tilt 10°: rays 0…20° down) sees the
    # vertical face from 11.8 m out to 11.8/cos 20° = 12.56 m (a sonar image has no
    # elevation); the 2013 mode drops z in the tilted frame, pulling points in by up to
    # 1 − cos 10° (0.2 m); the 5 px blur adds ±0.2 m. Across: the face (±0.2 m), the
    # main lobe and side lobes (±2.5° ≈ ±0.5 m at 12 m) and the blur (±0.2 m).
    for pts in (f.corners_sonar, f.edges_sonar):
        r = np.hypot(pts[:, 0], pts[:, 1])
        assert r.min() > 11.3 and r.max() < 12.9
    for pts in (f.corners_ned, f.edges_ned):
        bearing = np.arctan2(pts[:, 1], pts[:, 0]) - B
        across = np.hypot(pts[:, 0], pts[:, 1]) * np.sin(bearing)
        assert np.abs(across).max() < 0.95
    # The strongest corner is at the leading face (within 0.5 m).
    assert np.hypot(*(f.corners_ned[0, :2] - FACE_NE)) < 0.5
    # Points are in the sonar's plane, mapped to NED through the ping pose (sonar 4 m deep,
    # tilted 10°: z_NED = 4 + x·sin 10°).
    x = f.corners_sonar[:, 0]
    np.testing.assert_allclose(f.corners_ned[:, 2], 4.0 + x * math.sin(math.radians(10.0)))
    assert f.t == 2.0


def test_pixel_to_sonar_round_trip_physical() -> None:
    ping = _ping("physical", with_floor=False, speckle=False)
    # The apex maps to the sonar origin; one metre ahead is fan_px_per_m rows above it.
    c0, r0 = ping.fan_apex_px
    s = ping.fan_px_per_m
    pts = ping.fan_pixels_to_sonar(np.array([[c0, r0], [c0, r0 - s], [c0 + s, r0 - 2 * s]]))
    np.testing.assert_allclose(pts, [[0, 0, 0], [1, 0, 0], [2, 1, 0]], atol=1e-12)


def test_2013_boundary_lines_are_not_features() -> None:
    ping = _ping("2013", with_floor=False)
    mask = valid_mask(ping, FeatureParams())
    # The white boundary lines (drawn from the apex at the top-left) lie outside the mask.
    lines = ping.fan_u8 == 255
    lines[ping.label_fan >= 0] = False
    assert lines.sum() > 100 and not (lines & mask).any()
    f = extract_features(ping)
    r = np.hypot(f.edges_sonar[:, 0], f.edges_sonar[:, 1])
    assert (np.abs(r - 12.0) < 0.8).all()


def test_params_validation() -> None:
    with pytest.raises(ConfigError, match=r"FeatureParams\.blur_ksize"):
        FeatureParams(blur_ksize=4)
    with pytest.raises(ConfigError, match=r"FeatureParams\.quality_level"):
        FeatureParams(quality_level=0.0)
