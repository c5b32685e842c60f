"""The teamwork stage's bodies in the simulation's scene follow the workspace's state:
the lift bag swells in the scene the ray casters see (docs/teamwork.md)."""

from __future__ import annotations

import numpy as np

from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Simulation
from uhrisim.world import worksites as ws_


def test_the_rigged_bag_swells_in_the_scene_with_its_gas():
    sim = Simulation(load_scenario(shipped_scenario("salvage_team_boots.yaml")),
                     raycast_sensors=False)
    team = sim.team
    ws = team.workspace
    eye = ws.grasp_point("valve1")
    ws.things["bag1"].where = "rigged:valve1"
    caster = sim.scene.raycaster("embree")
    # a level ray from the west, 0.3 m (rigging) + 0.35 m over the lifting eye
    origin = eye + np.array([0.0, -3.0, -0.65])

    def seen(litres: float) -> str | None:
        ws.bag_states["bag1"] = ws_.LiftBagState("valve1", gas_surface_litres=litres)
        ws.step(0.0, 0.0, sim.scene.depth_at)  # the rigged bag goes to the lifting eye
        team.pose_scene()
        hits = caster.cast(origin, np.array([[0.0, 1.0, 0.0]]), 5.0, frozenset(sim.agents))
        return sim.scene.labels[hits.label[0]] if hits.label[0] >= 0 else None

    assert seen(0.0) is None  # folded on the eye: the ray passes over it
    assert seen(220.0) == "lift_bag"  # 100 L at 12 m: a 0.36 m wide, 1.15 m tall bag
