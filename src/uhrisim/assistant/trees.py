"""The assistant's behavior tree (py_trees): guards first, then the task in hand.

::

    assistant (sequence)
    ├── speed ceiling                 every tick: near_speed within reach of the diver
    └── decide (selector, re-evaluated every tick: a guard pre-empts the task)
        ├── diver lost    → abort the task, back off from where he was seen, hold
        ├── he has it     → he grips what the gripper holds: release it (before a guard's
        │                   back-off can pull it from his hand), back away, bring_tool done
        ├── too close     → back off astern, facing him (now or guard_lookahead_s ahead on
        │                   his track; hysteresis: to guard + backoff_to)
        ├── closing fast  → stop
        └── task (selector: the branch of the command in hand)
            ├── stop        hold where it is, facing the diver
            ├── follow_me   trail him
            ├── come_here   go to arm's reach in front of him, hold there facing him
            ├── bring_tool  fetch it (creep, square up, grip at the grasp point, fetch_attempts
            │               tries), hand it over (stand off, face him, creep to his hand,
            │               hold still until he grips; offer again on a timeout)
            ├── light_here  stand off from the work, above it, facing it, and hold
            ├── go_up       rise where it is to surface_depth and hold
            └── no task     (selector)
                ├── say again?  he hovers in front and nothing was read for ask_after_s:
                │               close in to arm's reach (come_here's point) unless within
                │               reach_m + position_tolerance_m of him already, then swing
                │               the lamps off him and back, twice (ask_max in a row)
                └── idle        hold where it is, facing the diver (or, with
                                watch_range_m, that far from him at his chest's depth)

The targets near the diver are kept a guard + ``clearance_m`` away from his body and
head; a task whose subtree fails ends (an event says so) and the ROV holds.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import py_trees
from py_trees.composites import Selector, Sequence
from py_trees.decorators import Retry

from uhrisim.assistant.behaviours import (
    Approach,
    AskAgain,
    BackOff,
    Check,
    CueAgain,
    Do,
    Face,
    Follow,
    GoTo,
    Gripper,
    HoldAt,
    Leaf,
    Point,
    SpeedCeiling,
    Status,
    TreeContext,
    WaitUntil,
    drive_facing,
)
from uhrisim.assistant.geometry import (
    bearing_deg,
    centre_for_jaw,
    guard_slack_ahead,
    horizontal,
    kept_clear,
    separations,
)
from uhrisim.core.frames import rot_z

CHEST_ABOVE_PELVIS_M = 0.3  # where "come here" brings the ROV: the diver's chest height
#: at the grasp, the ROV turns to the planned heading within this before it grips: its
#: jaws, 0.25 m ahead, are then within 1 cm of the grasp point (deg)
SQUARE_UP_DEG = 2.0
#: watching, the ROV's speed per metre of range error (1/s; at most near_speed)
WATCH_GAIN = 0.5


def _dir(heading_deg: float) -> Point:
    return rot_z(math.radians(heading_deg)) @ np.array([1.0, 0.0, 0.0])


def facing_diver(ctx: TreeContext) -> float | None:
    d = ctx.diver
    return None if d is None else bearing_deg(ctx.rov, d.position_ned)


class TooClose(Leaf):
    """Inside a guard + ``trigger_margin_m`` now or ``guard_lookahead_s`` ahead on the
    diver's track (and until out past a guard + ``backoff_to_m``, both).
    A condition is initialised every tick (it never runs), so its state lives here."""

    def __init__(self, name: str, ctx: TreeContext) -> None:
        super().__init__(name, ctx)
        self.active = False

    def update(self) -> Status:
        cfg, diver = self.ctx.config, self.ctx.diver
        if diver is None:
            self.active = False
            return Status.FAILURE
        slack = guard_slack_ahead(self.ctx.rov, diver, cfg)
        if self.active:
            self.active = slack < cfg.backoff_to_m
        else:
            self.active = slack < cfg.trigger_margin_m
            if self.active:
                body, head = separations(self.ctx.rov, diver)
                self.ctx.event(f"guard: {body:.2f} m from the diver's body, {head:.2f} m "
                               "from his head; backing off")
        return Status.SUCCESS if self.active else Status.FAILURE


class ClosingFast(Leaf):
    """Within ``slow_radius_m``, the range to the diver shrinking faster than
    ``max_closing_speed`` (from the last tick's range)."""

    def __init__(self, name: str, ctx: TreeContext) -> None:
        super().__init__(name, ctx)
        self.last: tuple[float, float] | None = None

    def update(self) -> Status:
        cfg, diver = self.ctx.config, self.ctx.diver
        if diver is None:
            self.last = None
            return Status.FAILURE
        rng = min(separations(self.ctx.rov, diver))
        last, self.last = self.last, (self.ctx.t, rng)
        if last is None or self.ctx.t <= last[0] or rng > cfg.slow_radius_m:
            return Status.FAILURE
        closing = (last[1] - rng) / (self.ctx.t - last[0])
        return Status.SUCCESS if closing > cfg.max_closing_speed else Status.FAILURE


class HoldHere(HoldAt):
    """Hold the point where the hold began, facing the diver when he is seen (else the
    heading it had)."""

    def __init__(self, name: str, ctx: TreeContext) -> None:
        self._here: Point | None = None
        self._heading = 0.0
        super().__init__(name, ctx, lambda c: self._here,
                         lambda c: facing_diver(c) if c.diver is not None else self._heading)

    def initialise(self) -> None:
        self._here = self.ctx.rov.copy()
        self._heading = self.ctx.now.rov.heading_deg
        super().initialise()


class Watch(Leaf):
    """Idle with ``watch_range_m``: keep that far from the diver (horizontally) at his
    chest's depth, facing him — forward or astern along the line to him (the helm parked,
    as a back-off), at ``WATCH_GAIN`` × the range's error, at most ``near_speed``; the
    camera stays on him all the while."""

    def __init__(self, name: str, ctx: TreeContext, range_m: float) -> None:
        super().__init__(name, ctx)
        self.range_m = range_m

    def update(self) -> Status:
        diver, cfg = self.ctx.diver, self.ctx.config
        if diver is None:
            return Status.FAILURE
        error = math.hypot(*(diver.position_ned - self.ctx.rov)[:2]) - self.range_m
        speed = max(-cfg.near_speed, min(cfg.near_speed, WATCH_GAIN * error))
        drive_facing(self.ctx, diver.position_ned, speed,
                     float(diver.position_ned[2]) - CHEST_ABOVE_PELVIS_M)
        return Status.RUNNING


def _task(ctx: TreeContext, command: str, subtree: py_trees.behaviour.Behaviour
          ) -> py_trees.behaviour.Behaviour:
    """The branch of one command: runs while it is the task; a failure ends the task."""
    return Sequence(command, memory=False, children=[
        Check(f"task is {command}?", ctx,
              lambda c: c.task is not None and c.task.name == command),
        Selector(f"{command}: run", memory=False, children=[
            subtree, Do(f"{command} failed", ctx, lambda c: c.finish_task("failed"))])])


# ---------------------------------------------------------------------------- targets

def _jaw_depth(ctx: TreeContext, point_depth: float) -> float:
    """The ROV's centre depth that puts its jaws at ``point_depth``."""
    return point_depth - ctx.config.jaw_frd[2]


def come_here_point(ctx: TreeContext) -> Point | None:
    d = ctx.diver
    if d is None:
        return None
    p = d.position_ned + ctx.config.reach_m * d.forward
    p[2] = d.position_ned[2] - CHEST_ABOVE_PELVIS_M
    return kept_clear(p, d.forward, d, ctx.config)


def handover_standoff(ctx: TreeContext) -> Point | None:
    d = ctx.diver
    if d is None:
        return None
    p = d.position_ned + ctx.config.standoff_m * d.forward
    p[2] = _jaw_depth(ctx, d.hand[2])
    return p


def _plan_handover(ctx: TreeContext) -> None:
    d = ctx.diver
    if d is not None:
        ctx.plan["handover_heading"] = bearing_deg(ctx.rov, d.hand)


def handover_point(ctx: TreeContext) -> Point | None:
    """The ROV's centre with its jaws ``handover_gap_m`` short of the diver's hand along
    the planned approach, at the planned heading (not the heading it has: with the jaws
    0.25 m ahead, a target that turned with the ROV would run away from a vehicle that
    yaws while it creeps)."""
    d, h = ctx.diver, ctx.plan.get("handover_heading")
    if d is None or h is None:
        return None
    way = _dir(float(h))  # type: ignore[arg-type]
    jaws = d.hand - ctx.config.handover_gap_m * way
    centre = centre_for_jaw(jaws, float(h), ctx.config)  # type: ignore[arg-type]
    return kept_clear(centre, -way, d, ctx.config)


def diver_grips(ctx: TreeContext) -> bool:
    return len(ctx.now.gripper.shared_with) > 0


def _grasp(ctx: TreeContext) -> Point | None:
    tool = ctx.task.argument if ctx.task is not None else None
    p = ctx.now.tools.get(tool) if tool is not None else None
    return None if p is None else np.asarray(p, dtype=float)


def _plan_fetch(ctx: TreeContext) -> None:
    """The grasp's heading (from where the ROV is) and the stand-off point on that line,
    ``basket_standoff_m`` short of the grasp: the last approach starts and ends there."""
    grasp = _grasp(ctx)
    if grasp is not None:
        h = bearing_deg(ctx.rov, grasp)
        ctx.plan["fetch_heading"] = h
        ctx.plan["fetch_standoff"] = (centre_for_jaw(grasp, h, ctx.config)
                                      - ctx.config.basket_standoff_m * _dir(h))


def fetch_point(ctx: TreeContext) -> Point | None:
    """The ROV's centre with its jaws on the grasp point, at the planned heading (see
    :func:`handover_point`)."""
    grasp, h = _grasp(ctx), ctx.plan.get("fetch_heading")
    return None if grasp is None or h is None else centre_for_jaw(
        grasp, float(h), ctx.config)  # type: ignore[arg-type]


def _plan_light(ctx: TreeContext) -> None:
    arg = ctx.task.argument if ctx.task is not None else None
    d = ctx.diver
    work = ctx.now.sites.get(arg) if arg is not None else (d.hand if d is not None else None)
    if work is None:
        return
    work = np.asarray(work, dtype=float)
    away = horizontal(ctx.rov - work)
    if not away.any():
        away = -d.forward if d is not None else np.array([1.0, 0.0, 0.0])
    p = work + ctx.config.light_standoff_m * away
    p[2] = work[2] - ctx.config.light_above_m
    if d is not None:
        p = kept_clear(p, away, d, ctx.config)
    ctx.plan["light_station"] = p
    ctx.plan["light_work"] = work


def _planned(key: str) -> Callable[[TreeContext], Point | None]:
    return lambda c: c.plan.get(key)  # type: ignore[return-value]


def _plan_up(ctx: TreeContext) -> None:
    p = ctx.rov.copy()
    p[2] = ctx.config.surface_depth_m
    ctx.plan["up_point"], ctx.plan["up_heading"] = p, ctx.now.rov.heading_deg


# ---------------------------------------------------------------------------- tree

def build_tree(ctx: TreeContext) -> tuple[py_trees.behaviour.Behaviour, Selector]:
    """The whole tree (module docstring) and its task selector (stopped by the assistant
    when the task changes, so that the new one starts from its beginning)."""
    cfg = ctx.config

    def back_off_until_clear(name: str) -> BackOff:
        return BackOff(name, ctx, lambda c: c.diver,
                       lambda c: c.diver is None
                       or guard_slack_ahead(c.rov, c.diver, cfg) >= cfg.backoff_to_m)

    lost = Sequence("diver lost", memory=False, children=[
        Check("track lost?", ctx, lambda c: c.diver is None),
        Do("abort the task", ctx, lambda c: c.finish_task("aborted: the diver track is lost")
           if c.task is not None else None),
        Selector("get clear", memory=False, children=[
            Sequence("back off and hold", memory=False, children=[
                BackOff("back off from where he was", ctx, lambda c: c.last_diver,
                        lambda c: c.last_diver is not None and float(np.linalg.norm(
                            (c.rov - c.last_diver.position_ned)[:2])) >= cfg.lost_standoff_m),
                HoldHere("hold, lost", ctx)]),
            HoldHere("hold, never seen", ctx)])])
    too_close = Sequence("too close", memory=False, children=[
        TooClose("inside a guard?", ctx), back_off_until_clear("back off")])
    closing = Sequence("closing fast", memory=False, children=[
        ClosingFast("closing fast?", ctx),
        Face("stop", ctx, lambda c: c.now.rov.heading_deg, hold=True)])

    fetch = Sequence("fetch", memory=True, children=[
        Do("plan the grasp", ctx, _plan_fetch),
        Gripper("open the gripper", ctx, close=False),
        GoTo("to the tool", ctx, _planned("fetch_standoff"), cfg.cruise_speed),
        Face("face the grasp", ctx, lambda c: c.plan.get("fetch_heading"),  # type: ignore
             lambda c: p[2] if (p := fetch_point(c)) is not None else 0.0),
        Approach("creep to the grasp", ctx, fetch_point, cfg.grasp_tolerance_m),
        Face("square up", ctx, lambda c: c.plan.get("fetch_heading"),  # type: ignore
             lambda c: p[2] if (p := fetch_point(c)) is not None else 0.0,
             tolerance_deg=SQUARE_UP_DEG),
        Gripper("grip", ctx, close=True),
        GoTo("lift clear", ctx, _planned("fetch_standoff"), cfg.near_speed)])
    handover = Sequence("hand over", memory=True, children=[
        back_off_until_clear("clear of him"),
        GoTo("stand off in front", ctx, handover_standoff, cfg.cruise_speed),
        Face("face him", ctx, facing_diver),
        Do("plan the approach", ctx, _plan_handover),
        Approach("creep to his hand", ctx, handover_point, 0.05),
        WaitUntil("hold still until he grips", ctx, diver_grips, cfg.handover_wait_s)])
    bring = Sequence("bring tool", memory=True, children=[
        Selector("have the tool", memory=True, children=[
            Check("holding it?", ctx, lambda c: c.task is not None
                  and c.now.gripper.holding == c.task.argument),
            Retry("fetch, again", fetch, cfg.fetch_attempts)]),
        Retry("offer again", handover, 3)])
    # he grips what it holds — as it holds still, creeps, or backs off at a guard: it
    # lets go before anything else (a guard's back-off would pull the tool from his hand)
    given = Sequence("he has it", memory=True, children=[
        Check("he grips it?", ctx, diver_grips),
        Gripper("release", ctx, close=False),
        Do("handed over", ctx, lambda c: c.event(
            f"handed over {c.task.argument if c.task is not None else ''}")),
        back_off_until_clear("back away"),
        Do("done", ctx, lambda c: c.finish_task("done") if c.task is not None
           and c.task.name == "bring_tool" else None)])
    light = Sequence("light here", memory=True, children=[
        Do("plan the stand-off", ctx, _plan_light),
        GoTo("to the stand-off", ctx, _planned("light_station"), cfg.cruise_speed),
        HoldAt("light the work", ctx, _planned("light_station"),
               lambda c: bearing_deg(c.rov, w) if (w := c.plan.get("light_work")) is not None
               else None)])  # type: ignore[arg-type]
    come = Sequence("come here", memory=True, children=[
        GoTo("to arm's reach", ctx, come_here_point, cfg.cruise_speed),
        HoldAt("hold at arm's reach", ctx, come_here_point, facing_diver)])
    up = Sequence("go up", memory=True, children=[
        Do("plan the ascent", ctx, _plan_up),
        HoldAt("rise and hold", ctx, _planned("up_point"),
               lambda c: c.plan.get("up_heading"))])  # type: ignore[arg-type]

    ask = AskAgain("ask?", ctx)
    say_again = Sequence("say again?", memory=False, children=[
        ask,
        Selector("close in", memory=False, children=[
            Check("at arm's reach?", ctx, lambda c: c.diver is not None and math.hypot(
                *(c.rov - c.diver.position_ned)[:2]) <= cfg.reach_m + cfg.position_tolerance_m),
            GoTo("to arm's reach", ctx, come_here_point, cfg.near_speed)]),
        CueAgain("swing the lamps", ctx, ask)])
    tasks = Selector("task", memory=False, children=[
        _task(ctx, "stop", HoldHere("hold still", ctx)),
        _task(ctx, "follow_me", Follow("trail him", ctx)),
        _task(ctx, "come_here", come),
        _task(ctx, "bring_tool", bring),
        _task(ctx, "light_here", light),
        _task(ctx, "go_up", up),
        Selector("no task", memory=False, children=[
            say_again, HoldHere("idle", ctx) if cfg.watch_range_m is None
            else Watch("idle", ctx, cfg.watch_range_m)])])
    decide = Selector("decide", memory=False, children=[lost, given, too_close, closing,
                                                        tasks])
    root = Sequence("assistant", memory=False, children=[SpeedCeiling("speed ceiling", ctx),
                                                          decide])
    return root, tasks


def active_path(root: py_trees.behaviour.Behaviour) -> str:
    """The path from the root to the tree's tip this tick ('assistant/decide/...')."""
    tip = root.tip()
    names = []
    node = tip
    while node is not None:
        names.append(node.name)
        node = node.parent
    return "/".join(reversed(names))
