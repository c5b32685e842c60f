"""The tree's leaves: conditions, the helm's motion primitives, the gripper, waiting.

Every leaf reads the tick's :class:`TreeContext` (the inputs, the task, the plan) and
writes only into it: the helm variables it wants this tick, a gripper command, events.
The :class:`~uhrisim.assistant.assistant.Assistant` turns that into postings. Time is
the simulation's (``inputs.t``), never the wall clock: the same inputs give the same
decisions.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import py_trees
from numpy.typing import NDArray

from uhrisim.assistant.config import AssistantConfig
from uhrisim.assistant.geometry import (
    bearing_deg,
    closing_speed,
    horizontal,
    segment_distance,
    separations,
)
from uhrisim.assistant.io import AssistantInputs, DiverTrack, HelmMode, moos_xy
from uhrisim.core.frames import wrap_180
from uhrisim.perception.signals import Command

Status = py_trees.common.Status
Point = NDArray[np.float64]


@dataclass
class TreeContext:
    """What the leaves share: the parameters, this tick's inputs, the task in hand and
    its plan (values fixed when a step starts), and this tick's wishes."""

    config: AssistantConfig
    inputs: AssistantInputs | None = None
    task: Command | None = None
    last_diver: DiverTrack | None = None  # the last fresh track
    plan: dict[str, object] = field(default_factory=dict)
    wants: dict[str, str | float] = field(default_factory=dict)
    override: bool = False
    gripper_command: str | None = None
    events: list[str] = field(default_factory=list)
    heard_t: float = -math.inf  # when it last took a command it obeys (s)
    asking: bool = False  # this tick it shows the "say again?" cue

    @property
    def now(self) -> AssistantInputs:
        assert self.inputs is not None
        return self.inputs

    @property
    def t(self) -> float:
        return self.now.t

    @property
    def rov(self) -> Point:
        return self.now.rov.position_ned

    @property
    def diver(self) -> DiverTrack | None:
        """The diver's track if it is fresh (younger than ``lost_after_s``), else None."""
        d = self.now.diver
        return d if d is not None and d.age_s <= self.config.lost_after_s else None

    def want(self, var: str, value: str | float) -> None:
        self.wants[var] = value

    def transit_speed(self, speed: float) -> float:
        """``speed`` (m/s), at most ``carry_speed`` while the gripper holds something."""
        if self.now.gripper.holding is None:
            return speed
        return min(speed, self.config.carry_speed)

    def event(self, text: str) -> None:
        self.events.append(text)

    def finish_task(self, how: str) -> None:
        if self.task is not None:
            self.event(f"task {self.task} {how}")
        self.task = None
        self.plan.clear()


class Leaf(py_trees.behaviour.Behaviour):
    """A leaf bound to the shared context."""

    def __init__(self, name: str, ctx: TreeContext) -> None:
        super().__init__(name)
        self.ctx = ctx


class Check(Leaf):
    """SUCCESS when ``predicate(ctx)`` holds, else FAILURE."""

    def __init__(self, name: str, ctx: TreeContext, predicate: Callable[[TreeContext], bool]
                 ) -> None:
        super().__init__(name, ctx)
        self.predicate = predicate

    def update(self) -> Status:
        return Status.SUCCESS if self.predicate(self.ctx) else Status.FAILURE


class Do(Leaf):
    """Runs ``action(ctx)`` and succeeds (a plan step, an event, finishing the task)."""

    def __init__(self, name: str, ctx: TreeContext, action: Callable[[TreeContext], None]
                 ) -> None:
        super().__init__(name, ctx)
        self.action = action

    def update(self) -> Status:
        self.action(self.ctx)
        return Status.SUCCESS


def _depth(value: float) -> str:
    return f"depth={max(value, 0.0):.2f}"


class Drive(Leaf):
    """A helm motion primitive toward a target that may move (the diver does): the
    target is re-posted only when it has moved ``repost_m`` since it was last posted, so
    the helm's behavior is not reset every tick. Subclasses say what to post and when
    they have arrived."""

    MODE: HelmMode = "FACE"
    repost_m = 0.1

    def __init__(self, name: str, ctx: TreeContext,
                 target: Callable[[TreeContext], Point | None]) -> None:
        super().__init__(name, ctx)
        self.target = target
        self._posted: Point | None = None

    def initialise(self) -> None:
        self._posted = None

    def update(self) -> Status:
        p = self.target(self.ctx)
        if p is None:
            return Status.FAILURE
        if self._posted is None or np.linalg.norm(p - self._posted) > self.repost_m:
            self._posted = p
        self.ctx.want("ASSIST_MODE", self.MODE)
        self.ctx.want("DEPTH_UPDATES", _depth(self._posted[2]))
        self.post(self._posted)
        return Status.SUCCESS if self.arrived(p) else Status.RUNNING

    def post(self, point: Point) -> None:
        raise NotImplementedError

    def arrived(self, point: Point) -> bool:
        cfg = self.ctx.config
        d = point - self.ctx.rov
        return (math.hypot(d[0], d[1]) <= self.tolerance()
                and abs(d[2]) <= cfg.depth_tolerance_m)

    def tolerance(self) -> float:
        return self.ctx.config.position_tolerance_m


#: beside the diver, the ROV goes on straight to his front while he turns less than this
BESIDE_TURN_DEG = 30.0


class GoTo(Drive):
    """Transit to a point (helm GOTO: BHV_Waypoint), the way round the diver when the
    straight line would pass nearer his body than the goal itself and within a guard
    + 0.5 m: first to a point beside him, ``standoff_m`` out on the side the ROV starts
    from — and while the line to that point, too, would pass within a guard + 0.5 m (the
    ROV behind or in front of him), along the ``standoff_m`` circle round him, to the
    point half way round to his side. Once beside him it goes straight on — until he
    swims ``position_tolerance_m`` on or turns ``BESIDE_TURN_DEG``: then it rounds him
    again (the bag-carrying ROV, beside him as he swam past, went on straight to his new
    front across his held-out arms and touched him, 2026-11-26)."""

    MODE = "GOTO"

    def __init__(self, name: str, ctx: TreeContext,
                 target: Callable[[TreeContext], Point | None], speed: float) -> None:
        super().__init__(name, ctx, self._via)
        self.final = target
        self.speed = speed
        self._side: float | None = None  # +1: the diver's left, -1: his right
        #: where he was (NED) and his heading (deg) when the ROV got beside him; None: not yet
        self._beside_at: tuple[Point, float] | None = None

    def initialise(self) -> None:
        super().initialise()
        self._side, self._beside_at = None, None

    def _via(self, ctx: TreeContext) -> Point | None:
        goal = self.final(ctx)
        diver = ctx.diver
        if goal is None or diver is None:
            return goal
        cfg = ctx.config
        if self._beside_at is not None:
            where, heading = self._beside_at
            if (np.linalg.norm((diver.position_ned - where)[:2]) <= cfg.position_tolerance_m
                    and abs(float(wrap_180(diver.heading_deg - heading))) <= BESIDE_TURN_DEG):
                return goal  # beside him, and he is where he was: the rest of the way is clear
            self._side, self._beside_at = None, None  # he swam on or turned: round him again
        body = diver.position_ned, diver.neck

        def closest(end: Point) -> float:  # of the straight line from the ROV to end
            return min(segment_distance(p, *body) for p in np.linspace(ctx.rov, end, 25))

        clear_m = cfg.body_guard_m + 0.5
        if closest(goal) >= min(segment_distance(goal, *body) - 0.05, clear_m):
            return goal
        left = horizontal(np.cross(diver.forward, [0.0, 0.0, 1.0]))
        if self._side is None:
            self._side = 1.0 if left @ (ctx.rov - diver.position_ned) >= 0.0 else -1.0
        beside = diver.position_ned + cfg.standoff_m * self._side * left
        beside[2] = goal[2]
        if np.linalg.norm((beside - ctx.rov)[:2]) <= cfg.position_tolerance_m:
            self._beside_at = (diver.position_ned.copy(), diver.heading_deg)
            return goal
        if closest(beside) >= clear_m:
            return beside
        # the chord to his side would cut across his front or back (his arms reach
        # there): round him on the stand-off circle, half the angle to his side at a time
        here, there = ((p - diver.position_ned)[:2] for p in (ctx.rov, beside))
        start = math.atan2(here[1], here[0])
        turn = math.atan2(there[1], there[0]) - start
        half = start + 0.5 * math.atan2(math.sin(turn), math.cos(turn))
        return np.array([diver.position_ned[0] + cfg.standoff_m * math.cos(half),
                         diver.position_ned[1] + cfg.standoff_m * math.sin(half), goal[2]])

    def post(self, point: Point) -> None:
        speed = self.ctx.transit_speed(self.speed)
        self.ctx.want("WPT_UPDATES", f"points={moos_xy(point)} # speed={speed:.2f}")

    def update(self) -> Status:
        status = super().update()
        goal = self.final(self.ctx)
        if status == Status.RUNNING and goal is not None and math.hypot(
                *(goal - self.ctx.rov)[:2]) <= self.tolerance():
            # there but for the depth: hold the heading (a waypoint behavior that has
            # reached its point completes, and a helm left without a course stops all)
            self.ctx.want("ASSIST_MODE", "FACE")
            self.ctx.want("HEADING_UPDATES", f"heading={round(self.ctx.now.rov.heading_deg) % 360}")
        return status

    def arrived(self, point: Point) -> bool:  # only at the final goal
        goal = self.final(self.ctx)
        return goal is not None and super().arrived(goal)


class Approach(Drive):
    """Close in on a point, slowing as it nears (helm APPROACH: BHV_StationKeep with its
    speed graded inside outer_radius), to ``tolerance_m``."""

    MODE = "APPROACH"
    repost_m = 0.01

    def __init__(self, name: str, ctx: TreeContext,
                 target: Callable[[TreeContext], Point | None], tolerance_m: float) -> None:
        super().__init__(name, ctx, target)
        self.tolerance_m = tolerance_m

    def post(self, point: Point) -> None:
        v = self.ctx.config.creep_speed
        self.ctx.want("STATION_UPDATES",
                      f"station_pt={moos_xy(point)} # outer_speed={v:.2f} # transit_speed={v:.2f}")

    def tolerance(self) -> float:
        return self.tolerance_m


class Face(Leaf):
    """Turn in place to a heading and hold still (helm FACE). SUCCESS once within
    ``heading_tolerance_deg``; with ``hold`` it keeps RUNNING (holding the heading)."""

    def __init__(self, name: str, ctx: TreeContext,
                 heading: Callable[[TreeContext], float | None],
                 depth: Callable[[TreeContext], float] | None = None, hold: bool = False,
                 tolerance_deg: float | None = None) -> None:
        super().__init__(name, ctx)
        self.heading = heading
        self.depth = depth
        self.hold = hold
        self.tolerance_deg = tolerance_deg or ctx.config.heading_tolerance_deg

    def update(self) -> Status:
        h = self.heading(self.ctx)
        if h is None:
            return Status.FAILURE
        self.ctx.want("ASSIST_MODE", "FACE")
        self.ctx.want("HEADING_UPDATES", f"heading={round(h) % 360}")
        if self.depth is not None:
            self.ctx.want("DEPTH_UPDATES", _depth(self.depth(self.ctx)))
        error = abs(float(wrap_180(self.ctx.now.rov.heading_deg - h)))
        if not self.hold and error <= self.tolerance_deg:
            return Status.SUCCESS
        return Status.RUNNING


class HoldAt(Leaf):
    """Keep station at a point facing a heading, for good: FACE while within
    ``redrive_m`` of it, else drive back — APPROACH when it is within 1 m, GOTO (the way
    round the diver) when it has moved farther (he turned: his front is elsewhere)."""

    def __init__(self, name: str, ctx: TreeContext,
                 point: Callable[[TreeContext], Point | None],
                 heading: Callable[[TreeContext], float | None]) -> None:
        super().__init__(name, ctx)
        self.point = point
        self.approach = Approach(f"{name}: back", ctx, point,
                                 ctx.config.position_tolerance_m / 3.0)
        self.transit = GoTo(f"{name}: round", ctx, point, ctx.config.near_speed)
        self.face = Face(f"{name}: face", ctx, heading,
                         lambda c: float(p[2]) if (p := point(c)) is not None else 0.0, hold=True)
        self._drive: Drive | None = None

    def initialise(self) -> None:
        self._drive = None

    def update(self) -> Status:
        p = self.point(self.ctx)
        if p is None:
            return Status.FAILURE
        off = float(np.linalg.norm((p - self.ctx.rov)[:2]))
        if self._drive is None and off > self.ctx.config.redrive_m:
            self._drive = self.transit if off > 1.0 else self.approach
            self._drive.initialise()
        if self._drive is self.transit and off <= 1.0:
            self._drive = self.approach
            self._drive.initialise()
        if self._drive is not None and self._drive.update() == Status.SUCCESS:
            self._drive = None
        if self._drive is None:
            self.face.update()
        return Status.RUNNING


class Follow(Leaf):
    """Trail the diver (helm FOLLOW: BHV_Trail) at ``follow_range_m``, at his depth."""

    def update(self) -> Status:
        diver = self.ctx.diver
        if diver is None:
            return Status.FAILURE
        self.ctx.want("ASSIST_MODE", "FOLLOW")
        self.ctx.want("TRAIL_UPDATES", f"trail_range={self.ctx.config.follow_range_m:g}")
        self.ctx.want("DEPTH_UPDATES", _depth(diver.position_ned[2]))
        return Status.RUNNING


class BackOff(Leaf):
    """Back away from ``source`` (a diver), facing it: the helm is parked
    (MOOS_MANUAL_OVERRIDE) and DESIRED_* posted here — astern at ``backoff_speed`` plus
    the diver's closing speed (at most ``cruise_speed``) × cos(heading error), so every
    moment's motion opens the range. SUCCESS once
    ``done(ctx)``."""

    def __init__(self, name: str, ctx: TreeContext,
                 source: Callable[[TreeContext], DiverTrack | None],
                 done: Callable[[TreeContext], bool]) -> None:
        super().__init__(name, ctx)
        self.source = source
        self.done = done

    def update(self) -> Status:
        diver = self.source(self.ctx)
        if diver is None:
            return Status.FAILURE
        if self.done(self.ctx):
            return Status.SUCCESS
        rov = self.ctx.now.rov
        cfg = self.ctx.config
        speed = min(cfg.cruise_speed, cfg.backoff_speed
                    + max(0.0, closing_speed(rov.position_ned, diver)))
        drive_facing(self.ctx, diver.position_ned, -speed, float(rov.position_ned[2]))
        return Status.RUNNING


def drive_facing(ctx: TreeContext, point: Point, speed: float, depth: float) -> None:
    """Park the helm (MOOS_MANUAL_OVERRIDE) and post DESIRED_*: facing ``point`` (NED),
    ``speed`` (m/s; < 0 astern) × cos(heading error), so that the motion is along the
    line to it, at ``depth`` (m)."""
    rov = ctx.now.rov
    facing = bearing_deg(rov.position_ned, point)
    error = math.radians(float(wrap_180(rov.heading_deg - facing)))
    ctx.override = True
    ctx.want("DESIRED_HEADING", round(facing, 1))
    ctx.want("DESIRED_SPEED", round(speed * math.cos(error), 3))
    ctx.want("DESIRED_DEPTH", round(depth, 2))


class Gripper(Leaf):
    """Open or close the gripper and wait for it: SUCCESS when open, or closed on an
    object; FAILURE when it closed on nothing (a missed grasp)."""

    def __init__(self, name: str, ctx: TreeContext, close: bool) -> None:
        super().__init__(name, ctx)
        self.close = close

    def update(self) -> Status:
        g = self.ctx.now.gripper
        command = "close" if self.close else "open"
        self.ctx.gripper_command = command
        self.ctx.want("GRIPPER_CMD", command)
        if not self.close:
            return Status.SUCCESS if g.phase == "open" else Status.RUNNING
        if g.phase != "closed":
            return Status.RUNNING
        if g.holding is None:
            self.ctx.event("grasp missed: the gripper closed on nothing")
            return Status.FAILURE
        return Status.SUCCESS


class WaitUntil(Leaf):
    """Hold still (FACE at the heading held when the wait began) until ``predicate``
    (SUCCESS) or ``timeout_s`` of simulation time (FAILURE)."""

    def __init__(self, name: str, ctx: TreeContext,
                 predicate: Callable[[TreeContext], bool], timeout_s: float) -> None:
        super().__init__(name, ctx)
        self.predicate = predicate
        self.timeout_s = timeout_s
        self._start = 0.0
        self._heading = 0.0

    def initialise(self) -> None:
        self._start = self.ctx.t
        self._heading = self.ctx.now.rov.heading_deg

    def update(self) -> Status:
        if self.predicate(self.ctx):
            return Status.SUCCESS
        if self.ctx.t - self._start > self.timeout_s:
            self.ctx.event(f"{self.name}: gave up after {self.timeout_s:g} s")
            return Status.FAILURE
        self.ctx.want("ASSIST_MODE", "FACE")
        self.ctx.want("HEADING_UPDATES", f"heading={round(self._heading) % 360}")
        return Status.RUNNING


class SpeedCeiling(Leaf):
    """Every tick: the helm's speed ceiling — ``near_speed`` while the ROV is within
    ``slow_radius_m`` + ``slow_lead_m`` of the diver's body or head (the lead lets it slow
    down before it is inside), else ``cruise_speed``; at most ``carry_speed`` while it
    holds something. Always SUCCESS."""

    def update(self) -> Status:
        cfg = self.ctx.config
        diver = self.ctx.diver or self.ctx.last_diver
        near = diver is not None and min(separations(self.ctx.rov, diver)) < (
            cfg.slow_radius_m + cfg.slow_lead_m)
        limit = self.ctx.transit_speed(cfg.near_speed if near else cfg.cruise_speed)
        self.ctx.want("MAXSPEED_UPDATES", f"max_speed={limit:.2f}")
        return Status.SUCCESS


class AskAgain(Leaf):
    """Whether to ask "say again?": idle, with the diver hovering (below ``STILL_SPEED``)
    within ``ask_range_m`` and 45° of its heading, and no command taken for
    ``ask_after_s`` (counted from when it was last busy or last asked). At most
    ``ask_max`` asks in a row without a command taken while he hovers (he swims off:
    counted anew). SUCCESS from then on while the ask is under way — the ROV closing in
    to arm's reach first (he need not face the ROV then), then :class:`CueAgain` — and
    while he still hovers in range; else FAILURE (the hold goes on)."""

    STILL_SPEED = 0.1  # m/s

    def __init__(self, name: str, ctx: TreeContext) -> None:
        super().__init__(name, ctx)
        self._quiet_since: float | None = None
        self._last_tick = -math.inf
        self._asked_t = -math.inf
        self.asks = 0
        self.pending = False  # an ask is under way

    def _waits(self) -> bool:
        """He hovers within range (before the ROV, unless an ask is under way)."""
        d, cfg = self.ctx.diver, self.ctx.config
        if d is None or abs(d.speed) > self.STILL_SPEED:
            return False
        off = d.position_ned - self.ctx.rov
        bearing = bearing_deg(self.ctx.rov, d.position_ned)
        return (math.hypot(off[0], off[1]) <= cfg.ask_range_m
                and (self.pending or
                     abs(float(wrap_180(bearing - self.ctx.now.rov.heading_deg))) <= 45.0))

    def quiet_s(self) -> float:
        """Seconds since anything was read (or it was busy, or last asked)."""
        return self.ctx.t - (self._quiet_since if self._quiet_since is not None else self.ctx.t)

    def update(self) -> Status:
        ctx, cfg = self.ctx, self.ctx.config
        busy = ctx.t - self._last_tick > 1.0  # not ticked: a task or a guard had the ROV
        self._last_tick = ctx.t
        if not self._waits():  # he swims off (or is out of range): asked anew next time
            self._quiet_since, self.asks, self.pending = None, 0, False
            return Status.FAILURE
        if self.pending:
            return Status.SUCCESS
        if self._quiet_since is None or busy:
            self._quiet_since = ctx.t
        self._quiet_since = max(self._quiet_since, ctx.heard_t)
        if ctx.heard_t > self._asked_t:
            self.asks = 0
        if self.asks >= cfg.ask_max or ctx.t - self._quiet_since < cfg.ask_after_s:
            return Status.FAILURE
        self.asks += 1
        self._asked_t = ctx.t
        self.pending = True
        return Status.SUCCESS

    def asked(self) -> None:
        """The cue was shown: quiet counted from now."""
        self.pending, self._quiet_since = False, self.ctx.t

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.pending:  # a guard or a task cut it short
            self.pending, self._quiet_since = False, None


class CueAgain(Leaf):
    """The "say again?" cue of an :class:`AskAgain` under way: the ROV swings its lamps
    ``wag_deg`` off him and back, twice (FACE; a flicker in his face), and says so (event
    "say again? ..."). RUNNING while it wags, then FAILURE (the hold goes on)."""

    WAG_STEP_S = 1.5  # at most this long on each swing (s)

    def __init__(self, name: str, ctx: TreeContext, ask: AskAgain) -> None:
        super().__init__(name, ctx)
        self.ask = ask
        self._swings: list[float] = []  # the headings still to turn to (deg)
        self._swing_t = 0.0

    def initialise(self) -> None:
        ctx, cfg = self.ctx, self.ctx.config
        d = ctx.diver
        assert d is not None
        facing = bearing_deg(ctx.rov, d.position_ned)
        self._swings = [facing + cfg.wag_deg, facing - cfg.wag_deg, facing + cfg.wag_deg,
                        facing - cfg.wag_deg, facing]
        self._swing_t = ctx.t
        ctx.event(f"say again? (nothing read for {self.ask.quiet_s():.0f} s, the "
                  f"diver hovering {math.hypot(*(d.position_ned - ctx.rov)[:2]):.1f} m "
                  f"ahead; ask {self.ask.asks} of {cfg.ask_max})")

    def update(self) -> Status:
        ctx = self.ctx
        error = abs(float(wrap_180(ctx.now.rov.heading_deg - self._swings[0])))
        if error <= ctx.config.heading_tolerance_deg or ctx.t - self._swing_t > self.WAG_STEP_S:
            self._swings.pop(0)
            self._swing_t = ctx.t
            if not self._swings:
                self.ask.asked()
                return Status.FAILURE
        ctx.asking = True
        ctx.want("ASSIST_MODE", "FACE")
        ctx.want("HEADING_UPDATES", f"heading={round(self._swings[0]) % 360}")
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self._swings = []
