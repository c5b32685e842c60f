"""SonarConfig validation, presets and the physics cap on the ping rate."""

from __future__ import annotations

import logging
import math

import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar import PRESETS, SonarConfig, get_preset


def test_presets_table_i() -> None:
    p = PRESETS["P900-45"]  # DeMarco et al. 2013, Table I
    assert (p.frequency_hz, p.fov_h_deg, p.n_beams) == (900e3, 45.0, 256)
    assert (p.beam_width_h_deg, p.beam_width_v_deg, p.max_range_m) == (1.0, 20.0, 100.0)
    assert p.range_resolution_m == pytest.approx(0.0254)
    assert p.beam_spacing_deg == pytest.approx(0.18, abs=0.005)
    assert PRESETS["P900-90"].n_beams == 512 and PRESETS["P900-130"].n_beams == 768
    assert PRESETS["P900-130"].fov_h_deg == 130.0


def test_unknown_preset() -> None:
    with pytest.raises(ConfigError, match="P900-45"):
        get_preset("P901")
    with pytest.raises(ConfigError, match="preset"):
        SonarConfig(preset="nope")


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"range_max_m": 0.0}, "range_max_m"),
        ({"range_max_m": -5.0}, "range_max_m"),
        ({"range_min_m": -1.0}, "range_min_m"),
        ({"range_min_m": 10.0, "range_max_m": 10.0}, "range_min_m"),
        ({"range_max_m": 150.0}, "range_max_m"),  # beyond the P900-45's 100 m
        ({"range_resolution_m": 0.0}, "range_resolution_m"),
        ({"rays_per_beam": 1}, "rays_per_beam"),
        ({"rays_per_beam": 8.5}, "rays_per_beam"),
        ({"rate_hz": 0.0}, "rate_hz"),
        ({"tilt_deg": 95.0}, "tilt_deg"),
        ({"mode": "2014"}, "mode"),
        ({"colormap": "rainbow-ish"}, "colormap"),
        ({"mount_position_frd": (0.0, 0.0)}, "mount_position_frd"),
        ({"dynamic_range_db": 0.0}, "dynamic_range_db"),
        ({"blur_ksize_2013": 4}, "blur_ksize_2013"),
        ({"gain_db": math.nan}, "gain_db"),
    ],
)
def test_bad_values_name_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ConfigError) as err:
        SonarConfig(**kwargs)
    assert f"SonarConfig.{field}" in str(err.value)
    assert err.value.where == f"SonarConfig.{field}"


def test_ping_rate_capped_by_range(caplog: pytest.LogCaptureFixture) -> None:
    # At 100 m the two-way travel 2R/c with a 1.1 margin allows c/(2.2·100) ≈ 6.8 Hz.
    with caplog.at_level(logging.WARNING), pytest.warns(UserWarning, match="rate_hz"):
        cfg = SonarConfig(range_max_m=100.0, rate_hz=15.0)
    c = 1412 + 3.21 * 15 + 1.19 * 35 + 0.0167 * 5
    assert cfg.effective_rate_hz == pytest.approx(c / (1.1 * 2 * 100.0))
    assert cfg.effective_rate_hz < 7.5
    assert any("rate_hz" in r.message for r in caplog.records)


def test_ping_rate_not_capped_at_short_range(recwarn: pytest.WarningsRecorder) -> None:
    cfg = SonarConfig(range_max_m=30.0, rate_hz=15.0)  # cap ≈ 22.8 Hz
    assert cfg.effective_rate_hz == 15.0
    assert not [w for w in recwarn if "rate_hz" in str(w.message)]
    # The hardware limit (15 Hz) also caps: asking 20 Hz at 30 m gives 15 Hz.
    with pytest.warns(UserWarning):
        assert SonarConfig(range_max_m=30.0, rate_hz=20.0).effective_rate_hz == 15.0


def test_bins_and_absorption() -> None:
    cfg = SonarConfig(range_min_m=1.0, range_max_m=31.0)
    assert cfg.bin_m == pytest.approx(0.0254)
    assert cfg.n_bins == math.ceil(30.0 / 0.0254)
    assert cfg.alpha_db_per_m == pytest.approx(0.279, abs=0.01)


def test_floor_coverage_range() -> None:
    # δφ = 20°/64; bins hit continuously while R²δφ/h < Δr → R = sqrt(Δr·h/δφ).
    cfg = SonarConfig(rays_per_beam=64)
    dphi = math.radians(20.0) / 64
    assert cfg.floor_bin_coverage_range_m(5.0) == pytest.approx(math.sqrt(0.0254 * 5 / dphi))
