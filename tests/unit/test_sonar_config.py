"""SonarConfig validation, presets and the physics cap on the ping rate."""

from __future__ import annotations

import dataclasses
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
        # Image formation (issue 14): a negative gain, noise at or above the source level.
        ({"gain_db": -3.0}, "gain_db"),
        ({"noise_floor_db": 215.0}, "noise_floor_db"),
        ({"noise_floor_db": 210.0}, "noise_floor_db"),
        ({"display_gamma": 0.0}, "display_gamma"),
        ({"speckle_model": "fancy"}, "speckle_model"),
        ({"sea_state": 12.0}, "sea_state"),
        ({"far_sidelobe_db": 3.0}, "far_sidelobe_db"),
        ({"sidelobe_db": 0.0}, "sidelobe_db"),
        ({"fan_edge_loss_db": -1.0}, "fan_edge_loss_db"),
        ({"tvg_min_range_m": -1.0}, "tvg_min_range_m"),
        ({"receiver_bandwidth_hz": 0.0}, "receiver_bandwidth_hz"),
        ({"post_tvg_noise_db": math.inf}, "post_tvg_noise_db"),
        ({"n_sidelobes": -1}, "n_sidelobes"),
        ({"multipath_loss_db": -2.0}, "multipath_loss_db"),
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


@pytest.mark.parametrize(("field", "value"), [("n_beams", 0), ("n_beams", 1), ("sidelobe_db", 2.0),
                                              ("fan_edge_loss_db", 40.0)])  # fmt: skip
def test_bad_spec_names_the_field(field: str, value: float) -> None:
    # Zero beams (or one: no spacing) is a one-line error naming the spec's field.
    with pytest.raises(ConfigError) as err:
        dataclasses.replace(get_preset("P900-45"), **{field: value})
    assert err.value.where == f"SonarSpec('P900-45').{field}"
    assert "\n" not in str(err.value)


SCENARIO = """name: x
agents:
  - name: rov
    model: kinematic
    driver: none
    sensors:
      - {type: sonar, range_max_m: 10, IMAGE}
"""


def test_scenario_image_settings_reach_the_sonar(tmp_path) -> None:
    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim.simulation import Simulation

    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO.replace("IMAGE", "gain_db: 6, post_tvg_noise_db: null, "
                                     "speckle_model: coherent"))  # fmt: skip
    sim = Simulation(load_scenario(path))
    cfg = sim.agents["rov"].sonars[0].sonar.config
    assert (cfg.gain_db, cfg.post_tvg_noise_db, cfg.speckle_model) == (6.0, None, "coherent")
    assert cfg.display_gamma == SonarConfig().display_gamma  # left out: the default
    path.write_text(SCENARIO.replace("IMAGE", "gain_db: -3"))
    with pytest.raises(ConfigError) as err:  # refused at load, by SonarConfig's declaration
        load_scenario(path)
    assert "s.yaml:7" in str(err.value) and "sensors[0].gain_db" in str(err.value)
    assert "must be in [0, 200] dB, got -3" in str(err.value)
