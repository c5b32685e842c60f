"""The sonar presets against the makers' published specifications (issue 31), and the
native image geometry of their polar output: beam count, beam angles and spacing (ARIS's
measured, non-uniform table), field of view, range sample spacing.

``CITED`` restates the numbers of the preset table of ``docs/sonar.md`` (where each one's
source is named); the presets are held to it, and each preset's ping to its spec.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.support.analytic_sonar import LEVEL, ORIGIN, AnalyticCaster
from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar import PRESETS, ImagingSonar, SonarConfig, get_preset
from uhrisim.sensors.sonar.beam_tables import ARIS3000_64, ARIS3000_128
from uhrisim.sensors.sonar.fan import fractional_beam

#: name: (frequency Hz, field of view deg, beams, horizontal beam width deg, vertical deg,
#: maximum range m, range resolution m, ping rate Hz) — docs/sonar.md, "Presets".
CITED = {
    "P900-45": (900e3, 45.0, 256, 1.0, 20.0, 100.0, 0.0254, 15.0),
    "P900-90": (900e3, 90.0, 512, 1.0, 20.0, 100.0, 0.0254, 15.0),
    "P900-130": (900e3, 130.0, 768, 1.0, 20.0, 100.0, 0.0254, 15.0),
    "M900-130": (900e3, 130.0, 768, 1.0, 20.0, 100.0, 0.014, 25.0),
    "ARIS3000-1.8MHz": (1.8e6, 29.406, 64, 0.466, 14.0, 20.0, 0.012, 15.0),
    "ARIS3000-3MHz": (3.0e6, 29.41, 128, 0.232, 14.0, 20.0, 0.0075, 15.0),
    "M750d-750kHz": (750e3, 130.0, 512, 1.0, 20.0, 120.0, 0.004, 40.0),
    "M750d-1.2MHz": (1.2e6, 70.0, 512, 0.6, 12.0, 40.0, 0.0025, 40.0),
    "M1200d-1.2MHz": (1.2e6, 130.0, 512, 0.6, 20.0, 30.0, 0.0025, 40.0),
    "M1200d-2.1MHz": (2.1e6, 60.0, 512, 0.4, 12.0, 10.0, 0.0025, 40.0),
    "Gemini-720ik": (720e3, 130.0, 512, 1.0, 20.0, 120.0, 0.008, 30.0),
}


def test_every_preset_is_cited_and_holds_its_cited_numbers() -> None:
    assert set(PRESETS) == set(CITED)
    for name, cited in CITED.items():
        p = PRESETS[name]
        got = (p.frequency_hz, p.fov_h_deg, p.n_beams, p.beam_width_h_deg, p.beam_width_v_deg,
               p.max_range_m, p.range_resolution_m, p.max_rate_hz)  # fmt: skip
        np.testing.assert_allclose(got, cited, rtol=1e-9, err_msg=name)
        assert p.source, name


def test_quoted_beam_separations() -> None:
    # Table I of DeMarco et al. (P900-45): 0.18°; the M900-130's datasheet: 0.18° (768 beams
    # over 130°: 0.1695°, the quoted figure rounded); ARIS 3000 (the maker's table): 0.232°
    # mean at 3 MHz, 0.467° at 1.8 MHz.
    assert PRESETS["P900-45"].beam_spacing_deg == pytest.approx(0.18, abs=0.005)
    assert PRESETS["M900-130"].beam_spacing_deg == pytest.approx(0.18, abs=0.011)
    assert PRESETS["ARIS3000-3MHz"].beam_spacing_deg == pytest.approx(0.2316, abs=5e-4)
    assert PRESETS["ARIS3000-1.8MHz"].beam_spacing_deg == pytest.approx(0.4668, abs=5e-4)


@pytest.mark.parametrize(("name", "table", "edge", "mid", "axis"), [
    ("ARIS3000-3MHz", ARIS3000_128, 0.217, 0.2317, 0.246),
    ("ARIS3000-1.8MHz", ARIS3000_64, 0.438, 0.467, 0.497),
])  # fmt: skip
def test_aris_beams_follow_the_makers_lens_table(name, table, edge, mid, axis) -> None:
    spec = get_preset(name)
    angles = np.degrees(spec.beam_angles_rad)
    np.testing.assert_allclose(angles, table, atol=1e-9)
    np.testing.assert_allclose(angles, -angles[::-1], atol=1e-9)  # symmetric about the axis
    spacing = np.diff(angles)
    n = len(angles)
    # Narrow at the edges, wide around the axis (the lens), as the maker's table gives them.
    assert spacing[0] == pytest.approx(edge, abs=1e-3)
    assert spacing[n // 4] == pytest.approx(mid, abs=1e-3)
    assert spacing[n // 2 - 1] == pytest.approx(axis, abs=2e-3)
    assert spacing.max() / spacing.min() == pytest.approx(axis / edge, rel=0.01)
    assert not spec.steered  # a lens, not a steered array


@pytest.mark.parametrize("name", sorted(CITED))
def test_each_presets_ping_has_its_native_polar_geometry(name: str) -> None:
    spec = get_preset(name)
    window = min(5.0, spec.max_range_m)
    cfg = SonarConfig(preset=name, range_min_m=0.5, range_max_m=window, rays_per_beam=4,
                      tilt_deg=15.0, mount_position_frd=(0.0, 0.0, 0.0), rate_hz=10.0,
                      fan_size_px=128)  # fmt: skip
    ping = ImagingSonar(cfg, np.random.default_rng(0)).ping(AnalyticCaster(), ORIGIN, LEVEL, 0)
    n_bins = math.ceil((window - 0.5) / spec.range_resolution_m - 1e-9)
    assert ping.polar.shape == ping.polar_u8.shape == (n_bins, spec.n_beams)
    # Range samples: one bin of the native range resolution each, centred in its bin.
    np.testing.assert_allclose(np.diff(ping.bin_ranges_m), spec.range_resolution_m, rtol=1e-9)
    assert ping.bin_ranges_m[0] == pytest.approx(0.5 + 0.5 * spec.range_resolution_m)
    # Beams: the native angles, spanning the field of view, mean spacing FOV/(n − 1).
    np.testing.assert_allclose(ping.beam_angles_rad, spec.beam_angles_rad, atol=1e-12)
    fov = math.degrees(ping.beam_angles_rad[-1] - ping.beam_angles_rad[0])
    assert fov == pytest.approx(spec.fov_h_deg, abs=1e-9)
    mean = np.degrees(np.diff(ping.beam_angles_rad)).mean()
    assert mean == pytest.approx(spec.fov_h_deg / (spec.n_beams - 1), rel=1e-9)


@pytest.mark.parametrize("name", ["ARIS3000-3MHz", "P900-45"])
def test_the_fan_samples_each_bearing_from_the_beams_that_bracket_it(name: str) -> None:
    spec = get_preset(name)
    cfg = SonarConfig(preset=name, range_max_m=5.0, rays_per_beam=4, fan_size_px=400)
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    g = sonar.geometry
    ys, xs = np.nonzero(g.fan_mask)
    col0, row0 = g.fan_apex
    bearing = np.arctan2((xs - col0) / g.fan_scale, (row0 - ys) / g.fan_scale)
    beam = g.map_x[ys, xs]
    # Wherever a fan pixel's bearing is a beam centre, it samples that beam exactly; in
    # between, linearly between the two centres that bracket it (the native, uneven angles).
    angles = spec.beam_angles_rad
    inside = (bearing >= angles[0]) & (bearing <= angles[-1])
    j = np.clip(np.searchsorted(angles, bearing[inside]) - 1, 0, len(angles) - 2)
    t = (bearing[inside] - angles[j]) / (angles[j + 1] - angles[j])
    np.testing.assert_allclose(beam[inside], j + t, atol=1e-4)
    # The fan spans the beam centres and half a beam beyond the outer ones.
    assert beam.min() >= -0.5 - 1e-6 and beam.max() <= spec.n_beams - 0.5 + 1e-6


def test_fractional_beam_continues_beyond_the_outer_beams_with_their_spacing() -> None:
    angles = np.radians(np.array(ARIS3000_128))
    first, last = angles[1] - angles[0], angles[-1] - angles[-2]
    got = fractional_beam(np.array([angles[0] - 0.5 * first, angles[-1] + 0.5 * last]), angles)
    np.testing.assert_allclose(got, [-0.5, 127.5], atol=1e-9)
    np.testing.assert_allclose(fractional_beam(angles, angles), np.arange(128), atol=1e-9)


@pytest.mark.parametrize(("change", "message"), [
    ({"beam_angles_deg": (1.0, 2.0)}, "one per beam"),
    ({"beam_angles_deg": tuple(reversed(ARIS3000_128))}, "ascend"),
    ({"beam_angles_deg": tuple(a * 0.9 for a in ARIS3000_128)}, "start at"),
    ({"tvg_max_gain_db": 0.0}, "tvg_max_gain_db"),
    ({"display_black_level": 255}, "display_black_level"),
])  # fmt: skip
def test_a_bad_native_table_names_the_field(change: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as err:
        dataclasses.replace(get_preset("ARIS3000-3MHz"), **change)
    assert "SonarSpec('ARIS3000-3MHz')" in str(err.value)
