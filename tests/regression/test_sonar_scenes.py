"""The imaging sonar in the world's scenes (Embree ray caster): targets where geometry says,
acoustic shadows behind them, the sea-floor band where the tilted beam meets the floor,
and the paper's torus (Figs 15-16) with the shadow of its inner ring."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.sensors.sonar import ImagingSonar, SonarConfig
from uhrisim.sensors.sonar.config import ECHOES_ONLY
from uhrisim.world.paper_scenes import single_piling_scene, torus_scene


def linear(ping, cfg: SonarConfig) -> np.ndarray:
    """Display-scale linear intensity from the log-compressed polar image."""
    return 10.0 ** ((ping.polar.astype(np.float64) - 1.0) * cfg.dynamic_range_db / 10.0)


def cfg_for(tilt_deg: float, **kw) -> SonarConfig:
    # The echoes of the geometry alone: no speckle, no diffuse terms (noise, reverberation
    # and far side lobes grey the shadows on purpose; test_sonar_tank.py measures them).
    base = dict(
        tilt_deg=tilt_deg, mount_position_frd=(0.0, 0.0, 0.0), speckle=False,
        dynamic_range_db=200.0, display_top_db=250.0, range_max_m=30.0, labels=True,
        **ECHOES_ONLY,
    )  # fmt: skip
    base.update(kw)
    return SonarConfig(**base)


def ping_scene(paper, pose_name: str, cfg: SonarConfig, seed: int = 0):
    pose = paper.sonar_poses[pose_name]
    sonar = ImagingSonar(cfg, np.random.default_rng(seed))
    rc = paper.scene.raycaster("embree")
    return sonar, sonar.ping(rc, pose.position_ned, pose.rotation, 0.0)


def beams_near(ping, bearing_deg: float, half_width_deg: float) -> np.ndarray:
    return np.flatnonzero(np.abs(np.degrees(ping.beam_angles_rad) - bearing_deg) <= half_width_deg)


def bins_between(ping, r0: float, r1: float) -> np.ndarray:
    return np.flatnonzero((ping.bin_ranges_m >= r0) & (ping.bin_ranges_m <= r1))


@pytest.mark.parametrize(("range_m", "bearing_deg"), [(12.0, 8.0), (7.0, -15.0), (20.0, 0.5)])
def test_single_piling_at_its_range_and_bearing(range_m: float, bearing_deg: float) -> None:
    # A 10 cm piling faced to the sonar: nearest surface at range − width/2. Level sonar at
    # 4 m over an 8 m floor: the floor enters the fan only beyond 4/sin(10°) = 23 m.
    width = 0.1
    paper = single_piling_scene(range_m, bearing_deg, width=width)
    cfg = cfg_for(0.0)
    _, ping = ping_scene(paper, "origin", cfg)
    img = linear(ping, cfg)
    b, j = np.unravel_index(np.argmax(img[: int(22.0 / cfg.bin_m)]), img.shape)
    expected_bin = math.floor((range_m - width / 2) / cfg.bin_m)
    spacing = math.radians(45.0 / 255.0)
    expected_beam = (math.radians(bearing_deg) + math.radians(22.5)) / spacing
    assert abs(b - expected_bin) <= 1
    assert abs(j - expected_beam) <= 1.0
    assert ping.label_polar[b, j] == paper.scene.label_id("piling")


def test_shadow_behind_piling() -> None:
    # 1 m piling 15 m ahead; sonar 4 m deep, tilted 10°: the floor (8 m) is lit from
    # 4/sin(20°) = 11.7 m out, except radially behind the piling.
    paper = single_piling_scene(15.0, 0.0, width=1.0)
    cfg = cfg_for(10.0)
    _, ping = ping_scene(paper, "origin", cfg)
    img = linear(ping, cfg)
    rows = bins_between(ping, 18.0, 28.0)
    shadow = img[np.ix_(rows, beams_near(ping, 0.0, 0.8))].mean()
    beside = img[np.ix_(rows, beams_near(ping, 10.0, 0.8))].mean()
    assert shadow < 0.05 * beside
    # Geometry: no ray reaches anything inside the shadow cone behind the piling
    # (half-angle atan(0.5/15) = 1.9°), so the darkness is not painted.
    p = ping.hit_points_sonar
    bearing = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
    horiz = np.hypot(p[:, 0], p[:, 1])
    assert not np.any((np.abs(bearing) < 1.5) & (horiz > 15.6))


def test_floor_band_starts_where_tilted_beam_meets_floor() -> None:
    # Sonar 4 m above a flat floor, tilted 10° down, 20° vertical aperture: the lowest edge
    # of the beam is 20° below horizontal and meets the floor at slant range 4/sin(20°).
    paper = single_piling_scene(5.0, 80.0)  # piling well outside the 45° fan
    cfg = cfg_for(10.0, noise_floor_db=-60.0)
    _, ping = ping_scene(paper, "origin", cfg)
    img = linear(ping, cfg)
    expected = 4.0 / math.sin(math.radians(10.0 + 10.0))  # 11.695 m
    centre = beams_near(ping, 0.0, 0.1)
    profile = img[:, centre].mean(axis=1)
    band = profile[bins_between(ping, expected + 0.5, expected + 1.0)].mean()
    first = int(np.argmax(profile > 0.1 * band))
    assert ping.bin_ranges_m[first] == pytest.approx(expected, abs=2 * cfg.bin_m)
    assert profile[: first - 3].max() < 1e-3 * band  # dark water before the band
    assert ping.label_polar[first + 2, centre[0]] == paper.scene.label_id("seafloor")


def test_torus_inner_ring_shadow() -> None:
    # Paper scene: torus (R = 1.5 m, r = 0.3 m) on an 8 m floor, centre 10 m north;
    # sonar at 4 m depth looking north, tilted 20°. In the vertical plane of the centre
    # beam the near tube (centre 8.5 m north, 7.7 m deep) hides the floor inside the ring
    # out to the tangent from the sonar over the tube; likewise behind the far tube.
    paper = torus_scene()
    cfg = cfg_for(20.0)
    _, ping = ping_scene(paper, "front", cfg)
    img = linear(ping, cfg)
    h = 4.0

    def floor_slant(ground: float) -> float:
        return math.hypot(ground, h)

    def shadow_end(tube_north: float) -> float:
        # Ground distance where the upper tangent over the tube meets the floor.
        dz, dist = 7.7 - 4.0, math.hypot(tube_north, 7.7 - 4.0)
        dep = math.atan2(dz, tube_north) - math.asin(0.3 / dist)
        return h / math.tan(dep)

    near_end, far_end = shadow_end(8.5), shadow_end(11.5)  # ≈ 10.06 m, 13.56 m
    cols = beams_near(ping, 0.0, 0.5)

    def mean(r0: float, r1: float) -> float:
        return float(img[np.ix_(bins_between(ping, r0, r1), cols)].mean())

    lit_front = mean(floor_slant(7.2), floor_slant(8.0))  # floor before the torus
    inner_shadow = mean(floor_slant(9.0), floor_slant(near_end) - 0.1)
    lit_hole = mean(floor_slant(near_end) + 0.15, floor_slant(11.0))  # hole floor beyond
    outer_shadow = mean(floor_slant(12.0), floor_slant(far_end) - 0.1)
    lit_behind = mean(floor_slant(far_end) + 0.3, floor_slant(far_end) + 1.3)
    assert inner_shadow < 0.1 * lit_front
    assert inner_shadow < 0.1 * lit_hole  # a shadow inside the ring, then floor again
    assert outer_shadow < 0.1 * lit_behind
    torus = paper.scene.label_id("torus")
    assert (ping.label_polar[:, cols] == torus).any()


def test_sonar_inside_piling_or_below_floor_is_rejected() -> None:
    from uhrisim.core.errors import ConfigError

    paper = single_piling_scene(12.0, 0.0, width=1.0)
    rc = paper.scene.raycaster("embree")
    sonar = ImagingSonar(cfg_for(0.0), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="inside a 'piling' mesh") as err:
        sonar.ping(rc, np.array([12.0, 0.0, 4.0]), np.eye(3), 0.0)  # in the piling
    assert err.value.where == "SonarConfig.mount_position_frd"
    with pytest.raises(ConfigError, match="below the sea floor"):
        sonar.ping(rc, np.array([3.0, 0.0, 8.5]), np.eye(3), 0.0)  # floor is 8 m deep
    # The mount offset counts: a vehicle 0.3 m behind the piling face with the sonar
    # mounted 0.5 m forward puts the sonar inside it.
    mounted = ImagingSonar(
        cfg_for(0.0, mount_position_frd=(0.5, 0.0, 0.0)), np.random.default_rng(0)
    )
    with pytest.raises(ConfigError, match="inside"):
        mounted.ping(rc, np.array([11.2, 0.0, 4.0]), np.eye(3), 0.0)
    mounted.ping(rc, np.array([10.0, 0.0, 4.0]), np.eye(3), 0.0)  # 1 m clear: fine


def test_diver_in_the_pier_scene() -> None:
    # Pier scene with the diver 10 m ahead at 4 m depth (sonar 3 m deep, tilted 10°,
    # mounted 0.35 m forward on the VideoRay, whose own hull is excluded from the rays).
    from uhrisim.world.paper_scenes import pier_scene

    paper = pier_scene(with_diver=True, with_rov=True)
    cfg = cfg_for(10.0, mount_position_frd=(0.35, 0.0, -0.1), range_max_m=20.0)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    rc = paper.scene.raycaster("embree")
    pose = paper.sonar_poses["approach"]
    own = frozenset({"videoray"})
    ping = sonar.ping(rc, pose.position_ned, pose.rotation, 0.0, exclude=own)
    diver = paper.scene.label_id("diver")
    assert paper.scene.label_id("rov") not in set(np.unique(ping.label_polar).tolist())
    b, j = np.nonzero(ping.label_polar == diver)
    assert len(b) > 50
    # Where the geometry says: about 10 m ahead (the body spans ~2 m along the line of
    # sight: head to fins), straight ahead (the diver is ~0.6 m wide: ±2° at 9 m).
    ranges = ping.bin_ranges_m[b]
    assert ranges.min() > 8.0 and ranges.max() < 11.5
    assert np.abs(np.degrees(ping.beam_angles_rad[j])).max() < 2.5
    # Bright against the water around it (no floor there: the beam meets it at 14.6 m).
    img = linear(ping, cfg)
    water = img[np.ix_(bins_between(ping, 8.0, 11.5), beams_near(ping, 12.0, 4.0))].mean()
    assert img[b, j].mean() > 100.0 * water
    # The fins kick: another kick phase changes the echo (the flicker of real divers).
    p, R, _ = paper.scene.pose("diver")
    paper.scene.set_pose("diver", p, R, kick_phase=0.5 * math.pi)
    kicked = sonar.ping(rc, pose.position_ned, pose.rotation, 0.1, exclude=own)
    assert not np.array_equal(kicked.label_polar == diver, ping.label_polar == diver)


def test_shadow_cells_carry_no_label() -> None:
    # Behind the 1 m piling no ray reaches the floor: those cells hold no echo and no label.
    paper = single_piling_scene(15.0, 0.0, width=1.0)
    cfg = cfg_for(10.0)
    _, ping = ping_scene(paper, "origin", cfg)
    rows = bins_between(ping, 17.0, 28.0)
    cols = beams_near(ping, 0.0, 0.8)
    assert (ping.label_polar[np.ix_(rows, cols)] == -1).all()
    beside = beams_near(ping, 10.0, 0.8)
    assert (ping.label_polar[np.ix_(rows, beside)] == paper.scene.label_id("seafloor")).all()


def test_default_shadow_is_grey_with_soft_edges() -> None:
    # With the default diffuse terms (noise, reverberation, far side lobes) the shadow of
    # the 1 m piling is grey, not black, and its edge across the beams is soft: the
    # horizontal beam pattern (1° main lobe, side lobes) spreads the lit floor into it.
    # Real shadows: ≈ 20–40 of 255 with soft edges (issue 14).
    paper = single_piling_scene(15.0, 0.0, width=1.0)
    cfg = SonarConfig(tilt_deg=10.0, mount_position_frd=(0.0, 0.0, 0.0), speckle=False)
    _, ping = ping_scene(paper, "origin", cfg)
    rows = bins_between(ping, 18.0, 28.0)
    shadow = ping.polar_u8[np.ix_(rows, beams_near(ping, 0.0, 0.5))].astype(float)
    lit = ping.polar_u8[np.ix_(rows, beams_near(ping, 10.0, 0.8))].astype(float)
    assert shadow.min() > 0 and 10.0 < shadow.mean() < 0.6 * lit.mean()
    # Across the shadow's edge (half-angle atan(0.5/15) = 1.9°) the brightness climbs over
    # about a beam width (10 % → 90 % of the step over > 0.5°), not from one beam to the next.
    profile = ping.polar_u8[rows].astype(float).mean(axis=0)
    angles = np.degrees(ping.beam_angles_rad)
    side = (angles > 0.0) & (angles < 6.0)
    a, p = angles[side], profile[side]
    lo, hi = p.min(), p[a > 4.0].mean()
    rise = a[np.argmax(p > lo + 0.9 * (hi - lo))] - a[np.argmax(p > lo + 0.1 * (hi - lo))]
    assert rise > 0.5
