"""The acts' rules, each in a tiny world of real models: a commercial diver, a second
diver, the ROV's gripper, tools, a basket, a flange, a hatch, a lift bag and a load."""

import math

import numpy as np
import pytest

from uhrisim.dynamics import diver_boots as bt
from uhrisim.dynamics.diver_body import solve_reach
from uhrisim.dynamics.free_body import GRAVITY, WATER_DENSITY
from uhrisim.teamwork import acts
from uhrisim.teamwork import gripper as gr
from uhrisim.teamwork.workspace import Platform, Workspace, pose_matrix
from uhrisim.world import seafloor
from uhrisim.world import worksites as ws_
from uhrisim.world.tools import make_tool

FLOOR_DEPTH = 12.0
FLOOR = seafloor.flat(FLOOR_DEPTH, 40.0).depth_at
BOOTS = bt.BootsParams()
SKELETON = BOOTS.skeleton
DT = 1.0 / 60.0


def standing(north=0.0, east=0.0, psi=0.0):
    """(body pose 4x4, q) of a diver standing on the floor, legs posed."""
    state = bt.BootsState((north, east, 0.0), psi)
    state = bt.BootsState((north, east, bt.standing_hip_depth(state, BOOTS, FLOOR)), psi)
    return pose_matrix(state.position, psi), bt.leg_angles(state, BOOTS, FLOOR,
                                                           SKELETON.zeros())


def crouching(north, east, psi=0.0):
    """(body pose 4x4, q) of a diver crouched on the floor (to work low)."""
    state = bt.BootsState((north, east, 0.0), psi, crouch=1.0)
    state = bt.BootsState((north, east, bt.standing_hip_depth(state, BOOTS, FLOOR)), psi,
                          crouch=1.0)
    return pose_matrix(state.position, psi), bt.leg_angles(state, BOOTS, FLOOR,
                                                           SKELETON.zeros())


def hand(diver="diver1", side="right", body=None, q=None, at=None, bend=False):
    """A hand; ``at`` (NED): the arm moved there first (it must be reachable)."""
    pose, legs = standing() if body is None else (body, q)
    q = legs if q is None else q
    if at is not None:
        r, p = pose[:3, :3], pose[:3, 3]
        solution = solve_reach(SKELETON, side, r.T @ (np.asarray(at) - p), q, bend=bend)
        assert solution.ok, solution.reason
        q = solution.q
    return acts.Hand(diver, side, SKELETON, q, pose)


def world():
    ws = Workspace.of(
        tools=[make_tool("wrench", "wrench1"), make_tool("hammer", "hammer1"),
               make_tool("tool_basket", "basket1"), make_tool("lift_bag", "bag1"),
               make_tool("light", "light1")],
        loads=[ws_.steel_load("valve1", 40.0)],
        flanges=[ws_.FlangeSpec("flange1", (0.55, 0.0, FLOOR_DEPTH - 1.0), yaw=math.pi)],
        hatches=[ws_.HatchSpec("hatch1", (-0.3, 0.45, FLOOR_DEPTH - 0.9), yaw=0.0)],
        bags=[ws_.LiftBagSpec("bag1")],
        platforms=[Platform("stand1", (0.45, 0.1, FLOOR_DEPTH - 1.1), (0.3, 0.8))])
    # a waist-high stand carries the wrench and the hammer; the light floats mid-water
    ws.put("wrench1", (0.45, 0.25, FLOOR_DEPTH - 1.1075), where="on:stand1")
    ws.put("hammer1", (0.45, -0.02, FLOOR_DEPTH - 1.125), where="on:stand1")
    ws.put("basket1", (3.0, 0.0, FLOOR_DEPTH - 0.15))
    ws.put("bag1", (3.0, 0.1, FLOOR_DEPTH - 0.25), where="in:basket1")
    ws.put("light1", (-2.0, 0.0, FLOOR_DEPTH - 3.0), where="water")
    ws.put("valve1", (5.0, 0.0, FLOOR_DEPTH - 0.2))
    return ws


def kinds(events):
    return [(e.kind, e.ok) for e in events]


# ------------------------------------------------------------------------ grasp


def test_grasp_in_reach_holds_it_and_the_object_moves_with_the_hand():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1"))
    events = acts.grasp(ws, h, "wrench1", t=1.0)
    assert kinds(events) == [("grasp", True)]
    assert ws.held_by(h.name) == "wrench1" and ws.things["wrench1"].where == "held"
    # the diver turns 90 degrees and raises the hand: the wrench's grasp point stays in it
    pose, _ = standing(0.0, 0.0, math.pi / 2)
    moved = hand(body=pose, q=h.q)
    ws.carry(moved.name, moved.grip_frame())
    np.testing.assert_allclose(ws.grasp_point("wrench1"), moved.grip_frame()[:3, 3],
                               atol=1e-12)


def test_grasp_out_of_reach_fails_with_the_reason():
    ws = world()
    h = hand()
    events = acts.grasp(ws, h, "valve1", t=1.0)  # 5 m away
    assert kinds(events) == [("grasp_failed", False)]
    assert events[0].reason.startswith("out of reach: ") and "right shoulder" in events[0].reason
    assert ws.held_by(h.name) is None and ws.things["valve1"].where == "floor"


def test_grasp_within_reach_but_not_at_the_grasp_point_fails_on_tolerance():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1") + np.array([0.0, 0.0, -0.12]))
    events = acts.grasp(ws, h, "wrench1", t=1.0)
    assert events[0].reason == "hand 0.12 m from it (tolerance 0.05 m)"


def test_grasp_needs_an_open_free_hand_and_an_existing_object():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1"))
    closed = acts.Hand(h.diver, h.side, SKELETON,
                       SKELETON.vector({"right_fingers": SKELETON.upper[
                           SKELETON.index("right_fingers")]}, h.q), h.body_pose)
    assert acts.grasp(ws, closed, "wrench1", 0.0)[0].reason == "the hand is closed"
    assert acts.grasp(ws, h, "spanner9", 0.0)[0].reason == "no object 'spanner9'"
    acts.grasp(ws, h, "wrench1", 0.0)
    assert acts.grasp(ws, h, "hammer1", 0.0)[0].reason == "already holds wrench1"


# ------------------------------------------------------------------------ release, place


def test_release_in_mid_water_is_a_drop_and_it_falls_to_the_floor():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, h, "wrench1", 0.0)
    # lift it and hold it out to the side, off the stand, then let go
    away = hand(body=h.body_pose, q=h.q, at=(0.35, 0.60, FLOOR_DEPTH - 1.1))
    ws.carry(away.name, away.grip_frame())
    events = acts.release(ws, away, 2.0, FLOOR)
    assert events[0].kind == "drop"
    fall = FLOOR_DEPTH - 0.0075 - ws.things["wrench1"].position[2]
    assert events[0].detail["fall_m"] == pytest.approx(fall, abs=1e-3)
    landed = []
    for k in range(round(4.0 / DT)):
        landed += [e for e in ws.step(2.0 + k * DT, DT, FLOOR) if e.subject == "wrench1"]
    assert [e.kind for e in landed] == ["landed"] and landed[0].detail["on"] == "floor"
    assert ws.things["wrench1"].position[2] == pytest.approx(FLOOR_DEPTH - 0.0075)
    assert ws.held_by(away.name) is None


def test_a_tool_dropped_over_the_basket_lands_in_it():
    ws = world()
    ws.put("light1", (3.05, -0.05, FLOOR_DEPTH - 1.2), where="water")
    landed = []
    for k in range(round(8.0 / DT)):
        landed += [e for e in ws.step(k * DT, DT, FLOOR) if e.subject == "light1"]
    assert [(e.kind, e.detail["on"]) for e in landed] == [("landed", "in:basket1")]
    # on the basket's inside bottom (1 cm plate), not on the floor
    assert ws.things["light1"].position[2] == pytest.approx(FLOOR_DEPTH - 0.01 - 0.03)


def test_place_on_the_stand_and_basket_contents_follow_the_basket():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, h, "wrench1", 0.0)
    # put it down further along the stand: its grasp point 7.5 mm + 3 cm above the top
    target = np.array([0.40, 0.40, FLOOR_DEPTH - 1.1 - 0.0075 - 0.03])
    there = hand(body=h.body_pose, q=h.q, at=target)
    ws.carry(there.name, there.grip_frame())
    events = acts.place(ws, there, target, 1.0, FLOOR)
    assert kinds(events) == [("place", True)] and events[0].detail["on"] == "on:stand1"
    assert ws.things["wrench1"].position[2] == pytest.approx(FLOOR_DEPTH - 1.1 - 0.0075)
    assert ws.held_by(there.name) is None
    # what lies in a basket goes where the basket goes
    assert ws.things["bag1"].where == "in:basket1"
    ws.things["basket1"].pose = pose_matrix((3.0, 2.0, FLOOR_DEPTH - 0.15))
    ws.step(1.0, DT, FLOOR)
    assert ws.things["bag1"].position[1] == pytest.approx(2.1, abs=1e-9)


def test_place_needs_a_support_within_5_cm():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, h, "wrench1", 0.0)
    target = np.array([0.35, 0.60, FLOOR_DEPTH - 1.1])  # beside the stand
    away = hand(body=h.body_pose, q=h.q, at=target)
    ws.carry(away.name, away.grip_frame())
    events = acts.place(ws, away, target, 1.0, FLOOR)
    assert not events[0].ok and events[0].reason == (
        "nothing to put it on within 0.05 m (floor 1.09 m below)")
    assert ws.held_by(h.name) == "wrench1"
    # and out of reach: the hand cannot put it there
    far = acts.place(ws, away, (2.0, 0.0, FLOOR_DEPTH - 0.5), 1.0, FLOOR)
    assert far[0].reason.startswith("out of reach")


# ------------------------------------------------------------------------ hand over


def test_handover_needs_both_hands_on_the_object_at_the_moment():
    ws = world()
    giver = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, giver, "wrench1", 0.0)
    # the second diver faces the first, 0.85 m north of it, hand on the wrench's grasp point
    pose, q = standing(0.85, 0.45, math.pi)
    receiver = hand("diver2", "right", pose, q, at=ws.grasp_point("wrench1"))
    events = acts.hand_over(ws, giver, receiver, "wrench1", 3.0, FLOOR)
    assert [e.kind for e in events] == ["grasp", "handover", "release"]
    assert events[1].detail["holders"] == "diver1/right_hand, diver2/right_hand"
    assert ws.holders_of("wrench1") == ("diver2/right_hand",)
    assert ws.things["wrench1"].where == "held"


def test_a_handover_the_receiver_cannot_take_leaves_it_with_the_giver():
    ws = world()
    giver = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, giver, "wrench1", 0.0)
    pose, q = standing(3.0, 0.0, math.pi)  # too far away to take it
    receiver = hand("diver2", "right", pose, q)
    events = acts.hand_over(ws, giver, receiver, "wrench1", 3.0, FLOOR)
    assert [e.kind for e in events] == ["grasp_failed", "handover_failed"]
    assert events[-1].reason.startswith("out of reach")
    assert ws.holders_of("wrench1") == ("diver1/right_hand",)
    # and the giver must hold it in the first place
    other = acts.hand_over(ws, receiver, giver, "wrench1", 3.0, FLOOR)
    assert other[0].reason == "diver2/right_hand does not hold wrench1"


def test_a_diver_hands_the_wrench_to_the_rovs_gripper():
    ws = world()
    giver = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, giver, "wrench1", 0.0)
    spec = gr.GripperSpec()
    jaw_at = ws.grasp_point("wrench1")
    rov_pose = pose_matrix(jaw_at - np.array(spec.position_frd) * [-1, -1, 1], math.pi)
    state = gr.GripperState()
    state, _ = gr.command(spec, state, True, 3.0, "rov/gripper")
    jaws = acts.Jaws("rov", spec, state, rov_pose)
    np.testing.assert_allclose(jaws.grip_frame()[:3, 3], jaw_at, atol=1e-12)
    assert acts.between_jaws(ws, jaws) is None  # held by the diver: not free
    # the jaws close on the 15 mm grip after (60 - 15) / 60 x 1.5 s = 1.125 s
    width, closed_at, t = ws.grip_width("wrench1"), None, 3.0
    while closed_at is None:
        t += DT
        state, events = gr.advance(spec, state, DT, t, "rov/gripper", grip_width=width)
        closed_at = t if events else None
    assert closed_at - 3.0 == pytest.approx(1.125, abs=DT)
    assert events[0].detail["on_width"] == width and state.gap(spec) == pytest.approx(width)
    jaws = acts.Jaws("rov", spec, state, rov_pose)
    events = acts.hand_over(ws, giver, jaws, "wrench1", t, FLOOR)
    assert [e.kind for e in events] == ["grasp", "handover", "release"]
    assert ws.holders_of("wrench1") == ("rov/gripper",)


# ------------------------------------------------------------------------ the gripper


def test_the_gripper_state_machine_and_what_it_can_hold():
    spec = gr.GripperSpec()
    assert spec.holding_force_n == pytest.approx(2 * 0.4 * 30.0)
    state = gr.GripperState()
    state, events = gr.command(spec, state, True, 0.0, "rov/gripper")
    assert state.phase == "closing" and events[0].kind == "gripper_closing"
    assert gr.command(spec, state, True, 0.1, "rov/gripper")[1] == []  # already closing
    for k in range(100):
        state, events = gr.advance(spec, state, DT, k * DT, "rov/gripper")
        if events:
            break
    assert state.phase == "closed" and events[0].reason == "empty"
    assert (k + 1) * DT == pytest.approx(1.5, abs=DT)
    state, _ = gr.command(spec, state, False, 2.0, "rov/gripper")
    for k in range(100):
        state, events = gr.advance(spec, state, DT, 2.0 + k * DT, "rov/gripper")
        if events:
            break
    assert state.phase == "open" and events[0].kind == "gripper_opened"
    # the tool basket (68 N in water) is too heavy for the jaws (24 N)
    ws = world()
    rov_pose = pose_matrix(ws.grasp_point("basket1") - np.array(spec.position_frd))
    jaws = acts.Jaws("rov", spec, gr.GripperState("closed", 0.7), rov_pose)
    assert acts.between_jaws(ws, jaws) == "basket1"
    events = acts.grasp(ws, jaws, "basket1", 5.0)
    assert events[0].reason == "too heavy for the jaws: 68.2 N in water, they hold 24.0 N"
    # open jaws do not grasp
    assert acts.grasp(ws, acts.Jaws("rov", spec, gr.GripperState(), rov_pose), "basket1",
                      5.0)[0].reason == "the jaws are open"


# ------------------------------------------------------------------------ use


def test_a_wrench_works_a_flange_bolt_until_it_is_loose_then_it_comes_out():
    ws = world()
    h = hand(at=ws.grasp_point("wrench1"))
    acts.grasp(ws, h, "wrench1", 0.0)
    nut = ws.flanges["flange1"].bolt_position(1)
    # the hand 0.2 m from the nut: the wrench (0.265 m from grip to jaw) spans it
    worker = hand(body=h.body_pose, q=h.q, at=nut + np.array([-0.2, 0.0, 0.0]))
    ws.carry(worker.name, worker.grip_frame())
    loosened = []
    for k in range(round(20.0 / DT) + 1):
        loosened += acts.use(ws, worker, "flange1", 1, DT, k * DT)
    assert kinds(loosened) == [("bolt_loosened", True)]
    assert ws.flanges["flange1"].bolt_status(ws.flange_states["flange1"], 1) == "loose"
    # the other hand takes the bolt out
    left = hand(side="left", body=h.body_pose, q=worker.q, at=nut)
    assert kinds(acts.remove_bolt(ws, left, "flange1", 1, 21.0)) == [("bolt_removed", True)]
    # the cover: by its rim, and only with every bolt out
    rim = hand(side="left", body=h.body_pose, q=worker.q,
               at=ws.flanges["flange1"].cover_grasp_position())
    assert acts.remove_cover(ws, left, "flange1", 21.0)[0].reason == (
        "hand 0.14 m from it (tolerance 0.05 m)")
    assert acts.remove_cover(ws, rim, "flange1", 21.0)[0].reason == (
        "3 bolt(s) still in: 0, 2, 3")


def test_use_needs_the_right_tool_held_and_within_its_reach():
    ws = world()
    h = hand(at=ws.grasp_point("hammer1"))
    assert acts.use(ws, h, "flange1", 0, DT, 0.0)[0].reason == (
        "a flange needs a wrench (diver1/right_hand holds nothing)")
    acts.grasp(ws, h, "hammer1", 0.0)
    assert acts.use(ws, h, "flange1", 0, DT, 0.0)[0].reason == (
        "a flange needs a wrench (diver1/right_hand holds hammer1)")
    assert acts.use(ws, h, "hatch1", 0, DT, 0.0)[0].reason.startswith(
        "the hammer does not reach")
    assert acts.use(ws, h, "pump7", 0, DT, 0.0)[0].reason == "no work site 'pump7'"


def test_a_hammer_frees_the_hatch_latch_then_the_hand_opens_it():
    ws = world()
    h = hand(at=ws.grasp_point("hammer1"))
    acts.grasp(ws, h, "hammer1", 0.0)
    latch = ws.hatches["hatch1"].latch_position()
    worker = hand(body=h.body_pose, q=h.q, at=latch + np.array([0.0, 0.0, -0.15]))
    ws.carry(worker.name, worker.grip_frame())
    events = []
    for k in range(round(10.0 / DT) + 1):
        events += acts.use(ws, worker, "hatch1", 0, DT, k * DT)
    assert kinds(events) == [("latch_freed", True)]
    handle = ws.hatches["hatch1"].handle_position(ws.hatch_states["hatch1"])
    opener = hand(body=h.body_pose, q=worker.q, at=handle)
    assert kinds(acts.operate_hatch(ws, opener, "hatch1", True, 11.0)) == [
        ("hatch_opening", True)]
    opened = []
    for k in range(round(3.0 / DT)):
        opened += ws.step(11.0 + k * DT, DT, FLOOR)
    assert "hatch_opened" in [e.kind for e in opened]


def test_a_lift_bag_rigged_and_inflated_raises_the_load_once_its_lift_exceeds_the_weight():
    """The 40 kg steel valve (W = 341 N in water) with the 100 L bag (its fabric 4 N): at
    11.8 m (2.15 atm) the bag must hold W_total / (rho g) = 34.3 L at depth, 73.7 surface
    litres: 49 s at 1.5 L/s. The load leaves the floor then, not before, and rises."""
    ws = world()
    body, legs = crouching(4.45, 0.0)
    eye = ws.grasp_point("valve1")
    ws.put("bag1", eye + np.array([-0.1, 0.0, 0.0]), where="floor")
    h = hand(body=body, q=legs, at=ws.grasp_point("bag1"), bend=True)
    assert kinds(acts.grasp(ws, h, "bag1", 0.0)) == [("grasp", True)]
    worker = hand(body=body, q=h.q, at=eye, bend=True)
    ws.carry(worker.name, worker.grip_frame())
    assert kinds(acts.use(ws, worker, "valve1", 0, DT, 0.0)) == [("bag_attached", True)]
    assert ws.things["bag1"].where == "rigged:valve1" and ws.held_by(worker.name) is None
    assert kinds(acts.inflate(ws, worker, "bag1", True, 0.0)) == [("bag_inflating", True)]
    load = ws.loads["valve1"].hydro
    bag = ws.bags["bag1"]
    weight = load.in_water_weight() + bag.fabric.in_water_weight()
    lifted_at = None
    for k in range(round(70.0 / DT)):
        t = k * DT
        events = ws.step(t, DT, FLOOR)
        depth = ws.things["valve1"].position[2]
        lift = bag.lift_n(ws.bag_states["bag1"], depth)
        if any(e.kind == "lifted_off" and e.subject == "valve1" for e in events):
            lifted_at = t
            assert lift > weight
        if lifted_at is None:
            assert ws.things["valve1"].where == "floor"
            assert lift <= weight + bag.inflate_rate_lps * DT * 1e-3 * 1025 * 9.81
    pressure = 1.0 + 1025.0 * 9.80665 * (FLOOR_DEPTH - 0.2) / 101325.0
    expected = weight / (1025.0 * 9.80665) * 1e3 * pressure / bag.inflate_rate_lps
    assert lifted_at == pytest.approx(expected, abs=2 * DT)
    assert ws.things["valve1"].position[2] < FLOOR_DEPTH - 0.2 - 1.0  # it is on its way up
    np.testing.assert_allclose(ws.things["bag1"].position, ws.grasp_point("valve1"))


@pytest.mark.parametrize("support", ["floor", "on:stand1"])
@pytest.mark.parametrize(("margin", "lifts"), [(1.02, True), (0.98, False)])
def test_a_rigged_load_lifts_off_its_support_only_when_rho_g_v_exceeds_its_weight(
        support, margin, lifts):
    """The 40 kg valve on the floor or on the stand, its bag given the gas whose lift
    rho g V at the load's depth is 2 % over or under the in-water weight of load and bag."""
    ws = world()
    if support == "floor":
        ws.put("valve1", (5.0, 0.0, FLOOR_DEPTH - 0.2))
    else:  # on the stand's top, 1.1 m over the floor
        ws.put("valve1", (0.45, 0.1, FLOOR_DEPTH - 1.1 - 0.2), where=support)
    bag = ws.bags["bag1"]
    ws.things["bag1"].where = "rigged:valve1"
    weight = (ws.loads["valve1"].hydro.in_water_weight() + bag.fabric.in_water_weight())
    depth = float(ws.things["valve1"].position[2])
    pressure = 1.0 + WATER_DENSITY * GRAVITY * depth / 101325.0
    litres = margin * weight / (WATER_DENSITY * GRAVITY) * 1e3 * pressure
    ws.bag_states["bag1"] = ws_.LiftBagState("valve1", gas_surface_litres=litres)
    assert bag.lift_n(ws.bag_states["bag1"], depth) == pytest.approx(margin * weight)
    events = []
    for k in range(round(2.0 / DT)):
        events += [e for e in ws.step(k * DT, DT, FLOOR) if e.subject == "valve1"]
    rose = depth - float(ws.things["valve1"].position[2])
    if lifts:
        assert [(e.kind, e.subject) for e in events] == [("lifted_off", "valve1")]
        assert ws.things["valve1"].where == "water" and rose > 0.01
    else:
        assert events == [] and ws.things["valve1"].where == support and rose == 0.0
