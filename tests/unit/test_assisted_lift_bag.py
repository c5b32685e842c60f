"""The assisted salvage's lift bag (docs/hri.md, "What the VideoRay can carry"): the
VideoRay can hold it at depth (paper eqs 1-4 with the load, dynamics/carried_load.py)
and, full, it lifts the valve. Only the scenario is loaded: no simulation runs."""

from __future__ import annotations

import pytest

from uhrisim.dynamics import videoray
from uhrisim.dynamics.carried_load import CarriedLoad, hover_command, max_hover_weight
from uhrisim.dynamics.free_body import GRAVITY, WATER_DENSITY
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.world.tools import make_tool
from uhrisim.world.worksites import steel_load

JAWS_FRD = (0.25, 0.0, 0.14)  # where the gripper holds it (AssistantConfig.jaw_frd)


@pytest.fixture(scope="module")
def world():
    return load_scenario(shipped_scenario("salvage_team_assisted")).scenario.world


def test_a_lighter_tool_keeps_its_material(world):
    bag = next(t for t in world.tools if t.kind == "lift_bag")
    tool = make_tool(bag.kind, bag.name, bag.mass_kg)
    catalogue = make_tool("lift_bag", "reference")
    assert tool.hydro.mass == pytest.approx(1.5)
    assert tool.hydro.mass / tool.hydro.volume == pytest.approx(
        catalogue.hydro.mass / catalogue.hydro.volume)  # PVC-coated fabric, 1300 kg/m³
    # W = m g (1 - rho_water / rho_fabric) = 1.5 * 9.81 * (1 - 1025/1300) = 3.11 N
    assert tool.in_water_weight == pytest.approx(1.5 * GRAVITY * (1 - 1025 / 1300), rel=1e-6)
    assert tool.in_water_weight == pytest.approx(3.11, abs=0.01)


def test_the_videoray_holds_the_bag_and_the_bag_lifts_the_valve(world):
    bag = next(t for t in world.tools if t.kind == "lift_bag")
    tool = make_tool(bag.kind, bag.name, bag.mass_kg)
    params = videoray.VideoRayParams()
    hover = hover_command(params, CarriedLoad(tool.hydro, JAWS_FRD))
    assert not hover.saturated and hover.steady_heave == 0.0
    margin = max_hover_weight(params) - tool.in_water_weight
    assert margin == pytest.approx(0.89, abs=0.01)  # of 4.0 N: 22 %
    # the catalogue's folded 100 L bag (4.15 N) is beyond the thruster
    assert hover_command(params, CarriedLoad(make_tool("lift_bag", "big").hydro,
                                             JAWS_FRD)).saturated
    valve = next(s for s in world.sites if s.type == "load")
    load = steel_load(valve.name, valve.mass_kg, valve.size)
    lift = WATER_DENSITY * GRAVITY * bag.capacity_litres * 1e-3  # 503 N full
    assert lift > load.hydro.in_water_weight() + tool.in_water_weight
    assert load.hydro.in_water_weight() == pytest.approx(341.2, abs=0.5)


def test_a_tool_mass_must_be_positive():
    with pytest.raises(Exception, match="mass_kg: must be a finite mass > 0 kg"):
        make_tool("lift_bag", "bag1", -1.0)
