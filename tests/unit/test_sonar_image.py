"""Image formation of the imaging sonar on analytic scenes (no mesh ray caster needed).

The scenes here are closed-form: a flat floor and a square plate facing the sonar, so
every expected number is computed in the test from the geometry.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pytest

from tests.support.analytic_sonar import (
    FLOOR,
    LEVEL,
    ORIGIN,
    PLATE,
    AnalyticCaster,
    Hits,
    linear_display,
    small_cfg,
    window_hits,
)
from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, SonarSpec
from uhrisim.sensors.sonar import sonar as sonar_module
from uhrisim.sensors.sonar.config import ECHOES_ONLY
from uhrisim.sensors.sonar.reference import reference_polar
from uhrisim.world.paper_scenes import single_piling_scene


def test_fast_path_matches_reference() -> None:
    cfg = small_cfg()
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    caster = AnalyticCaster(plate_north=10.0, plate_half=0.3, plate_z=5.5)
    ping = sonar.ping(caster, ORIGIN, LEVEL, 0.0)
    # Recreate the hits the ping used and run the slow reference on them.
    hits, idx, cos_inc = window_hits(sonar, caster)
    ref = reference_polar(sonar, idx, hits.distance[idx], cos_inc, hits.reflectivity[idx])
    assert {FLOOR, PLATE} <= set(np.unique(ping.label_polar).tolist())
    assert ref.max() > 0.5  # the comparison covers lit cells, not just the noise floor
    np.testing.assert_allclose(ping.polar, ref, atol=2e-5)


def test_same_seed_same_image_different_seed_different_speckle() -> None:
    cfg = small_cfg(speckle=True)
    caster = AnalyticCaster(plate_north=10.0, plate_half=0.3, plate_z=5.5)
    a = ImagingSonar(cfg, np.random.default_rng(7)).ping(caster, ORIGIN, LEVEL, 0.0)
    b = ImagingSonar(cfg, np.random.default_rng(7)).ping(caster, ORIGIN, LEVEL, 0.0)
    c = ImagingSonar(cfg, np.random.default_rng(8)).ping(caster, ORIGIN, LEVEL, 0.0)
    assert np.array_equal(a.polar, b.polar) and np.array_equal(a.fan_u8, b.fan_u8)
    assert np.array_equal(a.label_fan, b.label_fan)
    assert not np.array_equal(a.polar, c.polar)
    # Speckle changes intensities, never geometry: labels are seed-independent.
    assert np.array_equal(a.label_polar, c.label_polar)
    # Two pings from one Generator differ (the stream advances).
    s = ImagingSonar(cfg, np.random.default_rng(7))
    p1, p2 = s.ping(caster, ORIGIN, LEVEL, 0.0), s.ping(caster, ORIGIN, LEVEL, 0.1)
    assert np.array_equal(p1.polar, a.polar) and not np.array_equal(p1.polar, p2.polar)


def test_speckle_is_rayleigh_on_homogeneous_floor() -> None:
    # Flat floor, 4 m below a sonar tilted 20°: lit from 4/sin(30°) = 8 m on. The echoes
    # alone (no noise or reverberation, which are speckled too but are not the floor's).
    kw = dict(
        range_min_m=9.0, range_max_m=13.0, tilt_deg=20.0, dynamic_range_db=150.0,
        rays_per_beam=64, mount_position_frd=(0.0, 0.0, 0.0), **ECHOES_ONLY,
    )  # fmt: skip
    clean_cfg = SonarConfig(speckle=False, **kw)
    speck_cfg = SonarConfig(speckle=True, **kw)
    caster = AnalyticCaster(floor_z=8.0)
    clean = ImagingSonar(clean_cfg, np.random.default_rng(1)).ping(caster, ORIGIN, LEVEL, 0)
    speckled = ImagingSonar(speck_cfg, np.random.default_rng(1))
    pings = [speckled.ping(caster, ORIGIN, LEVEL, 0) for _ in range(8)]
    i0 = linear_display(clean.polar, clean_cfg)
    assert clean.polar.min() > 0.0 and max(p.polar.max() for p in pings) < 1.0  # no clipping
    # A patch (60 bins × 60 central beams) that is homogeneous without speckle (±6 %)...
    patch = (slice(50, 110), slice(98, 158))
    assert i0[patch].std() / i0[patch].mean() < 0.06
    i1 = np.stack([linear_display(p.polar, speck_cfg)[patch] for p in pings])
    amp = np.sqrt(i1 / i0[patch])
    # ...has Rayleigh amplitude statistics with speckle: std/mean = sqrt(4/π − 1) = 0.5227.
    # The grain is ~6 beams × ~1.5 bins (beam width, pulse), so 8 pings of the patch hold
    # ~3000 independent grains: ±0.01 at 1σ on the ratio, ±2 % on the mean intensity.
    rayleigh = math.sqrt(4.0 / math.pi - 1.0)
    assert amp.std() / amp.mean() == pytest.approx(rayleigh, abs=0.03)
    # Intensity is unbiased: the mean of |c|² is the incoherent image's.
    assert (amp**2).mean() == pytest.approx(1.0, abs=0.06)


@pytest.mark.parametrize("tvg", [True, False])
def test_tvg_makes_target_peak_range_independent(tvg: bool) -> None:
    # A 10 cm square Lambert plate (μ = 0.2) facing a level sonar, no floor, no speckle.
    # Its target strength is TS = 10 log10(μ·A) = 10 log10(0.2·0.01) = −27 dB at any range;
    # after 40 log R + 2αR TVG the echo level SL + TS does not depend on range.
    spec = SonarSpec("narrow", 900e3, 6.0, 35, 1.0, 20.0, 100.0, 0.0254, 15.0, source="test")
    cfg = SonarConfig(
        spec=spec, range_max_m=45.0, rays_per_beam=1024, rays_per_beam_azimuth=16,
        tilt_deg=0.0, mount_position_frd=(0.0, 0.0, 0.0), speckle=False, tvg=tvg,
        dynamic_range_db=300.0, display_top_db=250.0, rate_hz=10.0, **ECHOES_ONLY,
    )  # fmt: skip
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    peaks = {}
    for k in (393, 787, 1574):  # bins centred at 10, 20, 40 m
        d = (k + 0.5) * cfg.bin_m
        caster = AnalyticCaster(floor_z=None, plate_north=d, plate_half=0.05, plate_z=4.0)
        ping = sonar.ping(caster, ORIGIN, LEVEL, 0.0)
        level_db = (ping.polar.astype(float) - 1.0) * cfg.dynamic_range_db + cfg.display_top_db
        b, j = np.unravel_index(np.argmax(level_db), level_db.shape)
        assert b == k and j == 17  # the plate's bin and the centre beam
        peaks[d] = level_db.max()
    ranges = sorted(peaks)
    if tvg:
        ts = 10 * math.log10(0.2 * 0.1 * 0.1)
        for d in ranges:
            # Within 1 dB of SL + TS (the beam pattern over a target < 1 beam wide and the
            # finite ray sampling account for the rest).
            assert peaks[d] == pytest.approx(cfg.source_level_db + ts, abs=1.0)
        assert max(peaks.values()) - min(peaks.values()) < 0.6
    else:
        # Without TVG the peak falls by the two-way loss: 40 log(2) + 2α·Δr per doubling.
        alpha = cfg.alpha_db_per_m
        for r1, r2 in itertools.pairwise(ranges):
            expected = 40 * math.log10(r2 / r1) + 2 * alpha * (r2 - r1)
            assert peaks[r1] - peaks[r2] == pytest.approx(expected, abs=0.6)


def test_mount_inside_geometry_is_rejected() -> None:
    # Sonar 1 cm above the floor, pointing straight down: every ray hits at ~1 cm.
    cfg = SonarConfig(tilt_deg=80.0, mount_position_frd=(0.0, 0.0, 0.0), rays_per_beam=8)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    with pytest.raises(ConfigError, match="inside geometry") as err:
        sonar.ping(AnalyticCaster(floor_z=4.01), ORIGIN, LEVEL, 0.0)
    assert err.value.where == "SonarConfig.mount_position_frd"


def test_own_fan_goes_to_a_scene_caster_unchecked_only_when_valid(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A sonar's own fan skips a scene caster's ray checks when its origin is finite and
    its rotation orthonormal (the checks would pass): the same ping as checked; a rotation
    that is not one, or a NaN position, is refused as before, by the caster's checks."""
    paper = single_piling_scene(12.0, 6.0, width=0.4)
    caster = paper.scene.raycaster("embree")
    pose = paper.sonar_poses["origin"]
    cfg = SonarConfig(tilt_deg=10.0, mount_position_frd=(0.0, 0.0, 0.0), range_max_m=20.0,
                      rays_per_beam=8, labels=True)  # fmt: skip
    checked = []
    cast = type(caster).cast
    monkeypatch.setattr(type(caster), "cast", lambda self, *a, **k: (
        checked.append(k.get("checked", True)), cast(self, *a, **k))[1])

    def polar(p, R):
        return ImagingSonar(cfg, np.random.default_rng(4)).ping(caster, p, R, 0.0)

    unchecked = polar(pose.position_ned, pose.rotation)
    monkeypatch.setattr(sonar_module, "own_fan_is_valid", lambda *_: False)
    checked_ping = polar(pose.position_ned, pose.rotation)
    assert checked == [False, True]
    for name in ("polar", "label_polar", "hit_points_ned"):
        np.testing.assert_array_equal(getattr(unchecked, name), getattr(checked_ping, name))
    monkeypatch.undo()
    with pytest.raises(ConfigError, match="unit vectors"):
        polar(pose.position_ned, 1.001 * pose.rotation)
    with pytest.raises(ConfigError, match="NaN"):
        polar(np.full(3, np.nan), pose.rotation)


def test_constructor_checks_types() -> None:
    with pytest.raises(ConfigError, match="SonarConfig"):
        ImagingSonar({"range_max_m": 10}, np.random.default_rng(0))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="Generator"):
        ImagingSonar(SonarConfig(), 42)  # type: ignore[arg-type]


def test_mount_pose_and_cloud_layout() -> None:
    cfg = small_cfg(mount_position_frd=(0.5, 0.1, -0.2), tilt_deg=15.0, yaw_deg=0.0)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    yaw = math.radians(90.0)  # vehicle heading east
    R = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    ping = sonar.ping(AnalyticCaster(floor_z=8.0), ORIGIN, R, 1.5)
    # Mount (0.5 fwd, 0.1 stbd, 0.2 up) on an east-facing vehicle → NED offset (−0.1, 0.5, −0.2).
    np.testing.assert_allclose(ping.position_ned, ORIGIN + np.array([-0.1, 0.5, -0.2]), atol=1e-12)
    # Sonar axis: east and 15° down.
    axis = ping.rotation_ned_from_sonar @ [1.0, 0.0, 0.0]
    t = math.radians(15.0)
    np.testing.assert_allclose(axis, [0.0, math.cos(t), math.sin(t)], atol=1e-12)
    # Hit points lie on the floor (NED z = 8) and agree between frames.
    assert np.allclose(ping.hit_points_ned[:, 2], 8.0)
    back = ping.position_ned + ping.hit_points_sonar @ ping.rotation_ned_from_sonar.T
    np.testing.assert_allclose(back, ping.hit_points_ned, atol=1e-9)
    c = ping.cloud
    assert c.num_planes == 16 and c.num_points_per_plane == 12
    assert c.x.shape == (16 * 12,)
    assert c.angle_min == pytest.approx(-math.radians(4.0))
    assert c.angle_increment == pytest.approx(math.radians(8.0) / 11)
    assert c.vert_height == pytest.approx(math.radians(20.0))
    assert c.vert_resolution == pytest.approx(math.radians(20.0) / 16)
    # Plane-major: point (plane i, beam j) at index i·12 + j has elevation of plane i.
    hit = np.isfinite(c.x)
    i, j = 15, 3  # lowest plane (most downward) hits the floor
    k = i * 12 + j
    assert hit[k]
    rng = math.sqrt(c.x[k] ** 2 + c.y[k] ** 2 + c.z[k] ** 2)
    el = -c.vert_height / 2 + (i + 0.5) * c.vert_resolution
    assert math.asin(c.z[k] / rng) == pytest.approx(el, abs=1e-5)
    assert math.atan2(c.y[k], c.x[k]) == pytest.approx(c.angle_min + j * c.angle_increment, 1e-5)
    assert (c.intensity[~hit] == 0).all() and (c.intensity[hit] > 0).any()


def test_2013_mode_geometry_and_white_boundaries() -> None:
    # 2013 mode, literal layout: a point at sonar (x, y) lands at column 10x, row 10y.
    cfg = small_cfg(mode="2013", layout_2013="literal", tilt_deg=0.0, range_min_m=0.0)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    caster = AnalyticCaster(floor_z=None, plate_north=10.0, plate_half=0.3, plate_z=4.0)
    ping = sonar.ping(caster, ORIGIN, LEVEL, 0.0)
    assert ping.fan_px_per_m == 10.0 and ping.fan_apex_px == (0.0, 0.0)
    pts = ping.hit_points_sonar
    assert len(pts) > 0
    img = ping.fan_u8
    # The plate spans east 0…0.3 on the starboard side → rows 0…3, column 100 (x = 10 m).
    stbd = pts[pts[:, 1] >= 0]
    cols = np.round(10 * stbd[:, 0]).astype(int)
    rows = np.round(10 * stbd[:, 1]).astype(int)
    assert set(cols.tolist()) == {100}
    assert (ping.label_fan[rows, cols] == PLATE).all()
    # After the blur each drawn point is still the brightest around it (blurred blob).
    assert img[rows, cols].min() > 0
    # Boundary lines drawn after the blur are pure white from the apex (top-left) out.
    half = math.radians(4.0)
    for r in (2.0, 7.0, 13.0):
        c, rr = round(10 * r * math.cos(half)), round(10 * r * math.sin(half))
        assert img[rr, c] == 255
    assert img[0, 0] == 255

    # Port-edge layout: bearings from the port edge, so the whole fan is in the image.
    cfg2 = small_cfg(mode="2013", tilt_deg=0.0, range_min_m=0.0, blur_ksize_2013=1)
    p2 = ImagingSonar(cfg2, np.random.default_rng(0)).ping(caster, ORIGIN, LEVEL, 0.0)
    th = np.arctan2(p2.hit_points_sonar[:, 1], p2.hit_points_sonar[:, 0]) + half
    rr = np.hypot(p2.hit_points_sonar[:, 0], p2.hit_points_sonar[:, 1])
    cols = np.round(10 * rr * np.cos(th)).astype(int)
    rows = np.round(10 * rr * np.sin(th)).astype(int)
    assert (p2.fan_u8[rows, cols] == 255).all()  # no blur: drawn points are white
    assert (p2.label_fan[rows, cols] == PLATE).sum() == len(rows)
    assert p2.fan_u8[0, 10 * 13] == 255  # port boundary along the top row


def test_fan_geometry_and_labels() -> None:
    cfg = SonarConfig(
        range_max_m=20.0, tilt_deg=0.0, mount_position_frd=(0.0, 0.0, 0.0), speckle=False,
        fan_size_px=400, colormap="bone", labels=True,
    )  # fmt: skip
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    caster = AnalyticCaster(floor_z=None, plate_north=12.0, plate_half=0.5, plate_z=4.0)
    ping = sonar.ping(caster, ORIGIN, LEVEL, 0.0)
    H, W = ping.fan_u8.shape
    assert H == 400  # the fan is taller (20 m) than wide (2·20·sin 22.5° = 15.3 m)
    width_px = math.ceil(2 * 20 * math.sin(math.radians(22.5)) * 20)
    assert width_px == W
    assert ping.fan_px_per_m == pytest.approx(20.0)
    # The plate (12 m ahead) shows at the fan pixel 12 m above the apex, centre column.
    col, row = ping.fan_apex_px
    r = round(row - 12.0 * ping.fan_px_per_m)
    c = round(col)
    assert ping.fan_u8[r - 1 : r + 2, c - 1 : c + 2].max() > 200
    assert ping.label_fan[r - 2 : r + 3, c - 2 : c + 3].max() == PLATE
    # Outside the fan: black and unlabelled.
    assert ping.fan_u8[0, 0] == 0 and ping.label_fan[0, 0] == -1
    assert ping.fan_rgb is not None and ping.fan_rgb.shape == (H, W, 3)
    assert (ping.fan_rgb[0, 0] == 0).all()
    assert ping.polar_u8.dtype == np.uint8 and ping.label_polar.dtype == np.int16
    assert ping.bin_ranges_m[0] == pytest.approx(0.0127)


@dataclass(frozen=True)
class ThreeLabelCaster:
    """Floor (label 0) with two plates: label 1 at 10 m, label 2 further out at 11 m."""

    def cast(self, origins, directions, max_range, exclude=frozenset()):
        floor_plate = AnalyticCaster(floor_z=8.0, plate_north=10.0, plate_half=0.4, plate_z=5.8)
        h1 = floor_plate.cast(origins, directions, max_range)
        plate2 = AnalyticCaster(floor_z=None, plate_north=11.0, plate_half=0.6, plate_z=6.6)
        h2 = plate2.cast(origins, directions, max_range)
        take = h2.distance < h1.distance
        lab = np.where(take, 2, h1.label).astype(np.int32)
        return Hits(
            np.where(take, h2.distance, h1.distance), lab,
            np.where(take[:, None], h2.normal, h1.normal),
            np.where(take, 0.5, h1.reflectivity), h1.body,
        )  # fmt: skip


@pytest.mark.parametrize("caster", [AnalyticCaster(plate_north=10.0, plate_half=0.3, plate_z=5.5),
                                    ThreeLabelCaster()])  # fmt: skip
def test_labels_match_reference(caster) -> None:
    from uhrisim.sensors.sonar.reference import reference_labels

    cfg = small_cfg()
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    ping = sonar.ping(caster, ORIGIN, LEVEL, 0.0)
    hits, idx, cos_inc = window_hits(sonar, caster)
    ref = reference_labels(
        sonar, idx, hits.distance[idx], cos_inc, hits.reflectivity[idx], hits.label[idx]
    )
    present = set(np.unique(hits.label[idx]).tolist())
    assert set(np.unique(ref).tolist()) - {-1} == present
    np.testing.assert_array_equal(ping.label_polar, ref)


def test_fidelity_knobs_do_not_change_the_level() -> None:
    # Each ray carries its solid angle, so the echo of an extended surface (the floor) does
    # not depend on how many rays sample it: 32 vs 128 elevation rays, 1 vs 4 azimuth
    # sub-rays agree within 0.3 dB on the mean of the lit band (speckle off).
    kw = dict(
        range_min_m=8.0, range_max_m=14.0, tilt_deg=20.0, speckle=False, noise_floor_db=-60.0,
        dynamic_range_db=150.0, mount_position_frd=(0.0, 0.0, 0.0),
    )  # fmt: skip
    caster = AnalyticCaster(floor_z=8.0)

    def band_db(**extra) -> float:
        cfg = SonarConfig(**kw, **extra)
        ping = ImagingSonar(cfg, np.random.default_rng(0)).ping(caster, ORIGIN, LEVEL, 0.0)
        rows = (ping.bin_ranges_m > 9.0) & (ping.bin_ranges_m < 13.0)
        return 10 * math.log10(linear_display(ping.polar, cfg)[rows, 20:-20].mean())

    ref = band_db(rays_per_beam=128)
    assert band_db(rays_per_beam=32) == pytest.approx(ref, abs=0.3)
    assert band_db(rays_per_beam=32, rays_per_beam_azimuth=4) == pytest.approx(ref, abs=0.3)


@pytest.mark.parametrize("speckle", [False, True])
def test_row_runs_match_filtering_every_row(speckle: bool) -> None:
    # A plate 2 m ahead and the floor from ~9 m leave a band of range bins no echo reaches
    # (nor the 3-bin range blur): the ping filters only the rows echo reaches; the rest
    # hold only the diffuse terms and take their level (times the bank's precomputed
    # diffuse field with speckle). That must equal forming every row, to float32 rounding
    # (the rows are formed from a per-row level, not by filtering zeros).
    cfg = small_cfg(range_min_m=0.0, range_max_m=20.0, speckle=speckle)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    twin = ImagingSonar(cfg, np.random.default_rng(0))  # the same speckle offsets
    caster = AnalyticCaster(floor_z=8.0, plate_north=2.0, plate_half=0.3, plate_z=4.0)
    hits, idx, cos_inc = window_hits(sonar, caster)
    r = hits.distance[idx]
    e = sonar.ray_intensity(idx, r, cos_inc, hits.reflectivity[idx])
    raw, _, rows = sonar._accumulate(idx, r, cos_inc, e)
    n_bins = sonar.polar_shape[0]
    covered = sum(b - a for a, b in rows)
    assert len(rows) >= 2 and n_bins - covered >= 50  # the skip is exercised (5 m of bins)
    fast = sonar._physical_polar(raw.copy(), rows)
    every = twin._physical_polar(raw.copy(), None)
    np.testing.assert_allclose(fast, every, atol=2e-6)
    outside = np.ones(n_bins, bool)
    for a, b in rows:
        outside[a:b] = False
    assert not raw[outside].any()
    if not speckle:  # outside the runs the echo is zero: the image is the diffuse level
        np.testing.assert_allclose(
            fast[outside], np.clip(sonar.geometry.floor_level[outside], 0, 1), atol=1e-6
        )


@pytest.mark.parametrize("mode", ["physical", "2013"])
def test_fan_images_and_hit_products_formed_late_equal_formed_at_once(mode: str) -> None:
    """The fan images, the hit points and the cloud are formed on first access: a ping
    whose fan and cloud are read only after the sonar has pinged again (new speckle,
    shared scratch buffers reused) shows exactly what it would have shown at once."""
    caster = ThreeLabelCaster()
    cfg = small_cfg(mode=mode, colormap="jet")
    at_once = ImagingSonar(cfg, np.random.default_rng(3))
    late = ImagingSonar(cfg, np.random.default_rng(3))

    def products(ping) -> list:
        c = ping.cloud
        return [ping.fan_u8, ping.label_fan, ping.fan_rgb, ping.hit_points_sonar,
                ping.hit_points_ned, c.x, c.y, c.z, c.intensity]

    first = at_once.ping(caster, ORIGIN, LEVEL, 0.0)
    images = [a.copy() for a in products(first)]
    kept = late.ping(caster, ORIGIN, LEVEL, 0.0)
    later = late.ping(caster, ORIGIN + np.array([0.5, 0.2, 0.0]), LEVEL, 0.1)
    assert not np.array_equal(later.fan_u8, images[0])
    assert not np.array_equal(later.hit_points_ned, images[4])
    for formed_late, formed_at_once in zip(products(kept), images, strict=True):
        np.testing.assert_array_equal(formed_late, formed_at_once)
    assert (images[1] == PLATE).any() and (images[1] == 2).any()


@pytest.mark.parametrize("speckle_model", [None, "product", "coherent"])
@pytest.mark.parametrize("surface", [True, False])
@pytest.mark.parametrize("multipath", [False, True])
def test_echo_free_shortcut_is_the_full_path_bit_for_bit(speckle_model, surface,
                                                         multipath) -> None:
    """A physical ping with no hit: ``polar_bytes``' shortcut (``_echo_free_level``, no
    raw image) gives the level ``_physical_image`` forms on no hit and ``form_image``'s
    ``polar_u8``, and leaves the sonar's Generator where the full path leaves it (at
    depths with and without surface reverberation, the sonar level and tilted)."""
    from uhrisim.core.frames import rot_z
    from uhrisim.sensors.sonar.cast import FanHits

    speckle = {} if speckle_model is None else {"speckle_model": speckle_model}
    cfg = small_cfg(speckle=speckle_model is not None, multipath=multipath, **speckle,
                    **({} if surface else {"surface_scattering_db": None}))
    assert (cfg.surface_scattering_db is not None) == surface
    short, full, short_bytes, full_bytes = (ImagingSonar(cfg, np.random.default_rng(11))
                                            for _ in range(4))
    no_hit = FanHits(np.empty(0, np.int64), *[np.empty(0)] * 3, np.empty(0, np.int32))
    for depth, pitch in [(1.5, 0.0), (4.0, 0.3), (12.0, -0.2), (-0.5, 0.0)]:
        c, s = math.cos(pitch), math.sin(pitch)
        rotation = rot_z(0.7) @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        pose = short.sonar_pose(np.array([3.0, -2.0, depth]), rotation)
        level = short._echo_free_level(*pose)
        expected, _ = full._physical_image(*pose, no_hit, np.empty(0), clipped=False)
        np.testing.assert_array_equal(level, expected)
        np.testing.assert_array_equal(short_bytes.polar_bytes(*pose, no_hit),
                                      full_bytes.form_image(0.0, *pose, *no_hit).polar_u8)
    states = {s.rng.integers(1 << 30) for s in (short, full, short_bytes, full_bytes)}
    assert len(states) == 1
