"""The vehicle-model registry (uhrisim.vehicles): every model builds its parts from a
scenario agent, answers for the facts the loop needs, and no other module compares model
names."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from uhrisim.dynamics.videoray import INPUT_LIMIT
from uhrisim.scenario.schema import AgentConfig
from uhrisim.vehicles import MODELS, vehicle_model

SRC = Path(__file__).resolve().parents[2] / "src" / "uhrisim"


@pytest.mark.parametrize("name", sorted(MODELS))
def test_each_model_builds_a_plant_and_controller_that_step(name: str) -> None:
    model = vehicle_model(name)
    cfg = AgentConfig(name="a", model=name, driver="none")
    plant = model.make_plant(cfg, 1.0 / 60.0, "a", lambda north, east: 10.0)  # a flat floor
    x = plant.initial_state(np.array([0.0, 0.0, 2.0]), 0.0)
    u = model.make_controller(cfg, plant).inputs(x, 90.0, 0.5, 3.0)
    assert u.shape == (plant.input_size,) and np.all(np.isfinite(u))
    x1 = plant.step(0.0, x, u)
    assert np.all(np.isfinite(x1)) and plant.nav(x1, u).position_ned.shape == (3,)
    assert model.collision_radius > 0 and model.length > 0
    assert model.max_speed(plant.params) > 0


def test_model_facts_with_their_numbers() -> None:
    videoray = vehicle_model("videoray")
    cfg = AgentConfig(name="a", model="videoray", driver="none")
    params = videoray.make_plant(cfg, 1 / 60, "a").params
    # both horizontal thrusters at +150 (4 N each, linear map) against the Wang 2006 drag:
    # 8 = 0.95 u + 6.04 u^2 -> u = 1.075 m/s
    assert videoray.max_speed(params) == pytest.approx(
        (-0.95 + math.sqrt(0.95**2 + 4 * 6.04 * 8.0)) / (2 * 6.04), rel=1e-9)
    assert params.input_limit == INPUT_LIMIT == 150.0
    assert videoray.thrusters and not vehicle_model("diver").thrusters
    assert vehicle_model("kinematic").max_speed(
        vehicle_model("kinematic").make_plant(cfg, 1 / 60, "a").params) == 5.0  # 100 % / 20
    with pytest.raises(KeyError, match="known: videoray, diver, kinematic"):
        vehicle_model("submarine")


def test_no_module_but_the_registry_compares_model_names() -> None:
    pattern = re.compile(r"\bmodel\s*(==|!=|in)\s*[\"'(\[]|[\"'](videoray|diver|kinematic)"
                         r"[\"']\s*(==|!=)\s*\w*model")
    found = [f"{path.relative_to(SRC)}:{n}" for path in SRC.rglob("*.py")
             if path.name != "vehicles.py"
             for n, line in enumerate(path.read_text().splitlines(), 1)
             if pattern.search(line)]
    assert not found, f"model names compared outside uhrisim/vehicles.py: {found}"
