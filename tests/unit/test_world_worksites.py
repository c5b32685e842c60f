"""Tools and work sites: numbers, state machines with their events, geometry that follows."""

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.dynamics.free_body import GRAVITY, WATER_DENSITY
from uhrisim.world import Scene, materials
from uhrisim.world import worksites as ws
from uhrisim.world.tools import CATALOGUE, TOOL_KINDS, Tool, make_tool


@pytest.mark.parametrize("kind,mass,weight_n", [
    ("wrench", 1.30, 11.08), ("hammer", 1.40, 8.23), ("light", 0.60, 0.86),
    ("lift_bag", 2.00, 4.15), ("tool_basket", 8.00, 68.2)])
def test_catalogue_in_water_weights(kind, mass, weight_n):
    tool = make_tool(kind, f"{kind}1")
    assert tool.name == f"{kind}1" and tool.label == kind
    assert tool.hydro.mass == mass
    # W = (m - rho V) g with the volume from the material's density
    assert tool.in_water_weight == pytest.approx(
        (mass - WATER_DENSITY * tool.hydro.volume) * GRAVITY)
    assert tool.in_water_weight == pytest.approx(weight_n, abs=0.01)


@pytest.mark.parametrize("kind", TOOL_KINDS)
def test_tool_meshes_fit_their_size_and_hold_their_grasp_point(kind):
    tool = CATALOGUE[kind]
    bounds = tool.mesh().bounds
    np.testing.assert_allclose(bounds[1] - bounds[0], tool.size, atol=1e-9)
    assert np.all(np.abs(tool.grasp_offset()) <= 0.5 * np.array(tool.size))


def test_tool_errors_name_the_problem():
    with pytest.raises(ConfigError, match=r"unknown tool kind 'spanner' .*have wrench"):
        make_tool("spanner", "s1")
    with pytest.raises(ConfigError, match=r"Tool\('w'\).grasp_point: must lie inside"):
        Tool("w", "wrench", CATALOGUE["wrench"].hydro, (0.1, 0.1, 0.1), (0.2, 0, 0),
             (0, 0, 0), 0.01)


FLANGE = ws.FlangeSpec("flange1", (10.0, 5.0, 11.0), yaw=math.pi / 2)


def test_flange_bolts_sit_on_the_bolt_circle_and_turn_with_the_site():
    for bolt in range(4):
        p = FLANGE.bolt_position(bolt) - np.array(FLANGE.position_ned)
        # the face looks east (yaw 90 deg): bolts lie in the north-down plane, 2 cm proud
        assert p[1] == pytest.approx(FLANGE.cover_thickness + 0.02)
        assert math.hypot(p[0], p[2]) == pytest.approx(0.5 * 0.1905)
    assert FLANGE.bolt_position(0)[2] < FLANGE.position_ned[2]  # bolt 0 at the top


def test_flange_state_machine_with_its_events_and_reasons():
    state = FLANGE.initial_state()
    state, events = FLANGE.work(state, 0, 19.0, t=19.0, actor="diver1/right_hand")
    assert events == [] and FLANGE.bolt_status(state, 0) == "tight"
    state, events = FLANGE.remove_bolt(state, 0, t=19.0)
    assert not events[0].ok and events[0].reason == (
        "bolt 0 is still tight (19.0 of 20.0 s of wrench work)")
    state, events = FLANGE.work(state, 0, 1.0, t=20.0, actor="diver1/right_hand")
    assert [e.kind for e in events] == ["bolt_loosened"] and events[0].detail["bolt"] == 0
    state, events = FLANGE.work(state, 0, 1.0, t=21.0)
    assert events == []  # loosened once, not every tick
    state, events = FLANGE.remove_bolt(state, 0, t=22.0)
    assert [e.kind for e in events] == ["bolt_removed"]
    state, events = FLANGE.remove_cover(state, t=23.0)
    assert events[0].reason == "3 bolt(s) still in: 1, 2, 3" and state.cover_on
    state, events = FLANGE.work(state, 0, 1.0, t=23.0)
    assert events[0].reason == "bolt 0 is already out"
    assert FLANGE.work(state, 7, 1.0, t=23.0)[1][0].reason == "no bolt 7 (bolts 0 to 3)"
    for bolt in (1, 2, 3):
        state, _ = FLANGE.work(state, bolt, 20.0, t=30.0)
        state, _ = FLANGE.remove_bolt(state, bolt, t=30.0)
    state, events = FLANGE.remove_cover(state, t=31.0)
    assert [e.kind for e in events] == ["cover_removed"] and not state.cover_on


def test_flange_geometry_follows_its_state():
    parts = FLANGE.parts()
    state = FLANGE.initial_state()
    full = ws.posed_mesh(parts, FLANGE.part_transforms(state))
    state, _ = FLANGE.work(state, 2, 20.0, t=0.0)
    loose = FLANGE.part_transforms(state)
    assert loose[3 + 2][0, 3] == pytest.approx(0.02)  # backed out along the face normal
    state, _ = FLANGE.remove_bolt(state, 2, t=0.0)
    gone = ws.posed_mesh(parts, FLANGE.part_transforms(state))
    bolt_faces = len(parts.parts[3 + 2].mesh.faces)
    assert len(gone.faces) == len(full.faces) - bolt_faces
    # in a scene, the removed bolt is no longer hit where it was
    scene = Scene()
    scene.add_dynamic("flange1", parts, "flange", materials.STEEL,
                      position_ned=FLANGE.position_ned, rotation=FLANGE.pose()[:3, :3])
    casters = [scene.raycaster(backend) for backend in ("reference", "embree")]
    nut = FLANGE.bolt_position(2)
    origin = nut + np.array([0.0, 0.3, 0.0])  # in front of the face (it looks east)

    def labels_seen():
        return {scene.labels[caster.cast(origin, np.array([[0.0, -1.0, 0.0]]),
                                         max_range=1.0).label[0]] for caster in casters}

    assert labels_seen() == {"flange/bolt"}
    scene.set_part_transforms("flange1", FLANGE.part_transforms(state))
    assert labels_seen() == {"flange/cover"}  # the cover behind the bolt's place


HATCH = ws.HatchSpec("hatch1", (0.0, 0.0, 10.0))


def test_hatch_latch_open_and_close_with_events():
    state = HATCH.initial_state()
    state, events = HATCH.command(state, True, t=0.0, actor="diver1/right_hand")
    assert events[0].kind == "open_failed" and "latch is still fast" in events[0].reason
    state, events = HATCH.work(state, 10.0, t=10.0)
    assert [e.kind for e in events] == ["latch_freed"] and HATCH.status(state) == "closed"
    state, events = HATCH.command(state, True, t=10.0)
    assert [e.kind for e in events] == ["hatch_opening"]
    kinds = []
    for k in range(150):
        state, events = HATCH.advance(state, 1 / 60, t=10.0 + k / 60)
        kinds += [e.kind for e in events]
    assert kinds == ["hatch_opened"] and HATCH.status(state) == "open"
    assert state.angle == pytest.approx(math.radians(110))
    # the handle went up: 0.6 sin(110 deg) above the hinge
    handle = HATCH.handle_position(state)
    assert handle[2] == pytest.approx(10.0 - 0.6 * math.sin(math.radians(110)))
    lid = ws.posed_mesh(HATCH.parts(), HATCH.part_transforms(state))  # site frame
    assert lid.bounds[0][2] == pytest.approx(-0.6 * math.sin(math.radians(110)), abs=0.03)


BAG = ws.LiftBagSpec("bag1")


def test_lift_bag_inflates_at_its_rate_and_is_full_at_its_capacity_at_depth():
    depth = 12.0
    state, events = BAG.attach(BAG.initial_state(), "load1", t=0.0)
    assert events[0].kind == "bag_attached"
    assert BAG.attach(state, "load2", t=0.0)[1][0].reason == "already attached to load1"
    state, events = BAG.set_inflating(state, True, t=0.0)
    assert [e.kind for e in events] == ["bag_inflating"]
    state, _ = BAG.advance(state, 10.0, t=10.0, depth=depth)
    assert state.gas_surface_litres == pytest.approx(15.0)
    ratio = 1.0 + WATER_DENSITY * GRAVITY * depth / 101325.0  # 2.19 atmospheres
    assert BAG.gas_m3(state, depth) == pytest.approx(15e-3 / ratio)
    full_after = 100.0 * ratio / 1.5
    kinds = []
    for k in range(round(full_after) + 5):
        state, events = BAG.advance(state, 1.0, t=11.0 + k, depth=depth)
        kinds += [e.kind for e in events]
    assert kinds == ["bag_full"]
    assert BAG.gas_m3(state, depth) == pytest.approx(0.100)
    assert BAG.lift_n(state, depth) == pytest.approx(WATER_DENSITY * GRAVITY * 0.1)


def test_lift_bag_geometry_swells_with_its_gas():
    parts = BAG.parts()
    heights = []
    for litres in (0.0, 8.0, 30.0, 100.0):
        state = ws.LiftBagState("load1", gas_surface_litres=litres)
        mesh = ws.posed_mesh(parts, BAG.part_transforms(state, depth=0.0))
        heights.append(mesh.bounds[1][2] - mesh.bounds[0][2])
    assert heights == sorted(heights) and heights[0] == pytest.approx(0.10)
    # the full bag: a prolate ellipsoid of 100 L, 1.6 times as tall as wide
    a = (3 * 0.1 / (4 * math.pi * 1.6)) ** (1 / 3)
    assert heights[-1] == pytest.approx(2 * 1.6 * a, rel=0.02)


def test_both_ray_casters_see_the_bag_swell():
    # a level ray 0.3 m (the rigging) + 0.2 m over the lifting eye: it passes over the
    # folded bag and meets the swollen one
    scene = Scene()
    scene.add_dynamic("bag1", BAG.parts(), "lift_bag", materials.STEEL, (0.0, 0.0, 10.0))
    casters = [scene.raycaster(backend) for backend in ("reference", "embree")]

    def distances(litres: float) -> list[float]:
        state = ws.LiftBagState("load1", gas_surface_litres=litres)
        scene.set_part_transforms("bag1", BAG.part_transforms(state, depth=10.0))
        return [float(c.cast(np.array([-3.0, 0.0, 9.5]), np.array([[1.0, 0.0, 0.0]]),
                             10.0).distance[0]) for c in casters]

    assert distances(0.0) == [math.inf, math.inf]
    a, _ = ws.bag_semi_axes(0.1)  # full at 10 m: 200 surface litres fill the 100 L bag
    near = distances(200.0)
    assert near[0] == pytest.approx(near[1], abs=1e-6) and 3.0 - near[0] < a
    assert 3.0 - near[0] > 0.8 * a


def test_steel_load_weight():
    load = ws.steel_load("valve", 60.0)
    expected = 60.0 * (1 - WATER_DENSITY / 7850) * GRAVITY  # 511 N
    assert load.hydro.in_water_weight() == pytest.approx(expected)
