"""The executor of a diver's orders: each tick, the next motion goal and act.

:class:`OrderExecutor` is a state machine over a diver's orders
(:mod:`uhrisim.teamwork.orders`). Every tick the simulation shows it its diver
(:class:`DiverView`), the workspace and where the other carriers' grips are; it answers
with a :class:`Directive`: how to move (forward speed and turn rate, a depth for a
swimmer), the joint goal of the upper body (from the
reach solver or a named pose, for :func:`uhrisim.dynamics.diver_body.step_motion`) and
at most one :class:`~uhrisim.teamwork.acts.ActRequest`. The simulation moves the diver,
performs the act (:func:`uhrisim.teamwork.acts.perform`) and hands the events back
(:meth:`OrderExecutor.observe`).

Each order goes through phases: **approach** (walk or swim until the working hand's
shoulder is ``standoff`` short of the point and in line with it, facing it, upright: a
prone swimmer's shoulders lie half a body ahead of its hips, a walker's above them), **reach** (the
arm puts the hand on the point, the diver bending at the waist and over from the hips if
it must: a diver on boots reaches the floor so), **act** (ask for the act; each tick for
``UseOn``) and **finish** (close the hand).
Failure handling: *out of reach* (the reach solver or an act says so) → come closer
(``standoff`` less 0.1 m, at most ``max_retries`` times); *the hand is not there* → reach
again; *a tool the order needs is not held* (dropped, or never picked up) → fetch it
first (a ``PickUp`` is put in front; a falling tool is waited for until it lands); an
order that cannot go on fails with the reason and the script stops.

The record of every step (:attr:`OrderExecutor.steps`: start, end, outcome, reason) is
what the task-completion metrics and the timeline figure read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.frames import vector_length, wrap_pi
from uhrisim.dynamics.diver_body import SIDES, DiverSkeleton, Side, pose_goal, solve_reach
from uhrisim.dynamics.diver_boots import BootsParams, max_pelvis_tilt
from uhrisim.teamwork import orders as od
from uhrisim.teamwork.acts import HAND_TOLERANCE_M, ActRequest, Hand, site_kind
from uhrisim.teamwork.workspace import Workspace
from uhrisim.world.events import WorldEvent


@dataclass(frozen=True)
class ExecutorParams:
    """How the executor drives its diver (SI; assumed values of a calm, careful diver)."""

    cruise_speed: float = 0.3
    turn_gain: float = 1.5  # rad/s per rad of heading error
    arrive_radius: float = 0.1
    standoff: float = 0.45  # working shoulder to the work point, horizontally, m
    min_standoff: float = 0.2
    lateral: float = 0.2  # the body stands this far aside so the hand's shoulder is in line
    hand_settle: float = 0.01  # the hand is there when within this of its goal, m
    max_retries: int = 3
    handover_timeout_s: float = 120.0


@dataclass(frozen=True)
class DiverView:
    """The executor's diver this tick: whether it walks on weighted boots (else it swims),
    body pose (4x4 body→NED, origin at the hip centre), joint angles, walking speed."""

    name: str
    walks: bool
    skeleton: DiverSkeleton
    q: NDArray[np.float64]
    body_pose: NDArray[np.float64]
    speed: float = 0.0

    @property
    def position(self) -> NDArray[np.float64]:
        return self.body_pose[:3, 3]

    @property
    def heading(self) -> float:
        return math.atan2(self.body_pose[1, 0], self.body_pose[0, 0])

    def hand(self, side: Side) -> Hand:
        return Hand(self.name, side, self.skeleton, self.q, self.body_pose)


@dataclass(frozen=True)
class Directive:
    """What the diver does this tick (module docstring)."""

    speed: float = 0.0
    turn_rate: float = 0.0
    depth: float | None = None
    arm_goal: NDArray[np.float64] | None = None
    act: ActRequest | None = None
    note: str = ""

    def noted(self, note: str) -> Directive:
        """This directive with ``note`` (``dataclasses.replace``'s answer, made directly)."""
        return Directive(self.speed, self.turn_rate, self.depth, self.arm_goal, self.act, note)


@dataclass
class StepRecord:
    """One order's run: when it started and ended (s), how (running, done, failed), why."""

    order: od.Order
    started: float
    ended: float | None = None
    outcome: str = "running"
    reason: str = ""
    fetched: bool = False  # inserted to fetch a tool another order needs


@dataclass
class OrderExecutor:
    """Runs one diver's orders (module docstring). Mutable; owned by the simulation."""

    diver: str
    orders: Sequence[od.Order]
    params: ExecutorParams = field(default_factory=ExecutorParams)
    steps: list[StepRecord] = field(default_factory=list)
    mode: Literal["walk", "swim"] = "walk"
    _queue: list[tuple[od.Order, bool]] = field(default_factory=list)
    _phase: str = "start"
    _standoff: float = 0.0
    _retries: int = 0
    _worked_s: float = 0.0
    _using: bool = False  # a use was asked for last tick
    _stand: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None  # (where, facing)
    _solved: tuple[str, NDArray[np.float64], NDArray[np.float64]] | None = None  # side, point, q
    _since: float = 0.0
    _last_events: list[WorldEvent] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._queue = [(o, False) for o in self.orders]

    # ------------------------------------------------------------------ status
    @property
    def finished(self) -> bool:
        return not self._queue or self.failed

    @property
    def failed(self) -> bool:
        return bool(self.steps) and self.steps[-1].outcome == "failed"

    @property
    def current(self) -> od.Order | None:
        return self._queue[0][0] if self._queue and not self.failed else None

    def observe(self, events: Sequence[WorldEvent]) -> None:
        """The events of this tick (all of them; the executor picks its own)."""
        mine = (f"{self.diver}/left_hand", f"{self.diver}/right_hand")
        self._last_events = [e for e in events if e.actor in mine or e.kind == "handover"]

    # ------------------------------------------------------------------ the tick
    def tick(self, view: DiverView, ws: Workspace, grips: Mapping[str, NDArray[np.float64]],
             t: float, dt: float) -> Directive:
        """Decide this tick's motion and act. ``grips``: other carriers' grip points
        (name → NED) for handovers."""
        events, self._last_events = self._last_events, []
        if self.finished:
            return Directive(arm_goal=None, note="done" if not self.failed else "failed")
        order, fetched = self._queue[0]
        if self._phase == "start":
            self.steps.append(StepRecord(order, t, fetched=fetched))
            self._phase, self._standoff, self._retries = "approach", self.params.standoff, 0
            self._worked_s, self._since, self._using, self._stand = 0.0, t, False, None
            self._solved = None
        return self._run(order, view, ws, grips, events, t, dt)

    def _finish(self, t: float, outcome: str = "done", reason: str = "") -> Directive:
        step = self.steps[-1]
        step.ended, step.outcome, step.reason = t, outcome, reason
        if outcome == "done":
            self._queue.pop(0)
        self._phase = "start"
        return Directive(note=f"{outcome}: {od.describe(step.order)}" + (
            f" ({reason})" if reason else ""))

    def _fetch_first(self, tool: str, t: float) -> Directive:
        """Put a PickUp of ``tool`` in front of the current order (it restarts after)."""
        self.steps.pop()  # the current order restarts once the tool is in hand
        self._queue.insert(0, (od.PickUp(tool, self._free_hand_default()), True))
        self._phase = "start"
        return Directive(note=f"fetching {tool}")

    def _free_hand_default(self) -> Side:
        return "right"

    # ------------------------------------------------------------------ geometry
    def _approach(self, view: DiverView, point: NDArray[np.float64], side: Side,
                  standoff: float) -> tuple[bool, Directive]:
        """Walk or swim until the ``side`` shoulder is ``standoff`` short of ``point`` and
        in line with it, facing it; (arrived, directive). Where to stand is chosen once per
        approach, on the line from where the diver was to the point."""
        p = self.params
        here = view.position[:2]
        if self._stand is None:
            towards = point[:2] - here
            if vector_length(towards) < 1e-6:
                towards = np.array([math.cos(view.heading), math.sin(view.heading)])
            u = towards / vector_length(towards)
            sign = 1.0 if side == "right" else -1.0
            ahead = self._shoulder_ahead(view, side)
            self._stand = (point[:2] - (standoff + ahead) * u
                           - sign * p.lateral * np.array([-u[1], u[0]]), u)
        goal, u = self._stand
        to_goal = goal - here
        distance = vector_length(to_goal)
        depth = None if view.walks else float(point[2])
        if distance > p.arrive_radius:
            bearing = math.atan2(to_goal[1], to_goal[0])
            error = float(wrap_pi(bearing - view.heading))
            speed = min(p.cruise_speed, 0.8 * distance) if abs(error) < math.radians(30) else 0.0
            upright = self._upright(view)
            if np.abs(upright - view.q).max() > math.radians(5.0):
                speed = 0.0  # straighten up before walking off
            return False, Directive(speed, p.turn_gain * error, depth, arm_goal=upright,
                                    note="approach")
        facing = float(wrap_pi(math.atan2(u[1], u[0]) - view.heading))
        settled = abs(facing) < math.radians(8.0) and view.speed < 0.02
        return settled, Directive(0.0, p.turn_gain * facing, depth, note="face")

    def _reach(self, view: DiverView, side: Side, point: NDArray[np.float64],
               fingers_open: bool = True) -> tuple[str, NDArray[np.float64] | None, str]:
        """('there'|'moving'|'out', arm goal, reason) for putting hand ``side`` on
        ``point``."""
        hand = view.hand(side)
        cached = self._solved
        if cached and cached[0] == side and vector_length(cached[1] - point) < 1e-3:
            goal = cached[2]
        else:
            solution = solve_reach(view.skeleton, side, hand.to_body(point), view.q, bend=True,
                                   max_tilt=self._tilt_room(view))
            if not solution.ok:
                return "out", None, solution.reason
            goal = solution.q
            self._solved = (side, np.array(point, dtype=float), goal)
        if fingers_open:
            goal = view.skeleton.vector({f"{side}_fingers": 0.0}, goal)
        there = vector_length(hand.grip_frame()[:3, 3] - point) < self.params.hand_settle
        if fingers_open and not hand.is_open():
            there = False  # a short reach arrives before the fingers have opened
        return ("there" if there else "moving"), goal, ""

    def _shoulder_ahead(self, view: DiverView, side: Side) -> float:
        """How far (m) the ``side`` shoulder lies ahead of the hip centre in the posture
        the diver moves in (prone swimmer: about the trunk's length; upright: ~0)."""
        skeleton = view.skeleton
        i = skeleton.index(f"{side}_shoulder_flex")
        t = skeleton.joint_transforms(self._upright(view))[i]
        return float((t[:3, :3] @ np.asarray(skeleton.joints[i].pivot) + t[:3, 3])[0])

    @staticmethod
    def _tilt_room(view: DiverView) -> float | None:
        """How far a diver on boots may tilt its pelvis (a swimmer: no cap)."""
        if not view.walks:
            return None
        return max_pelvis_tilt(BootsParams(skeleton=view.skeleton), view.q)

    def _upright(self, view: DiverView) -> NDArray[np.float64]:
        """The body straightened for moving: pelvis level (prone for a swimmer), trunk
        straight, arms as they are."""
        posture = 0.0 if view.walks else math.pi / 2
        return view.skeleton.vector({"posture": posture, "waist": 0.0}, view.q)

    def _closed_hand(self, view: DiverView, side: Side) -> NDArray[np.float64]:
        i = view.skeleton.index(f"{side}_fingers")
        return view.skeleton.vector({f"{side}_fingers": view.skeleton.upper[i]}, view.q)

    def _on_failure(self, reason: str, t: float) -> Directive | None:
        """A failed act's answer: out of reach → come closer (None: go on); the hand not
        there → None (reach again); anything else fails the order."""
        if reason.startswith(("out of reach", "too close")) or "does not reach" in reason:
            return self._come_closer(reason, t)
        if reason.startswith("hand "):
            return None  # the next tick's reach moves it there
        return self._finish(t, "failed", reason)

    def _come_closer(self, reason: str, t: float) -> Directive | None:
        """Out of reach: approach again 0.1 m closer (None), or fail the order."""
        p = self.params
        if self._retries >= p.max_retries or self._standoff - 0.1 < p.min_standoff:
            return self._finish(t, "failed", reason)
        self._retries += 1
        self._standoff -= 0.1
        self._phase, self._stand, self._solved = "approach", None, None
        return None

    # ------------------------------------------------------------------ the orders
    def _run(self, order: od.Order, view: DiverView, ws: Workspace,
             grips: Mapping[str, NDArray[np.float64]], events: list[WorldEvent], t: float,
             dt: float) -> Directive:
        match order:
            case od.GoTo(target=target, standoff_m=standoff):
                point = (od.target_point(ws, target) if isinstance(target, str)
                         else np.array([target[0], target[1], view.position[2]]))
                arrived, d = self._approach(view, point, "right", standoff)
                return self._finish(t) if arrived else d
            case od.SetMode(mode=mode):
                self.mode = mode
                return self._finish(t)
            case od.Signal(seconds=seconds):
                if t - self._since >= seconds:
                    return self._finish(t)
                return Directive(arm_goal=pose_goal(view.skeleton, "signal_ready", view.q),
                                 note=f"signal {order.name}")
            case od.WaitUntil(subject=subject, state=state, timeout_s=timeout):
                if od.condition_holds(ws, subject, state):
                    return self._finish(t)
                if t - self._since > timeout:
                    return self._finish(t, "failed", f"{subject} not {state} after {timeout:g} s")
                return Directive(note=f"waiting until {subject} {state}")
            case od.PickUp(obj=obj, hand=side):
                return self._pick_up(view, ws, obj, side, events, t)
            case od.UseOn(tool=tool, site=site, part=part, seconds=seconds):
                return self._use(view, ws, tool, site, part, seconds, events, t, dt)
            case od.Remove(site=site, part=part):
                spec = ws.flanges[site]
                point = (spec.cover_grasp_position() if part == "cover"
                         else spec.bolt_position(part))
                kind = "remove_cover" if part == "cover" else "remove_bolt"
                return self._by_hand(view, ws, point, ActRequest(
                    kind, "", site, 0 if part == "cover" else part), events, t,
                    {"bolt_removed", "cover_removed"})
            case od.Operate(site=site, action=action):
                if site in ws.hatches:
                    point = ws.hatches[site].handle_position(ws.hatch_states[site])
                    request = ActRequest("operate_hatch", "", site, flag=action == "open")
                    done = {"hatch_opening", "hatch_closing"}
                else:
                    point = ws.grasp_point(ws.bag_states[site].attached_to or site)
                    request = ActRequest("inflate", "", site, flag=action == "inflate")
                    done = {"bag_inflating", "bag_inflation_stopped"}
                return self._by_hand(view, ws, point, request, events, t, done)
            case od.PutDown(obj=obj, on=on):
                return self._put_down(view, ws, obj, on, events, t)
            case od.HandTo(obj=obj, receiver=receiver):
                return self._hand_to(view, ws, obj, receiver, grips, events, t)
        return self._finish(t, "failed", f"cannot run {order!r}")

    def _holding_hand(self, ws: Workspace, obj: str) -> Side | None:
        for side in SIDES:
            if ws.held_by(f"{self.diver}/{side}_hand") == obj:
                return side
        return None

    def _free_hand(self, ws: Workspace) -> Side:
        for side in ("right", "left"):
            if ws.held_by(f"{self.diver}/{side}_hand") is None:
                return side
        return "right"

    def _pick_up(self, view: DiverView, ws: Workspace, obj: str, side: Side,
                 events: list[WorldEvent], t: float) -> Directive:
        for e in events:
            if e.kind == "grasp" and e.subject == obj and e.ok:
                self._phase = "secure"
            elif e.kind == "grasp_failed" and e.subject == obj:
                answer = self._on_failure(e.reason, t)
                if answer is not None:
                    return answer
        if self._phase == "secure":
            if view.skeleton.grip_closure(view.q, side) > 0.95:
                return self._finish(t)
            return Directive(arm_goal=self._closed_hand(view, side), note=f"grip {obj}")
        if self._holding_hand(ws, obj) is not None:
            return self._finish(t)
        if ws.thing(obj).where in ("water", "surface"):
            return Directive(note=f"waiting for {obj} to settle")
        point = ws.grasp_point(obj)
        return self._reach_and_act(view, point, side, ActRequest("grasp", "", obj), t,
                                   f"pick up {obj}")

    def _reach_and_act(self, view: DiverView, point: NDArray[np.float64], side: Side,
                       request: ActRequest, t: float, note: str,
                       fingers_open: bool = True) -> Directive:
        """Approach, reach, then ask for ``request`` (with this hand as the carrier)."""
        if self._phase == "approach":
            arrived, d = self._approach(view, point, side, self._standoff)
            if not arrived:
                return d.noted(f"{note}: approach")
            self._phase = "reach"
        state, goal, reason = self._reach(view, side, point, fingers_open)
        if state == "out":
            retry = self._come_closer(reason, t)
            return retry or Directive(note=f"{note}: closer ({reason})")
        if state == "moving":
            return Directive(arm_goal=goal, note=f"{note}: reach")
        carrier = f"{self.diver}/{side}_hand"
        return Directive(arm_goal=goal, act=request.by(carrier),
                         note=note)

    def _use(self, view: DiverView, ws: Workspace, tool: str, site: str, part: int,
             seconds: float, events: list[WorldEvent], t: float, dt: float) -> Directive:
        kind = site_kind(ws, site)
        if kind == "load" and any(e.ok and e.kind == "bag_attached" for e in events):
            return self._finish(t)
        side = self._holding_hand(ws, tool)
        if side is None:
            where = ws.thing(tool).where
            if where == "held":
                return self._finish(t, "failed", f"{tool} is held by "
                                    f"{', '.join(ws.holders_of(tool))}")
            return self._fetch_first(tool, t)
        failed = [e for e in events if not e.ok and e.kind == "use_failed"]
        for e in failed:
            answer = self._on_failure(e.reason, t)
            if answer is not None:
                return answer
        if self._using and not failed:
            self._worked_s += dt  # last tick's work went in
        self._using = False
        if kind != "load" and self._worked_s >= seconds - 1e-9:
            return self._finish(t)
        work = ws.grasp_point(site) if kind == "load" else (
            ws.flanges[site].bolt_position(part) if kind == "flange"
            else ws.hatches[site].latch_position())
        spec = ws.tools[tool]
        span = vector_length(np.subtract(spec.working_point, spec.grasp_point))
        facing = (self._stand[1] if self._stand is not None
                  else np.array([math.cos(view.heading), math.sin(view.heading)]))
        # the hand holds the tool short of the work point, the tool reaching across
        hold_at = work if kind == "load" else work - 0.8 * span * np.array([*facing, 0.0])
        directive = self._reach_and_act(view, hold_at, side,
                                        ActRequest("use", "", site, part), t,
                                        f"use {tool} on {site}", fingers_open=False)
        self._using = directive.act is not None
        return directive

    def _by_hand(self, view: DiverView, ws: Workspace, point: NDArray[np.float64],
                 request: ActRequest, events: list[WorldEvent], t: float,
                 done: set[str]) -> Directive:
        for e in events:
            if e.ok and e.kind in done and e.subject == request.subject:
                return self._finish(t)
            if not e.ok and e.subject == request.subject:
                answer = self._on_failure(e.reason, t)
                if answer is not None:
                    return answer
        side = self._free_hand(ws)
        return self._reach_and_act(view, point, side, request, t,
                                   f"{request.kind} {request.subject}")

    def _put_down(self, view: DiverView, ws: Workspace, obj: str, on: str,
                  events: list[WorldEvent], t: float) -> Directive:
        side = self._holding_hand(ws, obj)
        for e in events:
            if e.kind == "place" and e.subject == obj and e.ok:
                return self._finish(t)
            if e.kind == "place_failed" and e.subject == obj:
                answer = self._on_failure(e.reason, t)
                if answer is not None:
                    return answer
        if side is None:
            return self._finish(t, "failed", f"{obj} is not in hand")
        tool = ws.tools[obj]
        lift = tool.hydro.bottom_offset - tool.grasp_point[2] + 0.02  # grasp above its bottom
        if on in ws.platforms:
            top = np.asarray(ws.platforms[on].top_centre_ned, dtype=float)
        else:
            basket = ws.things[on]
            top = basket.position + np.array([0.0, 0.0, 0.5 * ws.tools[on].size[2] - 0.01])
        target = top - np.array([0.0, 0.0, lift])
        request = ActRequest("place", "", obj, target=tuple(target))
        return self._reach_and_act(view, target, side, request,
                                   t, f"put {obj} on {on}", fingers_open=False)

    def _hand_to(self, view: DiverView, ws: Workspace, obj: str, receiver: str,
                 grips: Mapping[str, NDArray[np.float64]], events: list[WorldEvent], t: float
                 ) -> Directive:
        for e in events:
            if e.kind == "handover" and e.subject == obj and e.ok:
                return self._finish(t)
        side = self._holding_hand(ws, obj)
        if side is None:
            if ws.thing(obj).where != "held":
                return self._fetch_first(obj, t)
            return self._finish(t, "failed", f"{obj} is held by {', '.join(ws.holders_of(obj))}")
        if t - self._since > self.params.handover_timeout_s:
            return self._finish(t, "failed", f"{receiver} did not take {obj} in "
                                f"{self.params.handover_timeout_s:g} s")
        if receiver not in grips:
            return Directive(note=f"waiting for {receiver}")
        grip = np.asarray(grips[receiver], dtype=float)
        if vector_length(ws.grasp_point(obj) - grip) <= HAND_TOLERANCE_M:
            return Directive(act=ActRequest("hand_over", f"{self.diver}/{side}_hand", obj,
                                            receiver=receiver), note=f"hand {obj} to {receiver}")
        # offer it: walk up to the receiver, hold the object out towards its grip
        if self._phase == "approach":
            arrived, d = self._approach(view, grip, side, 0.7)
            if not arrived:
                return d.noted(f"hand {obj} to {receiver}: approach")
            self._phase = "reach"
        hand = view.hand(side)
        offset = ws.grasp_point(obj) - hand.grip_frame()[:3, 3]
        solution = solve_reach(view.skeleton, side, hand.to_body(grip - offset), view.q,
                               bend=True)
        goal = solution.q if solution.ok else pose_goal(view.skeleton, "reach", view.q, side)
        return Directive(arm_goal=self._keep_fingers(view, goal, side),
                         note=f"hand {obj} to {receiver}: offer")

    @staticmethod
    def _keep_fingers(view: DiverView, goal: NDArray[np.float64], side: Side
                      ) -> NDArray[np.float64]:
        i = view.skeleton.index(f"{side}_fingers")
        out = np.array(goal, dtype=float)
        out[i] = view.q[i]
        return out
