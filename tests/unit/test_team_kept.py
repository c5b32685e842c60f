"""What the team stage keeps between its ticks is what it would work out afresh: a
resting load that stays, a carried object following the very grip frame, a hand's frame
in NED, a grasp point, an assembly's in-water weight, a standing diver's legs (same
bits; the arrays kept are the very same objects, which is what lets the stage skip
comparing them)."""

import math

import numpy as np

from uhrisim.dynamics import diver_boots as bt
from uhrisim.dynamics import free_body as fb
from uhrisim.dynamics.diver_body import DiverSkeleton
from uhrisim.dynamics.plants import BootsPlant
from uhrisim.teamwork.workspace import Workspace, pose_matrix
from uhrisim.world import seafloor
from uhrisim.world import worksites as sites
from uhrisim.world.tools import make_tool

FLOOR_DEPTH = 12.0
FLOOR = seafloor.flat(FLOOR_DEPTH, 40.0).depth_at
DT = 0.05


def rigged(litres):
    """A 40 kg valve resting on the floor, a lift bag rigged to it with ``litres`` of
    gas (surface litres)."""
    ws = Workspace.of(tools=[make_tool("lift_bag", "bag1"), make_tool("wrench", "wrench1")],
                      loads=[sites.steel_load("valve1", 40.0)], bags=[sites.LiftBagSpec("bag1")])
    ws.put("valve1", (5.0, 0.0, FLOOR_DEPTH - 0.2))
    ws.put("bag1", (5.0, 0.0, FLOOR_DEPTH - 0.5))
    ws.put("wrench1", (1.0, 0.0, FLOOR_DEPTH - 2.0), where="water")
    ws.things["bag1"].where = "rigged:valve1"
    ws.bag_states["bag1"] = sites.LiftBagState("valve1", gas_surface_litres=litres)
    return ws


def test_a_resting_load_that_stays_keeps_its_arrays_and_the_steps_numbers():
    ws = rigged(10.0)  # far from the ~74 surface litres that lift it
    valve = ws.things["valve1"]
    pose, velocity = valve.pose, valve.velocity
    hydro = fb.combine(ws.loads["valve1"].hydro, ws.bags["bag1"].fabric,
                       drag_coefficient=1.0, area=1.0,
                       bottom_offset=ws.loads["valve1"].hydro.bottom_offset)
    gas = ws.bags["bag1"].gas_m3(ws.bag_states["bag1"], float(pose[2, 3]))
    x = np.concatenate([pose[:3, 3], velocity])
    stepped, where = fb.step(x, hydro, DT, FLOOR_DEPTH, gas)  # what a step gives
    assert ws.step(0.0, DT, FLOOR) == []
    assert valve.pose is pose and valve.velocity is velocity and valve.where == where
    assert np.concatenate([valve.pose[:3, 3], valve.velocity]).tobytes() == stepped.tobytes()
    lifting = rigged(120.0)  # more than enough: it lifts off, a new pose
    before = lifting.things["valve1"].pose
    assert [e.kind for e in lifting.step(0.0, DT, FLOOR)] == ["lifted_off"]
    assert lifting.things["valve1"].pose is not before
    assert lifting.things["valve1"].pose[2, 3] < before[2, 3]


def test_the_assemblys_weight_is_combines_to_the_bit():
    rng = np.random.default_rng(7)
    for _ in range(200):
        parts = [fb.Hydro(float(rng.uniform(0.1, 80.0)), float(rng.uniform(1e-4, 0.05)),
                          1.0, 0.1) for _ in range(int(rng.integers(1, 4)))]
        gas = float(rng.uniform(0.0, 0.1))
        combined = fb.combine(*parts, drag_coefficient=1.2, area=0.3)
        assert fb.combined_weight(*parts, gas_volume=gas) == combined.in_water_weight(gas)


def test_a_carried_object_follows_the_very_grip_frame_kept_and_a_new_one_afresh():
    ws = rigged(0.0)
    grip = pose_matrix((1.0, 0.0, FLOOR_DEPTH - 2.0), 0.3)
    ws.take("diver1/right_hand", "wrench1", grip)
    ws.carry("diver1/right_hand", grip)
    pose = ws.things["wrench1"].pose
    ws.carry("diver1/right_hand", grip)
    assert ws.things["wrench1"].pose is pose  # the same frame: kept
    moved = pose_matrix((1.2, 0.1, FLOOR_DEPTH - 2.0), 0.4)
    ws.carry("diver1/right_hand", moved)
    relative = ws.things["wrench1"].relative
    assert ws.things["wrench1"].pose.tobytes() == (moved @ relative).tobytes()
    ws.carry("diver1/right_hand", grip.copy())  # equal numbers, another array: afresh
    assert ws.things["wrench1"].pose.tobytes() == (grip @ relative).tobytes()


def test_a_grasp_point_follows_its_objects_pose():
    ws = rigged(0.0)
    first = ws.grasp_point("wrench1")
    assert first.tobytes() == ws.grasp_point("wrench1").tobytes()
    ws.put("wrench1", (2.0, 1.0, FLOOR_DEPTH - 1.0), 0.5)
    pose = ws.things["wrench1"].pose
    fresh = pose[:3, :3] @ ws.tools["wrench1"].grasp_offset() + pose[:3, 3]
    assert ws.grasp_point("wrench1").tobytes() == fresh.tobytes()


def test_a_hands_frame_in_ned_is_the_body_pose_times_its_frame_and_kept():
    skeleton = DiverSkeleton()
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = rng.uniform(skeleton.lower, skeleton.upper)
        body = pose_matrix(rng.uniform(-5.0, 5.0, 3), float(rng.uniform(-math.pi, math.pi)))
        for side in ("left", "right"):
            frame = skeleton.hand_frame_ned(q, side, body)
            assert frame.tobytes() == (body @ skeleton.hand_frame(q, side)).tobytes()
            assert skeleton.hand_frame_ned(q.copy(), side, body.copy()) is frame


def test_a_standing_divers_legs_kept_while_his_arms_move_are_those_worked_out_afresh():
    params = bt.BootsParams()
    skeleton = params.skeleton
    plant = BootsPlant(params, 1.0 / 60.0, FLOOR)
    rng = np.random.default_rng(5)
    x = plant.initial_state(np.array([1.0, 2.0, 0.0]), 0.4)
    for k in range(60):
        if k % 10 == 0:  # now and then the diver has moved
            x = plant.initial_state(np.array([*rng.uniform(-3.0, 3.0, 2), 0.0]),
                                    float(rng.uniform(-3.0, 3.0)))
        q = rng.uniform(skeleton.lower - 0.1, skeleton.upper + 0.1)  # arms anywhere
        if k % 3:
            q[skeleton.index("posture")] = 0.0  # the same tilt: the legs are kept
        fresh = bt.leg_angles(plant.boots_state(x), params, FLOOR, q)
        assert plant.leg_angles(x, q).tobytes() == fresh.tobytes()
