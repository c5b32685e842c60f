"""Acoustics of the imaging sonar against published numbers (docs/reference/sonar.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.sensors.sonar.acoustics import (
    absorption_db_per_m,
    absorption_terms_db_per_km,
    beam_pattern_gaussian,
    beam_pattern_sinc2,
    horizontal_beam_kernel,
    lambert_target_strength_db,
    range_blur_kernel,
    sound_speed_fg,
    transmission_loss_db,
    tvg_db,
)

# Francois-Garrison (1982) at 900 kHz, depth 5 m, pH 8 (docs/reference/sonar.md table).
FG_TABLE = [
    # T (°C), sea water S=35, fresh water S=0  (dB/m)
    (5.0, 0.344, 0.312),
    (10.0, 0.299, 0.252),
    (15.0, 0.279, 0.210),
    (20.0, 0.274, 0.178),
    (25.0, 0.286, 0.154),
]


@pytest.mark.parametrize(("temp", "sea", "fresh"), FG_TABLE)
def test_absorption_matches_reference_table(temp: float, sea: float, fresh: float) -> None:
    assert absorption_db_per_m(900e3, temp, 35.0, 5.0, 8.0) == pytest.approx(sea, abs=0.01)
    assert absorption_db_per_m(900e3, temp, 0.0, 5.0, 8.0) == pytest.approx(fresh, abs=0.01)


def test_absorption_is_pure_water_term_in_fresh_water() -> None:
    # S = 0 removes both relaxation terms (f1 ∝ sqrt(S/35), A2 ∝ S).
    boric, mgso4, water = absorption_terms_db_per_km(900e3, 15.0, 0.0, 5.0, 8.0)
    assert float(boric) == 0.0 and float(mgso4) == 0.0
    # Hand evaluation of the pure-water polynomial at 15 °C, D = 5 m, f = 900 kHz.
    a3 = 4.937e-4 - 2.59e-5 * 15 + 9.11e-7 * 15**2 - 1.50e-8 * 15**3
    p3 = 1 - 3.83e-5 * 5 + 4.9e-10 * 25
    assert float(water) == pytest.approx(a3 * p3 * 900.0**2, rel=1e-12)


def test_absorption_low_frequency_is_boric_acid_dominated() -> None:
    # Well below f1 (~1 kHz) the boric-acid term dominates sea-water absorption.
    boric, mgso4, water = absorption_terms_db_per_km(200.0, 10.0, 35.0, 0.0, 8.0)
    assert boric > mgso4 > water


def test_sound_speed_formula() -> None:
    assert sound_speed_fg(15.0, 35.0, 5.0) == pytest.approx(
        1412 + 3.21 * 15 + 1.19 * 35 + 0.0167 * 5
    )


def test_two_way_loss_reference_values() -> None:
    # Reference note: two-way loss at 15 °C sea water 45.6 dB at 10 m, 63.2 dB at 20 m.
    alpha = absorption_db_per_m(900e3, 15.0, 35.0, 5.0, 8.0)
    assert 2 * transmission_loss_db(10.0, alpha) == pytest.approx(45.6, abs=0.1)
    assert 2 * transmission_loss_db(20.0, alpha) == pytest.approx(63.2, abs=0.1)
    # 40 log R + 2αR TVG undoes the two-way loss exactly.
    r = np.array([1.0, 7.0, 55.0])
    assert np.allclose(tvg_db(r, alpha), 2 * transmission_loss_db(r, alpha))


def test_lambert_target_strength() -> None:
    # μ = 0.01 (−20 dB), normal incidence, 1 m² → −20 dB; at 60° cos² = 1/4 → −26.02 dB.
    assert lambert_target_strength_db(0.01, 1.0, 1.0) == pytest.approx(-20.0)
    assert lambert_target_strength_db(0.01, 0.5, 1.0) == pytest.approx(-20 + 20 * math.log10(0.5))


def test_beam_patterns_half_power_at_half_width() -> None:
    w = math.radians(1.0)
    assert beam_pattern_sinc2(0.5 * w, w) == pytest.approx(0.5, abs=1e-4)
    assert beam_pattern_sinc2(0.0, w) == pytest.approx(1.0)
    v = math.radians(20.0)
    assert beam_pattern_gaussian(0.5 * v, v) == pytest.approx(0.5)


def test_horizontal_kernel_shape() -> None:
    spacing = math.radians(45.0 / 255.0)
    k = horizontal_beam_kernel(spacing, math.radians(1.0), sidelobe_db=-25.0)
    centre = len(k) // 2
    assert k[centre] == pytest.approx(1.0)
    assert np.allclose(k, k[::-1])
    # -3 dB full width of 1° over 0.176° spacing ≈ 5.7 beams: beams ±2 are above half
    # power, beams ±3 (0.53°) below.
    assert k[centre + 2] > 0.5 > k[centre + 3]
    # First side lobe at 1.43 sinc units ≈ 1.61° ≈ 9.2 beams, scaled to −25 dB.
    side = k[centre + 8 : centre + 12].max()
    assert 10 * math.log10(side) == pytest.approx(-25.0, abs=1.0)


def test_range_blur_kernel_fwhm() -> None:
    k = range_blur_kernel(0.01, 0.05)  # FWHM 5 bins
    assert k.sum() == pytest.approx(1.0, abs=1e-6)
    c = len(k) // 2
    # Gaussian with FWHM 5 bins: value at ±2.5 bins is half the peak.
    half_level = np.interp(2.5, np.arange(len(k)) - c, k)
    assert half_level / k[c] == pytest.approx(0.5, abs=0.03)
    assert range_blur_kernel(0.0254, 0.001).tolist() == [1.0]
