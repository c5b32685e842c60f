"""Tools, sites and loads are obstacles to the agents' collision spheres, but for what an
agent works with (docs/teamwork.md, "Collisions with tools, sites and loads"): what its
hands or gripper hold, what its current order names, what those rest on. The loop's
bounding-sphere pre-check (uhrisim/sim/team_obstacles.py) is held to the full ray-cast
check on random placements."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.overlap import sphere_overlaps
from uhrisim.sim.simulation import Simulation
from uhrisim.teamwork import orders as od
from uhrisim.world.bodies import HIDDEN_BEYOND_M

#: a VideoRay driven at 0.4 m/s through a tool basket on a stand, a load beside its path
PASSING = {
    "name": "rov_meets_a_basket", "seed": 1, "duration": 6, "physics_rate_hz": 60,
    "world": {
        "seafloor": {"type": "flat", "depth": 12, "extent": 20},
        "sites": [
            {"type": "platform", "name": "stand0", "at": {"north": 3.0, "east": 0.0,
                                                          "depth": 11.2}, "size": [0.7, 0.5]},
            {"type": "load", "name": "valve1", "at": {"north": 0.0, "east": 3.0},
             "mass_kg": 60, "size": [0.6, 0.5, 0.8]}],
        "tools": [{"kind": "tool_basket", "name": "basket1", "at": {"north": 3.0, "east": 0.0},
                   "onto": "stand0"}]},
    "agents": [{"name": "rov1", "model": "videoray", "control_rate_hz": 20,
                "start": {"north": 1.5, "east": 0.0, "depth": 11.0, "heading_deg": 0},
                "driver": "script",
                "script": [{"t": 0, "goto": {"north": 6.0, "east": 0.0, "depth": 11.0},
                            "speed": 0.4}]}],
}


@pytest.fixture()
def passing(tmp_path):
    path = tmp_path / "passing.yaml"
    path.write_text(yaml.safe_dump(PASSING, sort_keys=False))
    with Simulation(load_scenario(path), raycast_sensors=False) as sim:
        yield sim


@pytest.fixture(scope="module")
def salvage():
    with Simulation(load_scenario(shipped_scenario("salvage_team.yaml")),
                    raycast_sensors=False) as sim:
        yield sim


def test_a_basket_in_the_rovs_way_is_one_collision_logged_with_its_name(passing):
    passing.run(6.0)
    hits = [e.detail for e in passing.events_log if e.kind == "collision"]
    assert passing.collisions == 1 and len(hits) == 1  # stopped against it: one contact
    assert hits[0].startswith("rov1 touched basket1 at NED [")
    where = np.array([float(v) for v in hits[0].split("[")[1].rstrip("]").split(",")])
    # the contact point lies on the basket (0.6 x 0.4 x 0.3 m on the stand's top at 11.2 m)
    assert abs(where[0] - 2.7) < 0.02 and abs(where[1]) < 0.2 and 10.9 <= where[2] <= 11.2
    # the VideoRay stopped with its 0.25 m sphere at the basket's south face
    assert passing.agents["rov1"].state[0] == pytest.approx(2.7 - 0.25, abs=0.02)


def test_a_load_that_moves_onto_an_agent_is_one_collision_and_shoves_it_out(passing):
    rov = passing.agents["rov1"]
    passing.run(1.0)
    ws = passing.team.workspace
    inside = rov.state[:3] + np.array([0.0, 0.2, 0.3])  # the load's top reaches its centre
    ws.put("valve1", inside, where="floor")
    for _ in range(2 * passing.team.period):
        passing.step()
    hits = [e.detail for e in passing.events_log if e.kind == "collision"]
    assert len(hits) == 1 and hits[0].startswith("rov1 touched valve1, which moved onto it")
    body = passing.scene.bodies[passing.scene.body_names.index("valve1")].mesh_world()
    assert sphere_overlaps(body, inside, rov.radius)
    assert not sphere_overlaps(body, rov.state[:3], rov.radius)  # pushed out of the load


def test_a_sinking_tools_sphere_and_scene_body_follow_it(passing):
    ws, team = passing.team.workspace, passing.team
    ws.put("basket1", (0.0, -3.0, 8.0), where="water")  # free in the water, 4 m up
    for _ in range(team.period):
        passing.step()
    start = ws.things["basket1"].position.copy()
    offset = team.obstacles.sphere("basket1")[0] - start  # (the sphere's centre in it)
    passing.run(1.0)
    now = ws.things["basket1"].position
    assert ws.things["basket1"].where == "water" and now[2] > start[2] + 0.05  # it sinks
    assert np.allclose(team.obstacles.sphere("basket1")[0], now + offset, atol=1e-9)
    passing._sync_scene()
    assert np.allclose(passing.scene.pose("basket1")[0], now, atol=1e-9)


def test_what_an_agent_holds_and_works_at_is_left_out(salvage):
    team = salvage.team
    # the diver's first order picks the wrench from the basket on stand0; the VideoRay
    # holds the light
    assert team.left_out("diver1") == {"wrench1", "basket1", "stand0"}
    assert team.left_out("rov1") == {"light1"}
    assert od.worked_at(od.WaitUntil("valve1", "lifted"), "diver1") == ()
    assert od.worked_at(od.WaitUntil("bag1", "held_by:diver1/right_hand"), "diver1") == (
        "bag1",)
    assert od.worked_at(od.UseOn("bag1", "valve1", 1.0), "diver1") == ("bag1", "valve1")


def test_the_diver_reaches_into_the_basket_of_his_order_and_is_stopped_by_it_after():
    with Simulation(load_scenario(shipped_scenario("salvage_team.yaml")),
                    raycast_sensors=False) as sim:
        diver = sim.agents["diver1"]
        top = sim.team.workspace.things["basket1"].position
        start, end = [top[0], top[1] + 1.0, top[2]], [top[0], top[1] + 0.5, top[2]]
        assert sim._clear_fraction(diver, start, end) == (1.0, "")  # picking the wrench
        sim.run(6.5)  # the wrench in hand, on to the flange
        assert sim.team.left_out("diver1") == {"wrench1", "flange1"}
        free, what = sim._clear_fraction(diver, start, end)
        assert free < 1.0 and what.startswith("basket1 at NED")
        grip = sim.team.workspace.things["wrench1"].position  # the held wrench: no obstacle
        assert sim._clear_fraction(diver, (grip - [0.0, 0.1, 0.0]).tolist(),
                                   grip.tolist()) == (1.0, "")


def test_the_pre_check_agrees_with_the_full_check_on_random_placements(salvage):
    """The loop's check (bounding spheres, then the ray bundle for the bodies within
    reach) against the ray bundle cast at every team body: the same fraction and the same
    body first touched, for moves of both agents among randomly placed objects."""
    sim, team = salvage, salvage.team
    ws = team.workspace
    rng = np.random.default_rng(7)
    movable = [n for n in ws.things if ws.things[n].where != "held"]
    others = sim._not_obstacles - team.body_names
    compared = hits = pruned = 0
    for _ in range(8):
        for name in movable:  # anywhere in a 4 x 4 x 1.5 m box over the work
            position = rng.uniform((0.0, -1.5, 10.0), (4.0, 2.5, 11.5))
            ws.put(name, position, rng.uniform(-math.pi, math.pi), where="water")
        team.pose_scene()
        for _ in range(25):
            for agent in sim.agents.values():
                start = rng.uniform((0.0, -1.5, 10.0), (4.0, 2.5, 11.5))
                step = rng.normal(size=3)
                end = start + step / np.linalg.norm(step) * rng.uniform(0.005, 0.6)
                if any(math.dist(end, o.state[:3]) < agent.radius + o.radius
                       for o in sim.agents.values() if o is not agent):
                    continue  # the agents' own check comes first
                fast = sim._clear_fraction(agent, start.tolist(), end.tolist())
                free, what, _ = sim.scene.segment_contact(
                    start, end, agent.radius, exclude=others | team.left_out(agent.name))
                assert fast[0] == free
                assert fast[1].split(" at NED")[0] == (
                    "" if free == 1.0 else what if what in team.body_names else "the scene")
                compared += 1
                hits += free < 1.0
                pruned += not team.obstacles.touching(start, end, agent.radius)
    assert compared > 300 and hits > 30 and pruned > 60  # both outcomes well sampled


def test_a_sites_sphere_leaves_out_its_hidden_parts(salvage):
    team = salvage.team
    ws = team.workspace
    centre, radius = team.obstacles.sphere("flange1")
    assert radius < 1.0 and np.all(np.isfinite(centre))  # the parked parts are not in it
    _, parts = team._body_pose("bag1")
    shown = np.linalg.norm(parts[:, :3, 3], axis=1) < HIDDEN_BEYOND_M
    assert shown.sum() == 1  # the folded bag
    bag_centre, bag_radius = team.obstacles.sphere("bag1")
    assert bag_radius < 0.3 and math.dist(bag_centre, ws.things["bag1"].position) < 0.3
