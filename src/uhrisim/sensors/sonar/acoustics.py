"""Underwater acoustics for the imaging sonar: absorption, transmission loss, scattering,
beam patterns.

Units: frequency in Hz at the API (kHz inside the Francois–Garrison formula, as published),
temperature °C, salinity psu, depth m, absorption dB/m, levels dB re 1 µPa (at 1 m for
source levels). Angles in radians unless suffixed ``_deg``.

References:
    R. E. Francois and G. R. Garrison, "Sound absorption based on ocean measurements.
    Part II: Boric acid contribution and equation for total absorption", J. Acoust. Soc.
    Am. 72(6), 1879–1890 (1982). Valid 0.2–1000 kHz, −2…22 °C (used here to 25 °C, as the
    reference table in ``docs/reference/sonar.md`` does).
    Lambert's law for diffuse backscatter, e.g. Urick, *Principles of Underwater Sound*, 3rd
    ed., §8.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray


def sound_speed_fg(
    temperature_c: ArrayLike, salinity_psu: ArrayLike, depth_m: ArrayLike
) -> NDArray[np.float64] | float:
    """Sound speed (m/s) used inside the Francois–Garrison absorption formula.

    c = 1412 + 3.21 T + 1.19 S + 0.0167 D (Francois & Garrison 1982, Part II, eq. 2).
    Adequate for the absorption terms and for the ping-rate cap; not a full UNESCO equation.
    """
    t = np.asarray(temperature_c, dtype=float)
    s = np.asarray(salinity_psu, dtype=float)
    d = np.asarray(depth_m, dtype=float)
    c = 1412.0 + 3.21 * t + 1.19 * s + 0.0167 * d
    return float(c) if c.ndim == 0 else c


def absorption_terms_db_per_km(
    frequency_hz: ArrayLike,
    temperature_c: ArrayLike,
    salinity_psu: ArrayLike,
    depth_m: ArrayLike,
    ph: ArrayLike = 8.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The three Francois–Garrison absorption terms (boric acid, MgSO4, pure water), dB/km.

    Each is A_i · P_i · f_i f² / (f² + f_i²) (relaxation terms) or A_3 P_3 f² (pure water),
    with f in kHz, exactly as in Francois & Garrison (1982), Part II, eqs 2–4.
    """
    f = np.asarray(frequency_hz, dtype=float) / 1e3  # kHz
    t = np.asarray(temperature_c, dtype=float)
    s = np.asarray(salinity_psu, dtype=float)
    d = np.asarray(depth_m, dtype=float)
    ph = np.asarray(ph, dtype=float)
    c = np.asarray(sound_speed_fg(t, s, d), dtype=float)
    theta = 273.0 + t
    f2 = f * f

    # Boric acid B(OH)3 relaxation.
    a1 = (8.86 / c) * 10.0 ** (0.78 * ph - 5.0)
    p1 = 1.0
    f1 = 2.8 * np.sqrt(s / 35.0) * 10.0 ** (4.0 - 1245.0 / theta)
    boric = a1 * p1 * f1 * f2 / (f2 + f1 * f1)

    # Magnesium sulphate MgSO4 relaxation.
    a2 = 21.44 * (s / c) * (1.0 + 0.025 * t)
    p2 = 1.0 - 1.37e-4 * d + 6.2e-9 * d * d
    f2r = (8.17 * 10.0 ** (8.0 - 1990.0 / theta)) / (1.0 + 0.0018 * (s - 35.0))
    mgso4 = a2 * p2 * f2r * f2 / (f2 + f2r * f2r)

    # Pure water (viscous) absorption; two polynomials split at 20 °C.
    a3 = np.where(
        t <= 20.0,
        4.937e-4 - 2.59e-5 * t + 9.11e-7 * t**2 - 1.50e-8 * t**3,
        3.964e-4 - 1.146e-5 * t + 1.45e-7 * t**2 - 6.5e-10 * t**3,
    )
    p3 = 1.0 - 3.83e-5 * d + 4.9e-10 * d * d
    water = a3 * p3 * f2
    return np.asarray(boric), np.asarray(mgso4), np.asarray(water)


def absorption_db_per_m(
    frequency_hz: ArrayLike,
    temperature_c: ArrayLike,
    salinity_psu: ArrayLike,
    depth_m: ArrayLike,
    ph: ArrayLike = 8.0,
) -> NDArray[np.float64] | float:
    """Sound absorption coefficient α in dB/m (Francois & Garrison 1982, total)."""
    boric, mgso4, water = absorption_terms_db_per_km(
        frequency_hz, temperature_c, salinity_psu, depth_m, ph
    )
    alpha = (boric + mgso4 + water) / 1e3
    return float(alpha) if np.ndim(alpha) == 0 else alpha


def transmission_loss_db(range_m: ArrayLike, alpha_db_per_m: float) -> NDArray[np.float64] | float:
    """One-way transmission loss TL = 20·log10(R) + α·R in dB (R in m, re 1 m).

    Spherical spreading plus absorption; the sonar equation uses 2·TL for the echo.
    """
    r = np.maximum(np.asarray(range_m, dtype=float), 1e-6)
    tl = 20.0 * np.log10(r) + alpha_db_per_m * r
    return float(tl) if tl.ndim == 0 else tl


def tvg_db(
    range_m: ArrayLike, alpha_db_per_m: float, spreading_db_per_decade: float = 40.0
) -> NDArray[np.float64] | float:
    """Time-varied gain (dB): ``spreading·log10(R) + 2αR``; 40 log R undoes 2·TL exactly."""
    r = np.maximum(np.asarray(range_m, dtype=float), 1e-6)
    g = spreading_db_per_decade * np.log10(r) + 2.0 * alpha_db_per_m * r
    return float(g) if g.ndim == 0 else g


def lambert_backscatter(mu: ArrayLike, cos_incidence: ArrayLike) -> NDArray[np.float64]:
    """Lambert backscattering cross-section per unit surface area: μ·cos²β (linear).

    β is the incidence angle from the surface normal (cos β = |n·d|).
    """
    c = np.clip(np.asarray(cos_incidence, dtype=float), 0.0, 1.0)
    return np.asarray(mu, dtype=float) * c * c


def lambert_target_strength_db(
    mu: ArrayLike, cos_incidence: ArrayLike, area_m2: ArrayLike
) -> NDArray[np.float64] | float:
    """Target strength TS = 10·log10(μ·cos²β·A) in dB re 1 m² (A = insonified surface area)."""
    sigma = lambert_backscatter(mu, cos_incidence) * np.asarray(area_m2, dtype=float)
    ts = 10.0 * np.log10(np.maximum(sigma, 1e-300))
    return float(ts) if np.ndim(ts) == 0 else ts


# sinc²(x) falls to one half at x = 0.442946 (np.sinc(x) = sin(πx)/(πx)).
_SINC2_HALF_POWER_X = 0.4429462


def beam_pattern_sinc2(angle_rad: ArrayLike, width_3db_rad: float) -> NDArray[np.float64]:
    """Power pattern of a uniform line aperture, sinc², with the given -3 dB full width."""
    x = np.asarray(angle_rad, dtype=float) * (2.0 * _SINC2_HALF_POWER_X / width_3db_rad)
    return np.sinc(x) ** 2


def beam_pattern_gaussian(angle_rad: ArrayLike, width_3db_rad: float) -> NDArray[np.float64]:
    """Gaussian power pattern with the given -3 dB full width (one-way).

    Used for the 20° vertical aperture, whose shape vendors do not publish; square it for a
    two-way (transmit × receive) pattern.
    """
    a = np.asarray(angle_rad, dtype=float) / (0.5 * width_3db_rad)
    return np.exp(-np.log(2.0) * a * a)


def horizontal_beam_kernel(
    beam_spacing_rad: float,
    width_3db_rad: float,
    sidelobe_db: float = -25.0,
    n_sidelobes: int = 2,
) -> NDArray[np.float32]:
    """Discrete horizontal beam-pattern kernel sampled at the beam spacing.

    The main lobe is sinc² with the requested -3 dB width (1° over 0.176° spacing gives a
    main lobe ~6 beams wide at -3 dB and ~13 between nulls); the side lobes keep the sinc²
    shape but are scaled so the first sits at ``sidelobe_db`` (a uniform aperture gives
    -13.3 dB; real arrays are shaded, -20…-30 dB). ``n_sidelobes`` lobes are kept each side.
    The kernel peaks at 1 (a beam sees a point target on its axis at full gain) and is not
    normalised: a beam integrates the echoes across its width, as a formed beam does.
    """
    x_per_rad = 2.0 * _SINC2_HALF_POWER_X / width_3db_rad
    half = int(np.ceil((1.0 + n_sidelobes) / x_per_rad / beam_spacing_rad))
    k = np.arange(-half, half + 1, dtype=float)
    x = k * beam_spacing_rad * x_per_rad
    p = np.sinc(x) ** 2
    side = np.abs(x) > 1.0
    first_sidelobe_db = -13.2618
    p[side] *= 10.0 ** ((sidelobe_db - first_sidelobe_db) / 10.0)
    p[np.abs(x) > 1.0 + n_sidelobes] = 0.0
    nz = np.flatnonzero(p > 0.0)
    trim = min(int(nz[0]), len(p) - 1 - int(nz[-1]))
    return p[trim : len(p) - trim].astype(np.float32)


def range_blur_kernel(bin_m: float, resolution_m: float) -> NDArray[np.float32]:
    """Range point-spread kernel (sum 1) for a pulse of range resolution ``resolution_m``.

    Gaussian with FWHM = resolution_m, sampled at the bin size, truncated at ±2 FWHM.
    When the resolution is finer than ~0.3 bin the kernel is the identity.
    """
    sigma_bins = resolution_m / bin_m / 2.354820
    if sigma_bins < 0.15:
        return np.ones(1, dtype=np.float32)
    half = max(1, int(np.ceil(2.0 * 2.354820 * sigma_bins)))
    k = np.arange(-half, half + 1, dtype=float)
    w = np.exp(-0.5 * (k / sigma_bins) ** 2)
    return (w / w.sum()).astype(np.float32)


def beam_amplitude_kernel(
    beam_spacing_rad: float,
    width_3db_rad: float,
    sidelobe_db: float = -25.0,
    n_sidelobes: int = 2,
) -> NDArray[np.float32]:
    """Signed amplitude (complex-voltage) pattern whose square is
    :func:`horizontal_beam_kernel`: a sinc with the same main lobe, its side lobes
    alternating in sign as a line aperture's do. A formed beam sums scatterer amplitudes
    through it, so the speckle grain across beams is set by the beam width."""
    power = horizontal_beam_kernel(beam_spacing_rad, width_3db_rad, sidelobe_db, n_sidelobes)
    half = power.size // 2
    x = np.arange(-half, half + 1) * beam_spacing_rad * (2.0 * _SINC2_HALF_POWER_X / width_3db_rad)
    sign = np.where(np.sinc(x) < 0.0, -1.0, 1.0)
    return (sign * np.sqrt(power.astype(np.float64))).astype(np.float32)


def thermal_noise_spectrum_db(frequency_hz: ArrayLike) -> NDArray[np.float64] | float:
    """Thermal (molecular agitation) noise spectrum level, dB re 1 µPa²/Hz:
    NL = −15 + 20·log10(f / 1 kHz) (Mellen 1952; the high-frequency limb of the Wenz
    curves). It dominates the ambient noise above ~100 kHz."""
    nl = -15.0 + 20.0 * np.log10(np.asarray(frequency_hz, dtype=float) / 1e3)
    return float(nl) if nl.ndim == 0 else nl


def wind_noise_spectrum_db(
    frequency_hz: ArrayLike, sea_state: float
) -> NDArray[np.float64] | float:
    """Wind/sea-state noise spectrum level, dB re 1 µPa²/Hz, after Knudsen as drawn in the
    Wenz curves: 56 + 19·log10(sea state) at 1 kHz (sea state 0 taken as 0.5), falling
    17 dB per decade of frequency (Urick, *Principles of Underwater Sound*, 3rd ed., §7.4).
    At 900 kHz it is ~40 dB below thermal noise: kept so low-frequency specs are right."""
    ss = max(float(sea_state), 0.5)
    f = np.asarray(frequency_hz, dtype=float) / 1e3
    nl = 56.0 + 19.0 * math.log10(ss) - 17.0 * np.log10(f)
    return float(nl) if nl.ndim == 0 else nl


def ambient_noise_band_db(frequency_hz: float, bandwidth_hz: float, sea_state: float) -> float:
    """Ambient noise band level at the hydrophone, dB re 1 µPa²: the power sum of the
    thermal and wind spectrum levels times the receiver bandwidth."""
    spectrum = 10.0 ** (thermal_noise_spectrum_db(frequency_hz) / 10.0) + 10.0 ** (
        wind_noise_spectrum_db(frequency_hz, sea_state) / 10.0
    )
    return float(10.0 * math.log10(spectrum * bandwidth_hz))


def directivity_index_db(width_h_rad: float, width_v_rad: float) -> float:
    """Receive directivity index of a beam of the given −3 dB widths, dB:
    DI ≈ 10·log10(4π / (θ_h·θ_v)) (Urick §3.6; isotropic noise rejected by a formed beam)."""
    return float(10.0 * math.log10(4.0 * math.pi / (width_h_rad * width_v_rad)))


def element_directivity(
    theta_rad: ArrayLike, edge_rad: float, edge_loss_db: float
) -> NDArray[np.float64]:
    """Two-way power pattern of one array element across the fan: sinc²(u·sin θ)² with u
    chosen so the pattern is ``edge_loss_db`` down at ``edge_rad`` (the fan edge). Vendors
    do not publish the element pattern; the edge loss is the knob (0 dB: flat)."""
    theta = np.asarray(theta_rad, dtype=float)
    if edge_loss_db <= 0.0:
        return np.ones_like(theta)
    # sinc(x)^4 = 10^(-loss/10) → sinc(x) = 10^(-loss/40): solve for x on the main lobe.
    target = 10.0 ** (-edge_loss_db / 40.0)
    lo, hi = 0.0, 1.0
    for _ in range(60):  # bisection: sinc is monotone on [0, 1]
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.sinc(mid) > target else (lo, mid)
    u = 0.5 * (lo + hi) / math.sin(edge_rad)
    return np.sinc(u * np.sin(theta)) ** 4


def gaussian_pattern_integral(width_3db_rad: float) -> float:
    """∫ b(φ)² dφ over all φ for the Gaussian one-way power pattern b of
    :func:`beam_pattern_gaussian` (two-way, b²): the equivalent angular width, rad."""
    return float(0.5 * width_3db_rad * math.sqrt(math.pi / (2.0 * math.log(2.0))))
