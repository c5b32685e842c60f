"""BHV_Waypoint: visit a list of points.

Objective (IvP ``BHV_Waypoint::buildOF``, zaic method, BHV_Waypoint.cpp:854-878): course
= SUM of two ZAIC peak components - at the bearing to the steering point, unrounded (pw
0, bw 180, max 100, wrap) and a small heading-hold component at the current heading (pw
30, bw 180, delta 5, max 20) - as ``extractIvPFunction(false)`` sums them
(ZAIC_PEAK.cpp:236-252); speed = ZAIC peak at ``speed`` (pw speed/2, bw 1.6, delta 20);
coupled 50/50, normalised 0..100. The heading-hold part moves the rounding of a bearing
between two whole degrees toward the current heading (e.g. bearing 45.55 deg, heading
0: course 45, not 46).

Parameters (IvP names): points ("x1,y1:x2,y2", "pts={...}"), point (one point), speed,
capture_radius (3; alias ``radius``), slip_radius (15; alias ``nm_radius``), lead (-1 =
off; >= 0: steer at the point ``lead`` metres along the track line beyond the vehicle's
perpendicular foot on it, never past the next point; the track line runs from the
previous point, or the last point after a full pass, or the position where the behavior
started when ``lead_to_start = true``), lead_damper (-1 = off; > 0: the lead distance
grows up to 3x as the vehicle closes within lead_damper of the track line), repeat (0:
extra passes over the list), order (normal | reverse), wptflag (posted on each point
reached; $[X], $[Y] expand to it), cycleflag (posted at the end of each pass),
post_suffix. When the last point is reached (after ``repeat`` extra passes) the behavior
completes (endflags); ``perpetual = true`` starts over. Posts WPT_INDEX, and the route as
VIEW_SEGLIST (``pts={x,y:...},label=<name>``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.behaviors.waypoint_engine import ArrivalTracker
from uhrisim.autonomy.coupler import coupled_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import bearing_deg, distance
from uhrisim.autonomy.params import (
    Flag,
    one_of,
    parse_flag,
    setter,
    to_bool,
    to_float,
    to_point,
    to_points,
    to_str,
)
from uhrisim.autonomy.zaic import zaic_peak_on_axis
from uhrisim.core.errors import ConfigError

Point = tuple[float, float]


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
    """BHV_Waypoint parameters (IvP names and defaults; module docstring).

    Points are MOOS local (x east, y north), m; ``speed`` m/s; ``capture_radius``,
    ``slip_radius``, ``lead``, ``lead_damper`` m (-1 = off); ``repeat`` extra passes;
    ``order`` "normal" | "reverse"; flags are (MOOS variable, value) pairs.
    """

    points: tuple[Point, ...] = ()
    speed: float = 0.0
    capture_radius: float = 3.0
    slip_radius: float = 15.0
    lead: float = -1.0
    lead_damper: float = -1.0
    lead_to_start: bool = False
    repeat: int = 0
    order: str = "normal"
    post_suffix: str = ""
    wptflags: tuple[Flag, ...] = ()
    cycleflags: tuple[Flag, ...] = ()


class Waypoint(Behavior):
    KIND = "BHV_Waypoint"
    Params = WaypointParams
    HANDLERS: ClassVar[dict] = {
        "points": setter("points", to_points),
        "point": _point,
        "speed": setter("speed", to_float),
        "capture_radius": setter("capture_radius", to_float),
        "radius": setter("capture_radius", to_float),
        "slip_radius": setter("slip_radius", to_float),
        "nm_radius": setter("slip_radius", to_float),
        "post_suffix": setter("post_suffix", to_str),
        "lead": setter("lead", to_float),
        "lead_damper": setter("lead_damper", to_float),
        "lead_to_start": setter("lead_to_start", to_bool),
        "repeat": setter("repeat", _repeat),
        "order": setter("order", one_of("normal", "reverse")),
        "wptflag": _add_flag("wptflags"),
        "cycleflag": _add_flag("cycleflags"),
    }

    def reset(self) -> None:
        p: WaypointParams = self.params
        self.route = tuple(reversed(p.points)) if p.order == "reverse" else p.points
        self.index = 0
        self.passes = 0
        self.start_mark: Point | None = None
        self.arrival = ArrivalTracker(p.capture_radius, p.slip_radius)
        self.finished = False
        self._posted: int | None = None

    def on_params_changed(self, key: str) -> None:
        if key in ("points", "point", "order", "capture_radius", "slip_radius", "radius",
                   "nm_radius"):  # fmt: skip
            self.reset()

    def on_run_start(self, ctx: BehaviorContext) -> None:
        if self.start_mark is None and ctx.own is not None:
            self.start_mark = (ctx.own.x, ctx.own.y)

    def anchor(self) -> Point | None:
        """Start of the current track line (None: no track line, steer at the point)."""
        if self.index > 0:
            return self.route[self.index - 1]
        if self.passes > 0:
            return self.route[-1]
        return self.start_mark if self.params.lead_to_start else None

    def steer_point(self, x: float, y: float) -> Point:
        """Point to steer at: the waypoint, or the track-line lead point (``lead`` >= 0)."""
        p: WaypointParams = self.params
        tx, ty = self.route[self.index]
        anchor = self.anchor()
        if p.lead < 0 or anchor is None:
            return tx, ty
        ax, ay = anchor
        dx, dy = tx - ax, ty - ay
        L = math.hypot(dx, dy)
        if L < 1e-9:
            return tx, ty
        ux, uy = dx / L, dy / L
        s_along = min(max((x - ax) * ux + (y - ay) * uy, 0.0), L)
        fx, fy = ax + s_along * ux, ay + s_along * uy  # perpendicular foot on the segment
        damper = 1.0
        if p.lead_damper > 0:
            off = math.hypot(x - fx, y - fy)
            if off < p.lead_damper:
                damper += 2.0 * (1.0 - off / p.lead_damper)
        step = min(L - s_along, p.lead * damper)
        return fx + step * ux, fy + step * uy

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: WaypointParams = self.params
        own = ctx.own
        if not self.route:  # pHelmIvP loads it, then idles (BHV_Waypoint.cpp:173-176)
            ctx.post("BHV_WARNING", f"{self.name}: No waypts given")
            return None
        if own is None:
            return None
        if self.finished:
            if not self.common.perpetual:
                return None
            self.reset()
        if self.start_mark is None:
            self.start_mark = (own.x, own.y)
        while True:
            tx, ty = self.route[self.index]
            if not self.arrival.arrived(distance(own.x, own.y, tx, ty)):
                break
            self.arrival.reset()
            for var, val in p.wptflags:
                if isinstance(val, str):
                    val = val.replace("$[X]", f"{tx:.2f}").replace("$[Y]", f"{ty:.2f}")
                ctx.post(var, val)
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
            sfx = f"_{p.post_suffix.upper()}" if p.post_suffix else ""
            ctx.post(f"WPT_INDEX{sfx}", float(self.index))
            self._posted = self.index
        sx, sy = self.steer_point(own.x, own.y)
        crs = ctx.domain.axis("course")
        fc = zaic_peak_on_axis(crs, bearing_deg(own.x, own.y, sx, sy), 0.0, 180.0, 50.0)
        fc += zaic_peak_on_axis(crs, own.heading, 30.0, 180.0, 5.0, 0.0, 20.0)
        fs = zaic_peak_on_axis(ctx.domain.axis("speed"), p.speed, p.speed / 2.0, 1.6, 20.0)
        return coupled_objective(ctx.domain, fc, fs)
