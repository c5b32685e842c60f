"""BHV_Waypoint: visit a list of points.

Course: ZAIC peak at the bearing to the steering point (pw 0, bw 180, wrap); speed: ZAIC
peak at ``speed`` with IvP's waypoint shape (pw 0.5, bw 1.0, summitdelta 0.8, as recalled
from IvP BHV_Waypoint; not in the reference note); coupled 50/50, normalised 0..100.

Parameters (IvP names): points ("x1,y1:x2,y2", "pts={...}"), point (one point), speed,
capture_radius (3), slip_radius (15), lead (-1 = off: steer at the point; > 0: steer at
the point ``lead`` metres ahead of the vehicle's projection on the track line from the
previous point, never past the next point), repeat (0: extra passes over the list),
order (normal | reverse), wptflag (posted on each point reached), cycleflag (posted at
the end of each pass over the list). When the last point is reached (after ``repeat``
extra passes) the behavior completes (endflags); ``perpetual = true`` starts over.
Posts WPT_INDEX, and the route as VIEW_SEGLIST (``pts={x,y:...},label=<name>``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.behaviors.waypoint_engine import ArrivalTracker, course_speed_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import bearing_deg, distance
from uhrisim.autonomy.params import Flag, parse_flag, setter, to_float, to_point, to_points, to_str
from uhrisim.core.errors import ConfigError

Point = tuple[float, float]


def _order(v: object, key: str, where: str) -> str:
    s = to_str(v, key, where).lower()
    if s not in ("normal", "reverse"):
        raise ConfigError(f"{key} must be normal or reverse, got {v!r}", where)
    return s


def _repeat(v: object, key: str, where: str) -> int:
    x = to_float(v, key, where)
    if x < 0 or x != int(x):
        raise ConfigError(f"{key} must be a whole number >= 0, got {v!r}", where)
    return int(x)


def _add_flag(field: str):
    def apply(p: WaypointParams, v: object, key: str, where: str) -> WaypointParams:
        vals = v if isinstance(v, list | tuple) else [v]
        new = tuple(parse_flag(x, key, where) for x in vals)
        return replace(p, **{field: getattr(p, field) + new})

    return apply


def _point(p: WaypointParams, v: object, key: str, where: str) -> WaypointParams:
    return replace(p, points=(to_point(v, key, where),))


@dataclass(frozen=True)
class WaypointParams:
    points: tuple[Point, ...] = ()
    speed: float = 0.0
    capture_radius: float = 3.0
    slip_radius: float = 15.0
    lead: float = -1.0
    repeat: int = 0
    order: str = "normal"
    wptflags: tuple[Flag, ...] = ()
    cycleflags: tuple[Flag, ...] = ()


class Waypoint(Behavior):
    KIND = "BHV_Waypoint"
    Params = WaypointParams
    REQUIRED = ("points",)
    HANDLERS: ClassVar[dict] = {
        "points": setter("points", to_points),
        "point": _point,
        "speed": setter("speed", to_float),
        "capture_radius": setter("capture_radius", to_float),
        "slip_radius": setter("slip_radius", to_float),
        "lead": setter("lead", to_float),
        "repeat": setter("repeat", _repeat),
        "order": setter("order", _order),
        "wptflag": _add_flag("wptflags"),
        "cycleflag": _add_flag("cycleflags"),
    }

    def reset(self) -> None:
        p: WaypointParams = self.params
        self.route = tuple(reversed(p.points)) if p.order == "reverse" else p.points
        self.index = 0
        self.passes = 0
        self.previous: Point | None = None
        self.arrival = ArrivalTracker(p.capture_radius, p.slip_radius)
        self.finished = False
        self._posted: int | None = None

    def on_params_changed(self, key: str) -> None:
        if key in ("points", "point", "order", "capture_radius", "slip_radius"):
            self.reset()

    def on_run_start(self, ctx: BehaviorContext) -> None:
        if self.previous is None and ctx.own is not None:
            self.previous = (ctx.own.x, ctx.own.y)

    def steer_point(self, x: float, y: float) -> Point:
        """Point to steer at: the waypoint, or the track-line lead point (``lead`` > 0)."""
        p: WaypointParams = self.params
        tx, ty = self.route[self.index]
        if p.lead <= 0 or self.previous is None:
            return tx, ty
        ax, ay = self.previous
        dx, dy = tx - ax, ty - ay
        L = math.hypot(dx, dy)
        if L < 1e-9:
            return tx, ty
        s = ((x - ax) * dx + (y - ay) * dy) / L + p.lead
        if s >= L:
            return tx, ty
        return ax + dx * s / L, ay + dy * s / L

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: WaypointParams = self.params
        own = ctx.own
        if own is None or not self.route:
            return None
        if self.finished:
            if not self.common.perpetual:
                return None
            self.reset()
            self.previous = (own.x, own.y)
        if self.previous is None:
            self.previous = (own.x, own.y)
        while True:
            tx, ty = self.route[self.index]
            if not self.arrival.arrived(distance(own.x, own.y, tx, ty)):
                break
            self.previous = (tx, ty)
            self.arrival.reset()
            for f in p.wptflags:
                ctx.post(*f)
            if self.index + 1 < len(self.route):
                self.index += 1
                continue
            for f in p.cycleflags:
                ctx.post(*f)
            if self.passes < p.repeat:
                self.passes += 1
                self.index = 0
            else:
                self.finished = True
                self.complete()
                return None
        if self._posted is None:
            pts = ":".join(f"{x:.2f},{y:.2f}" for x, y in self.route)
            ctx.post("VIEW_SEGLIST", f"pts={{{pts}}},label={self.name}")
        if self.index != self._posted:
            ctx.post("WPT_INDEX", float(self.index))
            self._posted = self.index
        sx, sy = self.steer_point(own.x, own.y)
        return course_speed_objective(ctx, bearing_deg(own.x, own.y, sx, sy), p.speed,
                                      (0.5, 1.0, 0.8))  # fmt: skip
