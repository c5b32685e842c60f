"""Each image-formation stage against its own physics (issue 14; ``docs/sonar.md``).

Closed-form scenes (tests/unit/test_sonar_image.py's analytic caster): every expected
number is computed here from the acoustics, not read back from the implementation.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest

from tests.support.analytic_sonar import (
    LEVEL,
    NO_SCENE,
    ORIGIN,
    AnalyticCaster,
    acf_fwhm,
    diffuse_only,
    level_db,
    linear_display,
    rows_at,
    small_cfg,
    window_hits,
)
from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, echoes, get_preset
from uhrisim.sensors.sonar.cast import cast_fan
from uhrisim.sensors.sonar.config import ECHOES_ONLY
from uhrisim.sensors.sonar.polar import clip_unit, display_bytes
from uhrisim.sensors.sonar.reference import reference_bytes, reference_polar
from uhrisim.sensors.sonar.speckle import SpeckleBank


def tvg(cfg: SonarConfig, r: float) -> float:
    """40 log R + 2αR, held inside tvg_min_range_m (the configured, imperfect TVG)."""
    rt = max(r, cfg.tvg_min_range_m)
    return 40.0 * math.log10(rt) + 2.0 * cfg.alpha_db_per_m * rt


# -- noise floor ------------------------------------------------------------------------------


def test_receiver_noise_rises_with_the_tvg_and_is_held_near_range() -> None:
    cfg = diffuse_only(noise_floor_db=60.0, tvg_min_range_m=2.0)
    polar = ImagingSonar(cfg, np.random.default_rng(0)).ping(NO_SCENE, ORIGIN, LEVEL, 0).polar
    ranges = [0.75, 1.55, 2.55, 5.05, 10.05, 20.05, 29.95]
    got = level_db(polar, cfg)[rows_at(cfg, ranges), 4]
    # Noise at the beam output (60 dB re 1 µPa²) amplified by the TVG of each range.
    expected = [60.0 + tvg(cfg, r) for r in ranges]
    np.testing.assert_allclose(got, expected, atol=0.02)
    assert got[0] == pytest.approx(got[1], abs=0.01)  # the gain is held inside 2 m


def test_ambient_noise_is_the_wenz_thermal_band_level_less_the_directivity_index() -> None:
    cfg = diffuse_only(noise_floor_db=-100.0, ambient_noise=True, sea_state=2.0)
    polar = ImagingSonar(cfg, np.random.default_rng(0)).ping(NO_SCENE, ORIGIN, LEVEL, 0).polar
    # Mellen's thermal noise at 900 kHz: −15 + 20 log10(900) = 44.1 dB re 1 µPa²/Hz; wind
    # noise at sea state 2 (Knudsen: 56 + 19 log 2 − 17 log 900 = 11.5 dB/Hz) adds 0.003 dB.
    bandwidth = cfg.sound_speed_m_s / (2.0 * 0.1)  # c / (2 · pulse resolution)
    spectrum = 10 ** ((-15 + 20 * math.log10(900)) / 10) + 10 ** (
        (56 + 19 * math.log10(2) - 17 * math.log10(900)) / 10
    )
    band = 10 * math.log10(spectrum * bandwidth)
    di = 10 * math.log10(4 * math.pi / (math.radians(1.0) * math.radians(20.0)))  # 33.1 dB
    r = 10.05
    got = level_db(polar, cfg)[rows_at(cfg, [r])[0], 4]
    assert got == pytest.approx(band - di + tvg(cfg, r), abs=0.02)


def test_post_tvg_noise_is_the_same_grey_at_every_range() -> None:
    cfg = diffuse_only(post_tvg_noise_db=140.0, gain_db=6.0)
    polar = ImagingSonar(cfg, np.random.default_rng(0)).ping(NO_SCENE, ORIGIN, LEVEL, 0).polar
    got = level_db(polar, cfg)[:, 4]
    np.testing.assert_allclose(got, 140.0 + 6.0, atol=0.02)  # the display level + user gain


def test_volume_reverberation_level_and_its_20_log_r_rise() -> None:
    sv = -60.0
    cfg = diffuse_only(volume_scattering_db=sv)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    polar = sonar.ping(NO_SCENE, ORIGIN, LEVEL, 0).polar
    ranges = [2.05, 8.05, 25.05]
    got = level_db(polar, cfg)[rows_at(cfg, ranges), 4]
    # A cell of one beam spacing δθ, one bin Δr, the two-way vertical pattern's
    # equivalent width Ψ = (W/2)·sqrt(π / (2 ln 2)) (Gaussian), summed through the
    # horizontal pattern (Σ of its power kernel): V = R²·δθ·Ψ·Δr. Echo re SL:
    # S_v·V·R⁻⁴·10^(−2αR/10); + SL + TVG (40 log R + 2αR): S_v + 10 log(δθΨΔrΣ) + SL + 20 log R.
    dtheta = math.radians(8.0 / 8)
    psi = 0.5 * math.radians(20.0) * math.sqrt(math.pi / (2 * math.log(2)))
    k = float(sonar.geometry.beam_kernel.sum())
    for r, g in zip(ranges, got, strict=True):
        expected = (sv + 10 * math.log10(dtheta * psi * 0.1 * k) + cfg.source_level_db
                    + 20 * math.log10(r))  # fmt: skip
        assert g == pytest.approx(expected, abs=0.02)


def test_surface_reverberation_level_through_the_vertical_pattern() -> None:
    # Sonar 1 m below the surface, tilted up by asin(1/10) = 5.74°: at 10 m the surface
    # lies on the beam's axis. A Lambert surface (μ_s) seen at slant range R covers
    # R·δθ·Δr per cell at incidence cos β = h/R; echo re SL μ_s(h/R)²·R·δθ·Δr·b_v²·R⁻⁴·
    # 10^(−2αR/10), summed through the horizontal pattern; the 40 log R + 2αR TVG
    # leaves μ_s + SL + 10 log((h/R)²·R·δθ·Δr·Σ) + 10 log b_v², b_v² the two-way Gaussian
    # vertical pattern at the surface's elevation off the axis. None before R = h.
    mu_db, h = -20.0, 1.0
    tilt = -math.degrees(math.asin(h / 10.0))
    cfg = diffuse_only(surface_scattering_db=mu_db, tilt_deg=tilt)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    polar = sonar.ping(NO_SCENE, np.array([0.0, 0.0, h]), LEVEL, 0).polar
    sigma = float(sonar.geometry.beam_kernel.sum())
    dtheta = math.radians(1.0)
    for r in (10.05, 20.05):
        off_axis = math.asin(h / r) + math.radians(tilt)
        b_v2 = math.exp(-2 * math.log(2) * (off_axis / math.radians(10.0)) ** 2)
        expected = (mu_db + cfg.source_level_db
                    + 10 * math.log10((h / r) ** 2 * r * dtheta * 0.1 * sigma * b_v2))  # fmt: skip
        assert level_db(polar, cfg)[rows_at(cfg, [r])[0], 4] == pytest.approx(expected, abs=0.05)
    assert (level_db(polar, cfg)[rows_at(cfg, [0.75])[0]] < 0.0).all()  # nothing above


# -- speckle ----------------------------------------------------------------------------------


def floor_pings(n: int, **kw) -> tuple[SonarConfig, np.ndarray, list[np.ndarray]]:
    """A flat floor 4 m below a sonar tilted 20° (lit from 8 m), window 9–13 m: the
    speckle-free intensity and ``n`` speckled ones (display-linear)."""
    base = dict(
        range_min_m=9.0, range_max_m=13.0, tilt_deg=20.0, dynamic_range_db=150.0,
        rays_per_beam=64, mount_position_frd=(0.0, 0.0, 0.0), **ECHOES_ONLY,
    )  # fmt: skip
    base.update(kw)
    caster = AnalyticCaster(floor_z=8.0)
    clean_cfg = SonarConfig(speckle=False, **base)
    cfg = SonarConfig(speckle=True, **base)
    clean = ImagingSonar(clean_cfg, np.random.default_rng(1)).ping(caster, ORIGIN, LEVEL, 0)
    sonar = ImagingSonar(cfg, np.random.default_rng(2))
    pings = [linear_display(sonar.ping(caster, ORIGIN, LEVEL, 0).polar, cfg) for _ in range(n)]
    return cfg, linear_display(clean.polar, clean_cfg), pings



@pytest.mark.parametrize("model", ["product", "coherent"])
def test_speckle_amplitude_is_rayleigh_on_a_uniform_floor(model: str) -> None:
    _, clean, pings = floor_pings(6, speckle_model=model)
    patch = (slice(40, 120), slice(88, 168))
    s = np.stack([p[patch] / clean[patch] for p in pings])
    amp = np.sqrt(s)
    # Fully developed speckle: amplitude std/mean sqrt(4/π − 1) = 0.5227; intensity
    # exponential (std/mean 1), unbiased (mean 1). ~3000 grains: ±0.01 / ±2 % at 1σ.
    assert amp.std() / amp.mean() == pytest.approx(math.sqrt(4 / math.pi - 1), abs=0.03)
    assert s.mean() == pytest.approx(1.0, abs=0.06)
    assert s.std() / s.mean() == pytest.approx(1.0, abs=0.08)


@pytest.mark.parametrize("model", ["product", "coherent"])
def test_speckle_grain_is_a_beam_wide(model: str) -> None:
    # A line aperture's amplitude pattern sinc(θ/a) (−3 dB power width W = 0.886 a)
    # correlates to itself as sinc(Δ/a): the intensity autocorrelation sinc²(Δ/a) is half
    # at Δ = W/2 — its full width at half maximum is the beam width, 5.7 beams of the
    # P900's 0.176° spacing; a 2° beam makes grains twice as wide.
    widths = {}
    for width_deg in (1.0, 2.0):
        spec = dataclasses.replace(get_preset("P900-45"), beam_width_h_deg=width_deg)
        _, clean, pings = floor_pings(4, speckle_model=model, spec=spec)
        fields = [p[40:120, 60:196] / clean[40:120, 60:196] for p in pings]
        widths[width_deg] = acf_fwhm(fields, axis=1)
        expected = width_deg / spec.beam_spacing_deg
        assert widths[width_deg] == pytest.approx(expected, rel=0.2)
    assert widths[2.0] / widths[1.0] == pytest.approx(2.0, rel=0.15)


@pytest.mark.parametrize("model", ["product", "coherent"])
def test_speckle_grain_is_a_pulse_long(model: str) -> None:
    # A Gaussian power envelope of FWHM F has amplitude envelope σ_a = √2 σ_p; its
    # autocorrelation σ = 2σ_p, squared for intensity: σ_I = √2 σ_p, FWHM √2·F.
    for pulse_bins in (3.0, 6.0):
        pulse_m = pulse_bins * 0.0254
        _, clean, pings = floor_pings(4, speckle_model=model, pulse_resolution_m=pulse_m)
        fields = [p[10:150, 88:168] / clean[10:150, 88:168] for p in pings]
        assert acf_fwhm(fields, axis=0) == pytest.approx(math.sqrt(2) * pulse_bins, rel=0.2)


# -- beam pattern, element directivity --------------------------------------------------------


def test_point_target_side_lobes_at_the_preset_level() -> None:
    # A 2 cm plate straight ahead at 10 m (0.11°: one beam's axis ray hits it), level
    # sonar, echoes only, no speckle: across the beams at its range, the image is the
    # horizontal beam pattern. Its first side lobe sits at the preset's documented level,
    # where a sinc²'s first side lobe is: 1.430·W/0.886 = 1.61° off the main lobe.
    spec = dataclasses.replace(get_preset("P900-45"), n_beams=257)  # a beam on the axis
    cfg = SonarConfig(
        spec=spec, range_min_m=8.0, range_max_m=12.0, tilt_deg=0.0, speckle=False,
        rays_per_beam=512, mount_position_frd=(0.0, 0.0, 0.0), dynamic_range_db=200.0,
        display_top_db=250.0, rate_hz=10.0, **ECHOES_ONLY,
    )  # fmt: skip
    caster = AnalyticCaster(floor_z=None, plate_north=10.0, plate_half=0.01, plate_z=4.0)
    ping = ImagingSonar(cfg, np.random.default_rng(0)).ping(caster, ORIGIN, LEVEL, 0)
    db = level_db(ping.polar, cfg)
    b = int(np.argmax(db.max(axis=1)))
    row = db[b]
    centre = int(np.argmax(row))
    assert centre == 128
    angles = np.degrees(ping.beam_angles_rad)
    side = np.flatnonzero((np.abs(angles) > 1.2) & (np.abs(angles) < 2.2))
    k = side[np.argmax(row[side])]
    assert abs(abs(angles[k]) - 1.430 / 0.886) < spec.beam_spacing_deg
    assert row[k] - row[centre] == pytest.approx(spec.sidelobe_db, abs=1.0)
    assert spec.sidelobe_db == -25.0  # the P900 presets' documented value (presets.py)


def test_fan_edges_darker_by_the_element_directivity_less_the_steered_broadening() -> None:
    # Level sonar 2 m above a flat floor (lit from 2/sin 10° = 11.5 m): every beam meets
    # the floor at the same slant ranges (a ray's depth component is sin φ for any
    # bearing), so across the beams the floor differs only by the element directivity
    # (the preset's edge loss down at the fan edges) and by the steered edge beam's
    # broadening, 1/cos 22.5° (+0.34 dB; tests/unit/test_sonar_realism.py): 3 dB net.
    cfg = SonarConfig(
        range_min_m=13.0, range_max_m=16.0, tilt_deg=0.0, speckle=False, rays_per_beam=64,
        mount_position_frd=(0.0, 0.0, 0.0), dynamic_range_db=200.0, display_top_db=250.0,
        **ECHOES_ONLY,
    )  # fmt: skip
    ping = ImagingSonar(cfg, np.random.default_rng(0)).ping(
        AnalyticCaster(floor_z=6.0), ORIGIN, LEVEL, 0
    )
    assert ping.polar[40:80].min() > 0.0 and ping.polar[40:80].max() < 1.0  # not clipped
    band = level_db(ping.polar, cfg)[40:80].mean(axis=0)
    broadening = -10 * math.log10(math.cos(math.radians(22.5)))
    assert band[0] - band[128] == pytest.approx(-cfg.edge_loss_db + broadening, abs=0.3)
    assert band[-1] - band[127] == pytest.approx(-cfg.edge_loss_db + broadening, abs=0.3)
    assert -cfg.edge_loss_db + broadening == pytest.approx(-3.0, abs=1e-9)


# -- multipath --------------------------------------------------------------------------------


def test_surface_ghost_range_and_level() -> None:
    # Sonar and a 10 cm plate both 2 m deep, 10 m apart: the ghost comes via the surface,
    # mirrored sonar 4 m above the plate's depth: one leg 10 m, the other √(10² + 4²);
    # it shows at their mean, (10 + 10.770)/2 = 10.385 m, 6 dB (the surface loss) +
    # 20 log(10.770/10) = 0.64 dB (the longer leg's spreading) below the plate, less the
    # TVG's extra gain at 10.385 m (40 log 1.0385 + 2α·0.385 ≈ 0.87 dB).
    origin = np.array([0.0, 0.0, 2.0])
    caster = AnalyticCaster(floor_z=None, plate_north=10.0, plate_half=0.05, plate_z=2.0)
    kw = dict(
        range_min_m=9.0, range_max_m=11.0, tilt_deg=0.0, speckle=False, rays_per_beam=256,
        mount_position_frd=(0.0, 0.0, 0.0), dynamic_range_db=200.0, display_top_db=250.0,
        **ECHOES_ONLY,
    )  # fmt: skip
    cfg = SonarConfig(multipath=True, multipath_loss_db=6.0, **kw)
    with_ghost = ImagingSonar(cfg, np.random.default_rng(0)).ping(caster, origin, LEVEL, 0)
    without = ImagingSonar(SonarConfig(**kw), np.random.default_rng(0)).ping(
        caster, origin, LEVEL, 0
    )
    centre = level_db(with_ghost.polar, cfg)[:, 127:129].max(axis=1)
    plain = level_db(without.polar, cfg)[:, 127:129].max(axis=1)
    r = with_ghost.bin_ranges_m
    direct = int(np.argmax(centre))
    assert r[direct] == pytest.approx(10.0, abs=0.03)
    ghost_rows = np.flatnonzero(r > 10.2)
    ghost = ghost_rows[np.argmax(centre[ghost_rows])]
    assert r[ghost] == pytest.approx(10.385, abs=0.03)
    extra_tvg = tvg(cfg, r[ghost]) - tvg(cfg, r[direct])
    assert centre[ghost] - centre[direct] == pytest.approx(-6.64 + extra_tvg, abs=0.2)
    assert plain[ghost] < centre[ghost] - 30.0  # off by default: nothing there


# -- the fast stages held to the slow reference ----------------------------------------------


def test_surface_reverberation_and_every_diffuse_term_match_the_reference() -> None:
    # Defaults (noise, ambient, volume, far side lobes, post-TVG noise) plus a strong
    # surface: sonar 1 m deep tilted 10° up, a plate at 10 m; speckle off.
    cfg = small_cfg(
        tilt_deg=-10.0, range_min_m=0.5, range_max_m=14.0, surface_scattering_db=-10.0
    )
    origin = np.array([0.0, 0.0, 1.0])
    caster = AnalyticCaster(floor_z=None, plate_north=10.0, plate_half=0.3, plate_z=0.0)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    ping = sonar.ping(caster, origin, LEVEL, 0.0)
    p_s, R_s = sonar.sonar_pose(origin, LEVEL)
    dirs = sonar.geometry.dirs_sonar @ R_s.T
    hits = caster.cast(np.broadcast_to(p_s, dirs.shape), dirs, sonar.cast_window_m[1])
    near, far = sonar.cast_window_m
    idx = np.flatnonzero((hits.distance >= near) & (hits.distance < far))
    cos_inc = np.abs(np.einsum("ij,ij->i", hits.normal[idx], dirs[idx]))
    ref = reference_polar(sonar, idx, hits.distance[idx], cos_inc, hits.reflectivity[idx],
                          depth_m=1.0, axis_depression_rad=math.radians(-10.0))  # fmt: skip
    np.testing.assert_allclose(ping.polar, ref, atol=3e-5)
    quiet = reference_polar(sonar, idx, hits.distance[idx], cos_inc, hits.reflectivity[idx])
    assert (ref - quiet).max() > 0.05  # the surface shows (beyond 1 m)


@pytest.mark.parametrize("model", ["product", "coherent"])
def test_speckled_image_matches_the_reference_given_the_same_fields(model: str) -> None:
    cfg = small_cfg(speckle=True, speckle_model=model)
    caster = AnalyticCaster(plate_north=10.0, plate_half=0.3, plate_z=5.5)
    sonar = ImagingSonar(cfg, np.random.default_rng(4))
    hits, idx, cos_inc = window_hits(sonar, caster)
    r, mu = hits.distance[idx], hits.reflectivity[idx]
    raw, _, _ = sonar._accumulate(idx, r, cos_inc, sonar.ray_intensity(idx, r, cos_inc, mu))
    raw = raw.copy()
    draws = copy.deepcopy(sonar.rng)  # the offsets the next image will draw
    fast = sonar._physical_polar(raw, None)
    bank: SpeckleBank = sonar._bank
    k_ln_w2 = bank.log_w(*bank.w_offset(draws))
    if model == "product":
        fields = (np.exp(k_ln_w2.astype(np.float64) / sonar.geometry.k_ln),)
    else:
        fields = bank.z(int(draws.integers(0, bank.z_offsets)))
    ref = reference_polar(sonar, idx, r, cos_inc, mu, fields=fields)
    assert ref.max() > 0.5
    np.testing.assert_allclose(fast, ref, atol=5e-5)


def test_display_bytes_match_the_reference_mapping() -> None:
    cfg = small_cfg(speckle=True)
    caster = AnalyticCaster(plate_north=10.0, plate_half=0.3, plate_z=5.5)
    ping = ImagingSonar(cfg, np.random.default_rng(5)).ping(caster, ORIGIN, LEVEL, 0)
    assert cfg.display_gamma == 2.5
    expected = reference_bytes(ping.polar.astype(np.float64), cfg.display_gamma)
    assert np.abs(ping.polar_u8.astype(int) - expected).max() <= 1  # float32 rounding
    assert (ping.polar_u8 == expected).mean() > 0.99


@pytest.mark.parametrize("gamma", [1.0, 2.5])
def test_polar_bytes_alone_are_the_ping_s_bytes(gamma: float) -> None:
    """polar_bytes (the vector env's image: the display curve clips the level itself for
    γ ≠ 1) gives the bytes of the whole ping, drawing the same speckle."""
    cfg = small_cfg(speckle=True, display_gamma=gamma)
    caster = AnalyticCaster(plate_north=10.0, plate_half=0.3, plate_z=5.5)
    ping = ImagingSonar(cfg, np.random.default_rng(5)).ping(caster, ORIGIN, LEVEL, 0)
    alone = ImagingSonar(cfg, np.random.default_rng(5))
    p_s, R_s = alone.sonar_pose(ORIGIN, LEVEL)
    hits = cast_fan(caster, p_s, alone.geometry.dirs_sonar @ R_s.T, alone.cast_window_m)
    assert ping.polar.min() == 0.0 and ping.polar.max() == 1.0  # levels were clipped
    np.testing.assert_array_equal(alone.polar_bytes(p_s, R_s, hits), ping.polar_u8)


@pytest.mark.parametrize("gamma", [0.3, 1.0, 2.5, 10.0])
def test_display_curve_clips_as_clip_unit_does(gamma: float) -> None:
    level = np.array([[-np.inf, -3.0, -1e-38, 0.0, 1e-38, 1e-31, 0.3, 0.999, 1.0, 1.0000001,
                       1.5, 40.0, np.inf]], np.float32)
    for black in (0, 17):
        expected = display_bytes(clip_unit(level.copy()), gamma, black)
        got = display_bytes(level.copy(), gamma, black, clipped=False)
        np.testing.assert_array_equal(got, expected)


def test_raw_echo_image_of_a_ping_does_not_keep_the_previous_ping_s_echo() -> None:
    """The raw image is a scratch buffer zeroed only where the previous ping wrote: after a
    ping with echo at every range (and volume echoes added anywhere), a ping with echo
    only near gives the raw image a fresh sonar gives, bit for bit."""
    cfg = small_cfg()
    sonar, fresh = ImagingSonar(cfg, np.random.default_rng(0)), ImagingSonar(
        cfg, np.random.default_rng(0))
    hits, idx, cos_inc = window_hits(sonar, AnalyticCaster(plate_north=None))
    r, mu = hits.distance[idx], hits.reflectivity[idx]
    e = sonar.ray_intensity(idx, r, cos_inc, mu)
    sonar._accumulate(idx, r, cos_inc, e)
    n_bins, n_beams = sonar.polar_shape
    sonar._echoes.add_echoes(np.array([0, n_bins - 1]), np.array([0, n_beams - 1]),
                             np.array([1e-6, 1e-6]))
    near = r < np.quantile(r, 0.2)
    got, _, rows = sonar._accumulate(idx[near], r[near], cos_inc[near], e[near])
    want, _, want_rows = fresh._accumulate(idx[near], r[near], cos_inc[near], e[near])
    assert rows == want_rows and rows[-1][1] < n_bins  # the far rows hold no echo now
    np.testing.assert_array_equal(got, want)


def test_compiled_echo_summing_gives_the_reference_bits(monkeypatch: pytest.MonkeyPatch) -> None:
    """The numba kernels of the echo accumulation are held to the numpy/OpenCV reference
    bit for bit: the footprints (``echoes._footprint_bins_loops`` against
    ``echoes.footprint_bins``: grazing and normal incidence, footprints across the window's
    ends, rays outside it) and their sum into the raw image (``_footprint_image_loops``
    against ``footprint_image``: inside one bin, across many, row counts not a multiple of
    its four rows, cells at and below the floor zeroed), the row runs the footprints reach
    (``_row_runs_loops`` against ``_row_runs``); and whole pings with labels and a surface
    ghost, formed once through each."""
    compiled = echoes._compiled_kernels()
    if compiled is None:
        pytest.skip("numba is not installed (the reference path is the only one)")
    rng = np.random.default_rng(7)
    cfg = dataclasses.replace(small_cfg(), labels=True, multipath=True)
    dphi = 0.01
    r = rng.uniform(0.0, cfg.range_max_m * 1.2, 2000)
    cos_inc = np.concatenate([rng.uniform(0.0, 1.0, 1998), [0.0, 1.0]])
    e = 10.0 ** rng.uniform(-12.0, -3.0, r.size)
    want = echoes.footprint_bins(r, cos_inc, e, dphi, cfg)
    got = compiled[0](r, cos_inc, e, dphi / cfg.bin_m, cfg.range_min_m, cfg.bin_m, cfg.n_bins)
    assert 0 < np.count_nonzero(want[0]) < r.size  # some rays outside the window
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
        assert g.dtype == w.dtype

    for n_rows, n_beams, m in ((1, 5, 3), (6, 16, 400), (37, 48, 3000)):
        a = rng.uniform(0.0, n_rows - 1e-9, m)
        b = np.minimum(a + rng.choice([0.0, 0.3, 2.5, n_rows / 2.0], m), n_rows * (1 - 1e-12))
        lo, hi = a.astype(np.int64), b.astype(np.int64)
        dens = 10.0 ** rng.uniform(-14.0, -3.0, m)
        one = dens * (b - a + rng.uniform(0.0, 1.0, m))
        beam = rng.integers(0, n_beams, m)
        r0 = int(lo.min())
        rows = int(hi.max()) + 1 - r0
        unfloored = np.full((rows, n_beams), np.nan, np.float32)
        echoes.footprint_image(a, b, lo, hi, dens, one, beam, r0, np.zeros((rows + 1) * n_beams),
                               unfloored, np.float32(-np.inf))  # fmt: skip
        # floors: float32's tiny, and a value of the image itself (a cell at the floor is
        # zeroed: only cells above it are kept, as OpenCV's THRESH_TOZERO keeps them)
        for floor in (np.float32(np.finfo(np.float32).tiny),
                      np.float32(np.median(unfloored[unfloored > 0]))):
            want_image, got_image = (np.full((rows, n_beams), np.nan, np.float32)
                                     for _ in range(2))  # fmt: skip
            diff_want, diff_got = np.zeros((2, (rows + 1) * n_beams))
            echoes.footprint_image(a, b, lo, hi, dens, one, beam, r0, diff_want, want_image,
                                   floor)  # fmt: skip
            compiled[1](a, b, lo, hi, dens, one, beam, r0, diff_got, got_image, floor)
            np.testing.assert_array_equal(got_image, want_image)
            assert not diff_got.any() and not diff_want.any()  # scratch left zeroed
        assert (want_image == 0).any() and (want_image > 0).any()

    # the row runs the footprints reach: scattered, touching both ends, none
    for n_bins, m, pad, gap in ((50, 6, 1, 3), (400, 40, 2, 16), (30, 200, 0, 0), (10, 0, 1, 1)):
        lo = rng.integers(0, n_bins, m)
        hi = np.minimum(lo + rng.integers(0, 4, m), n_bins - 1)
        if m:
            lo[0], hi[-1] = 0, n_bins - 1
        reach = np.bincount(lo, minlength=n_bins + 1) - np.bincount(hi + 1, minlength=n_bins + 1)
        want_runs = echoes._row_runs(np.cumsum(reach[:n_bins]) > 0, pad, gap)
        assert compiled[2](lo, hi, n_bins, pad, gap).tolist() == [list(r) for r in want_runs]

    caster = AnalyticCaster()

    def pings() -> list:
        sonar = ImagingSonar(cfg, np.random.default_rng(3))
        return [sonar.ping(caster, ORIGIN + np.array([0.2 * k, 0.0, 0.0]), LEVEL, 0.1 * k)
                for k in range(2)]

    fast = pings()
    monkeypatch.setattr(echoes, "_compiled_kernels", lambda: None)
    for got_ping, want_ping in zip(fast, pings(), strict=True):
        for name in ("polar", "polar_u8", "label_polar", "hit_points_ned"):
            np.testing.assert_array_equal(getattr(got_ping, name), getattr(want_ping, name))
