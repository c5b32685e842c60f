"""Every part a scenario configures is the part the Python API builds from the same values.

A part declares its settings once (uhrisim.core.settings); the scenario section embeds
that declaration (uhrisim.scenario.sections). Here each part — the sonar, the camera,
the VideoRay's model and its controller gains — is built by the simulation from a YAML
scenario, once with nothing set (the part's own defaults) and once with every declared
setting moved off its default, and compared with the part constructed directly.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import yaml

from uhrisim.control.videoray_p import GAIN_PRESETS, PGains
from uhrisim.core.errors import ConfigError
from uhrisim.core.settings import Quantity, declared
from uhrisim.dynamics.videoray import VideoRayParams
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.schema import CameraSensor, ControllerConfig, SonarSensor
from uhrisim.sensors.camera import CameraConfig, jerlov
from uhrisim.sensors.sonar import SonarConfig
from uhrisim.sim.simulation import Simulation


def _off_default(quantity: Quantity, default: object) -> float:
    """A value inside the declared bounds that is not the default."""
    low = quantity.ge if quantity.ge is not None else quantity.gt
    high = quantity.le if quantity.le is not None else quantity.lt
    base = 1.0 if default is None else float(default)  # type: ignore[arg-type]
    for candidate in (base + 1.0, base - 1.0, base * 1.5, base * 0.5,
                      (low + high) / 2.0 if low is not None and high is not None else base):
        value = round(candidate) if quantity.integer else candidate
        if value != default and quantity.problem(value) is None:
            return value
    raise AssertionError(f"no value off the default {default!r} in {quantity.range_text()}")


def _moved(part: type, names: set[str], keep: dict[str, object]) -> dict[str, object]:
    """Every declared setting of ``part`` among ``names`` off its default (``keep``: the
    values the part's cross-checks need, given as they are)."""
    values: dict[str, object] = {}
    for field, quantity in declared(part):
        if field.name not in names or field.name in keep:
            continue
        if isinstance(field.default, tuple):
            values[field.name] = tuple(v + 0.05 for v in field.default)
        else:
            values[field.name] = _off_default(quantity, field.default)
    return values | keep


def _build(tmp_path: Path, rov: dict) -> Simulation:
    data = {"name": "parts", "agents": [{"name": "rov", "model": "videoray", "driver": "none",
                                         "start": {"depth": 2.0}, **rov}]}
    path = tmp_path / "parts.yaml"
    path.write_text(yaml.safe_dump(data))
    return Simulation(load_scenario(path))


def _section_names(section: type) -> set[str]:
    return set(section.model_fields)


SONAR_KEEP = {"range_min_m": 0.5, "range_max_m": 12.0, "range_resolution_m": 0.05,
              "noise_floor_db": 70.0, "rate_hz": 10.0, "blur_ksize_2013": 7,
              "mount_position_frd": (0.15, 0.0, 0.05), "tilt_deg": 12.0}


def test_sonar_from_yaml_is_the_sonar_config_of_the_same_values(tmp_path: Path) -> None:
    sim = _build(tmp_path, {"sensors": [{"type": "sonar"}]})
    assert sim.agents["rov"].sonars[0].sonar.config == SonarConfig()  # the same defaults
    values = _moved(SonarConfig, _section_names(SonarSensor), SONAR_KEEP)
    settings = {f.name for f, _ in declared(SonarConfig)} & _section_names(SonarSensor)
    assert set(values) == settings and len(settings) > 30  # every one the scenario has
    sim = _build(tmp_path, {"sensors": [{"type": "sonar", "name": "s", **values}]})
    built = sim.agents["rov"].sonars[0].sonar.config
    assert built == SonarConfig(**values)
    for name, value in values.items():
        assert getattr(built, name) == pytest.approx(value), name


def test_water_reaches_the_sonar_and_sound_speed_is_not_a_setting(tmp_path: Path) -> None:
    data = {"name": "w", "world": {"water": {"temperature_c": 5.0, "salinity_psu": 30.0,
                                             "ph": 7.5}},
            "agents": [{"name": "rov", "model": "videoray", "driver": "none",
                        "start": {"depth": 2.0}, "sensors": [{"type": "sonar"}]}]}
    path = tmp_path / "w.yaml"
    path.write_text(yaml.safe_dump(data))
    built = Simulation(load_scenario(path)).agents["rov"].sonars[0].sonar.config
    assert built == SonarConfig(water_temperature_c=5.0, salinity_psu=30.0, ph=7.5)
    assert built.sound_speed_m_s == pytest.approx(1412 + 3.21 * 5 + 1.19 * 30 + 0.0167 * 5)
    data["world"]["water"]["sound_speed"] = 1500.0  # follows from the water: not settable
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"world\.water\.sound_speed: unknown key"):
        load_scenario(path)


def test_camera_from_yaml_is_the_camera_config_of_the_same_values(tmp_path: Path) -> None:
    sim = _build(tmp_path, {"sensors": [{"type": "camera"}]})
    assert sim.agents["rov"].cameras[0].camera.config == CameraConfig()
    keep = {"width": 64, "height": 48, "hfov_deg": 70.0, "tilt_deg": 5.0, "rate_hz": 5.0,
            "mount_position_frd": (0.1, 0.0, 0.02)}
    values = _moved(CameraConfig, _section_names(CameraSensor), keep)
    values |= {"sampling": "full", "lamps_on": False, "exposure": 3.0, "noise": False}
    sim = _build(tmp_path, {"sensors": [{"type": "camera", "water": {"jerlov": "1C"},
                                         **values}]})
    assert sim.agents["rov"].cameras[0].camera.config == CameraConfig(
        **values, water=jerlov("1C"))


def test_videoray_model_and_gains_from_yaml_are_the_parts_of_the_same_values(tmp_path):
    sim = _build(tmp_path, {})
    rov = sim.agents["rov"]
    assert rov.plant.params == VideoRayParams()
    assert rov.controller.gains == GAIN_PRESETS["mission"]
    model = {"J": 0.02, "moment_arm": 0.2, "thrust_map": "quadratic", "coupling": "rigid-body"}
    gains = _moved(PGains, _section_names(ControllerConfig), {}) | {"speed_feedforward": False}
    sim = _build(tmp_path, {"videoray": model, "controller": {"preset": "octave", **gains}})
    rov = sim.agents["rov"]
    assert rov.plant.params == VideoRayParams(**model)
    assert rov.controller.gains == dataclasses.replace(GAIN_PRESETS["octave"], **gains)
    assert rov.controller.gains == PGains(**gains)  # every gain given


@pytest.mark.parametrize(("part", "section"), [(SonarConfig, SonarSensor),
                                               (CameraConfig, CameraSensor)])
def test_a_section_has_its_parts_names_defaults_and_bounds(part, section) -> None:
    for field, quantity in declared(part):
        if field.name not in section.model_fields:
            continue
        info = section.model_fields[field.name]
        assert info.default == field.default, field.name
        assert quantity in info.metadata, field.name  # the very declaration


def test_old_sensor_keys_still_load_with_a_warning(tmp_path: Path) -> None:
    old = {"type": "sonar", "min_range": 0.5, "max_range": 10, "fan_width_px": 256,
           "mount": {"position": [0.2, 0, 0], "tilt_deg": 5},
           "image": {"gain_db": 6, "post_tvg_noise_db": None}}
    with pytest.warns(UserWarning, match="'max_range' of a SonarSensor is now 'range_max_m'"):
        sim = _build(tmp_path, {"sensors": [old]})
    assert sim.agents["rov"].sonars[0].sonar.config == SonarConfig(
        range_min_m=0.5, range_max_m=10.0, fan_size_px=256, mount_position_frd=(0.2, 0, 0),
        tilt_deg=5.0, gain_db=6.0, post_tvg_noise_db=None)
    with pytest.raises(ConfigError, match="give 'range_max_m' only"):
        _build(tmp_path, {"sensors": [{"type": "sonar", "max_range": 10, "range_max_m": 9}]})


def test_a_bad_value_fails_at_load_with_the_declared_range(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"sensors\[0\]\.rays_per_beam: must be in "
                                          r"\[2, 4096\], got 5000"):
        _build(tmp_path, {"sensors": [{"type": "sonar", "rays_per_beam": 5000}]})
    with pytest.raises(ConfigError, match=r"controller\.heading: must be in \[0, 10000\]"):
        _build(tmp_path, {"controller": {"heading": -1.0}})
