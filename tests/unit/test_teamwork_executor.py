"""The order executor driving a real diver on weighted boots in a tiny world of real model
objects (tools, a basket, a flange, a load and lift bag), and the order validator."""

import math

import numpy as np
import pytest

from uhrisim.dynamics import diver_boots as bt
from uhrisim.dynamics.diver_body import step_motion
from uhrisim.teamwork import acts
from uhrisim.teamwork import gripper as gr
from uhrisim.teamwork import orders as od
from uhrisim.teamwork.executor import DiverView, ExecutorParams, OrderExecutor
from uhrisim.teamwork.workspace import Platform, Workspace, pose_matrix
from uhrisim.world import seafloor
from uhrisim.world import worksites as ws_
from uhrisim.world.tools import make_tool

FLOOR_DEPTH = 12.0
SEAFLOOR = seafloor.flat(FLOOR_DEPTH, 30.0)
FLOOR = SEAFLOOR.depth_at
BOOTS = bt.BootsParams()
SKELETON = BOOTS.skeleton
LEGS = [SKELETON.index(f"{s}_{j}") for s in ("left", "right")
        for j in ("hip_flex", "hip_abd", "knee", "ankle")]
DT = 1.0 / 20.0  # the models take any step; a coarse one keeps the tests quick


def world(n_bolts=2, loosen_s=3.0):
    ws = Workspace.of(
        tools=[make_tool("wrench", "wrench1"), make_tool("tool_basket", "basket1"),
               make_tool("lift_bag", "bag1")],
        loads=[ws_.steel_load("valve1", 40.0)],
        flanges=[ws_.FlangeSpec("flange1", (3.0, 0.0, FLOOR_DEPTH - 1.0), yaw=math.pi,
                                n_bolts=n_bolts, loosen_time_s=loosen_s)],
        bags=[ws_.LiftBagSpec("bag1")],
        platforms=[Platform("stand1", (1.5, 1.5, FLOOR_DEPTH - 1.0), (0.4, 0.4))])
    ws.put("basket1", (1.5, -1.0, FLOOR_DEPTH - 0.15))
    # tools stand in the basket, handles up (wrench jaw down: pitched -90 degrees)
    ws.put("wrench1", (1.45, -1.0, FLOOR_DEPTH - 0.01 - 0.225), where="in:basket1",
           pitch=-math.pi / 2)
    ws.put("bag1", (1.5, 1.5, FLOOR_DEPTH - 1.05), where="on:stand1")
    ws.put("valve1", (4.0, 2.0, FLOOR_DEPTH - 0.2))
    return ws


class Team:
    """The smallest loop that runs an executor: the diver on boots walks and crouches
    (diver_boots), its upper body moves (step_motion) towards the executor's goals, its
    legs stand on the floor (leg_angles), acts are performed, held objects carried, the
    workspace's physics stepped, and the events handed back."""

    def __init__(self, ws, orders, params=None, start=(0.0, 0.0, 0.0)):
        self.ws, self.t = ws, 0.0
        state = bt.BootsState((start[0], start[1], 0.0), start[2])
        self.state = bt.BootsState((start[0], start[1], bt.standing_hip_depth(
            state, BOOTS, FLOOR)), start[2])
        self.q = bt.leg_angles(self.state, BOOTS, FLOOR, SKELETON.zeros())
        self.qdot = np.zeros_like(self.q)
        self.goal = self.q.copy()
        self.executor = OrderExecutor("diver1", orders, params or ExecutorParams())
        self.events, self.notes = [], []
        self.grips, self.extra_carriers = {}, {}

    def view(self):
        return DiverView("diver1", True, SKELETON, self.q,
                         pose_matrix(self.state.position, self.state.psi), self.state.speed)

    def tick(self):
        d = self.executor.tick(self.view(), self.ws, self.grips, self.t, DT)
        self.notes.append(d.note)
        result = bt.step(self.state, bt.BootsCommand(d.speed, d.turn_rate), BOOTS, DT, FLOOR)
        self.state = result.state
        if d.arm_goal is not None:
            self.goal = d.arm_goal.copy()
        self.goal[LEGS] = self.q[LEGS]
        self.q, self.qdot = step_motion(SKELETON, self.q, self.qdot, self.goal, DT)
        legs = bt.leg_angles(self.state, BOOTS, FLOOR, self.q)
        self.q[LEGS] = legs[LEGS]
        view = self.view()
        carriers = {h.name: h for h in (view.hand("left"), view.hand("right"))}
        carriers |= self.extra_carriers
        events = []
        if d.act is not None:
            events += acts.perform(d.act, self.ws, carriers, self.t, DT, FLOOR)
        for name, carrier in carriers.items():
            self.ws.carry(name, carrier.grip_frame())
        events += self.ws.step(self.t, DT, FLOOR)
        self.executor.observe(events)
        self.events += events
        self.t += DT
        return events

    def run(self, seconds, until=None):
        for _ in range(round(seconds / DT)):
            self.tick()
            if self.executor.finished or (until and until()):
                break
        return self


def outcomes(executor):
    return [(od.describe(s.order), s.outcome) for s in executor.steps]


@pytest.mark.slow
def test_the_script_runs_pick_up_use_remove_put_down():
    orders = [od.PickUp("wrench1"), od.UseOn("wrench1", "flange1", 3.0, part=0),
              od.UseOn("wrench1", "flange1", 3.0, part=1), od.Remove("flange1", 0),
              od.Remove("flange1", 1), od.Remove("flange1", "cover"),
              od.PutDown("wrench1", "stand1"), od.Signal("ok", 1.0)]
    ws = world()
    team = Team(ws, orders).run(240.0)
    assert outcomes(team.executor) == [(od.describe(o), "done") for o in orders]
    state = ws.flange_states["flange1"]
    assert all(state.removed) and not state.cover_on
    assert ws.things["wrench1"].where == "on:stand1" and ws.held_by("diver1/right_hand") is None
    # every bolt had at least its 3 s of wrench work, and the timeline is in order
    assert all(w >= 3.0 - 1e-9 for w in state.work_s)
    starts = [s.started for s in team.executor.steps]
    assert starts == sorted(starts) and team.executor.steps[-1].ended < 240.0
    kinds = [e.kind for e in team.events if e.ok]
    assert kinds.count("bolt_loosened") == 2 and kinds.count("bolt_removed") == 2
    assert "cover_removed" in kinds and "place" in kinds
    # the diver bent over the basket and stood up for the flange
    bent = [n for n in team.notes if n.startswith("pick up wrench1: reach")]
    assert bent and any(n.startswith("use wrench1 on flange1: approach") for n in team.notes)


def test_out_of_reach_makes_the_diver_come_closer():
    """Told to stand 1.6 m off, the arm cannot reach, even bending over; the executor
    comes 0.1 m closer each time until it can, and the orders complete."""
    orders = [od.PickUp("wrench1"), od.UseOn("wrench1", "flange1", 1.0, part=0)]
    params = ExecutorParams(standoff=1.6, max_retries=12)
    team = Team(world(), orders, params).run(120.0)
    assert outcomes(team.executor) == [("pick up wrench1", "done"),
                                       ("use wrench1 on flange1 for 1 s", "done")]
    assert any("closer (out of reach" in n for n in team.notes)


def test_a_dropped_tool_is_fetched_before_the_work_goes_on():
    orders = [od.PickUp("wrench1"), od.UseOn("wrench1", "flange1", 3.0, part=0)]
    ws = world()
    team = Team(ws, orders)
    team.run(120.0, until=lambda: ws.flange_states["flange1"].work_s[0] > 1.0)
    # the wrench slips out of the hand
    hand = team.view().hand("right")
    dropped = acts.release(ws, hand, team.t, FLOOR)
    assert dropped[0].kind == "drop"
    team.run(180.0)
    steps = team.executor.steps
    assert [(od.describe(s.order), s.outcome, s.fetched) for s in steps] == [
        ("pick up wrench1", "done", False), ("pick up wrench1", "done", True),
        ("use wrench1 on flange1 for 3 s", "done", False)]
    assert ws.flanges["flange1"].bolt_status(ws.flange_states["flange1"], 0) == "loose"
    assert any(n.startswith("waiting for wrench1 to settle") for n in team.notes)


def test_rigging_and_inflating_a_lift_bag_then_waiting_for_the_lift():
    orders = [od.PickUp("bag1"), od.UseOn("bag1", "valve1", 1.0), od.Operate("bag1", "inflate"),
              od.WaitUntil("valve1", "lifted", timeout_s=120.0)]
    ws = world()
    team = Team(ws, orders).run(300.0)
    assert outcomes(team.executor) == [(od.describe(o), "done") for o in orders]
    assert ws.things["bag1"].where == "rigged:valve1"
    lifted = [e for e in team.events if e.kind == "lifted_off" and e.subject == "valve1"]
    assert len(lifted) == 1


def test_a_wait_that_times_out_fails_the_script_with_the_reason():
    orders = [od.WaitUntil("flange1", "cover_off", timeout_s=2.0), od.Signal("ok")]
    team = Team(world(), orders).run(10.0)
    assert outcomes(team.executor) == [("wait until flange1 cover_off", "failed")]
    assert team.executor.steps[0].reason == "flange1 not cover_off after 2 s"
    assert team.executor.finished and team.executor.failed


def test_handing_the_wrench_to_the_rovs_gripper():
    """The diver offers the wrench; a stand-in for the ROV's pilot flies the jaws to its
    grasp point and closes them on it; the executor then hands it over."""
    orders = [od.PickUp("wrench1"), od.HandTo("wrench1", "rov1/gripper")]
    ws = world()
    team = Team(ws, orders)
    spec = gr.GripperSpec()
    team.grips["rov1/gripper"] = np.array([1.8, -0.2, FLOOR_DEPTH - 1.2])
    team.run(60.0, until=lambda: any("offer" in n for n in team.notes[-1:]))
    for _ in range(100):  # the jaws come to the offered wrench, closed on its grip
        jaw_at = ws.grasp_point("wrench1")
        pose = pose_matrix(jaw_at - np.array(spec.position_frd))
        team.grips["rov1/gripper"] = jaw_at
        closed = gr.GripperState("closed", 1.0 - ws.grip_width("wrench1") / spec.jaw_opening)
        team.extra_carriers["rov1/gripper"] = acts.Jaws("rov1", spec, closed, pose)
        team.tick()
        if team.executor.finished:
            break
    assert outcomes(team.executor) == [("pick up wrench1", "done"),
                                       ("hand wrench1 to rov1/gripper", "done")]
    assert ws.holders_of("wrench1") == ("rov1/gripper",)
    handover = next(e for e in team.events if e.kind == "handover")
    assert handover.detail["holders"] == "diver1/right_hand, rov1/gripper"


# ------------------------------------------------------------------------ validation

SETUP = od.DiverSetup("diver1", True, (0.0, 0.0))
EXTENT = (-15.0, 15.0, -15.0, 15.0)


def validate(orders, ws=None, floor=FLOOR, setup=SETUP):
    return od.validate_orders(orders, setup, ws or world(), floor, EXTENT,
                              carriers=["rov1/gripper"])


def test_a_good_script_validates():
    orders = [od.GoTo("basket1"), od.PickUp("wrench1"),
              od.UseOn("wrench1", "flange1", 2.0, part=0),
              od.UseOn("wrench1", "flange1", 1.0, part=0),
              od.UseOn("wrench1", "flange1", 3.0, part=1), od.Remove("flange1", 0),
              od.Remove("flange1", 1), od.Remove("flange1", "cover"),
              od.HandTo("wrench1", "rov1/gripper"), od.WaitUntil("flange1", "bolt0_out"),
              od.Signal("ok")]
    assert validate(orders) == []


@pytest.mark.parametrize("order,message", [
    (od.PickUp("wrench9"), "order 1 (pick up wrench9): no object or site 'wrench9' (have "
                           "bag1, basket1, flange1, stand1, valve1, wrench1)"),
    (od.UseOn("bag1", "flange1", 5.0), "order 1 (use bag1 on flange1 for 5 s): a flange "
                                        "needs a wrench; bag1 is a lift_bag"),
    (od.UseOn("wrench1", "flange1", 5.0, part=4), "order 1 (use wrench1 on flange1 for 5 s): "
                                                   "flange1 has bolts 0 to 1, not 4"),
    (od.Remove("flange1", "cover"), "order 1 (remove flange1 cover): the cover comes off only "
                                    "with every bolt out; no order before takes out bolt(s) "
                                    "0, 1"),
    (od.Remove("flange1", 0), "order 1 (remove flange1 bolt 0): bolt 0 is tight: the orders "
                              "before give it 0 s of wrench work, it needs 3 s"),
    (od.HandTo("wrench1", "rov2/gripper"), "order 1 (hand wrench1 to rov2/gripper): no "
                                           "carrier 'rov2/gripper' (have diver1/left_hand, "
                                           "diver1/right_hand, rov1/gripper)"),
    (od.HandTo("wrench1", "rov1/gripper"), "order 1 (hand wrench1 to rov1/gripper): wrench1 "
                                           "is not held: no order before picks it up"),
    (od.WaitUntil("flange1", "open"), "order 1 (wait until flange1 open): flange1 (a flange) "
                                      "has states cover_off, all_bolts_out, bolt<i>_loose, "
                                      "bolt<i>_out with i < 2, not 'open'"),
    (od.Signal("wave"), "order 1 (signal wave): unknown signal 'wave' (have ok, up, down, "
                        "stop, come_here, hold_this)"),
    (od.SetMode("swim"), "order 1 (swim): a diver on weighted boots walks; swimming needs "
                         "model: diver"),
])
def test_impossible_orders_are_refused_with_one_line(order, message):
    assert validate([order]) == [message]


def test_a_site_no_walking_path_reaches_is_refused():
    """A flange on a ledge behind a 1 m step (a cliff between): the walking diver cannot
    get there; the same flange on a slope it can walk is fine; one 3 m up is too high."""
    north = np.linspace(-15.0, 15.0, 61)
    east = np.linspace(-15.0, 15.0, 61)
    depth = np.where(north[:, None] > 2.0, FLOOR_DEPTH - 1.0, FLOOR_DEPTH) + 0.0 * east
    ledge = seafloor.SeaFloor(north, east, depth)
    ws = world()
    errors = validate([od.GoTo("flange1")], ws, ledge.depth_at)
    assert errors == ["order 1 (go to flange1): no walking path reaches flange1 at (3.0, 0.0): "
                      "the floor between is too steep or missing"]
    rising = FLOOR_DEPTH - 0.2 * np.clip(north[:, None], 0.0, 5.0)  # 20 %, up 1 m over 5 m
    ramp = seafloor.SeaFloor(north, east, rising + 0.0 * east)
    assert validate([od.GoTo("flange1")], ws, ramp.depth_at) == []
    high = Workspace.of(tools=[make_tool("wrench", "wrench1")],
                        flanges=[ws_.FlangeSpec("flange1", (3.0, 0.0, FLOOR_DEPTH - 3.0))])
    high.put("wrench1", (1.0, 0.0, FLOOR_DEPTH - 0.01))
    assert validate([od.GoTo("flange1")], high) == [
        "order 1 (go to flange1): flange1 is 3.0 m above the floor: a walking diver reaches "
        "2.0 m"]
    # a swimming diver goes anywhere
    swimmer = od.DiverSetup("diver1", False, (0.0, 0.0))
    assert validate([od.GoTo("flange1")], ws, ledge.depth_at, swimmer) == []
