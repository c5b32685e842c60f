"""BHV_Loiter: loop the vertices of a convex polygon.

reference/helm.md. Course: ZAIC peak at the bearing to the next vertex (pw 0, bw 180,
wrap: linear to zero at +-180 deg); speed: peak at ``speed`` (pw 0, bw 0.3, a triangle);
coupled 50/50 and normalised to 0..100. Vertices advance on ``capture_radius`` or by slip
(``slip_radius``). When the vehicle is farther than ``acquire_dist`` from the polygon
(distance to its boundary, 0 inside) it is in *acquire mode*: each tick it re-picks the
vertex to approach (below). ``clockwise = true | false | best``.

Acquire vertex (our rule, IvP's LoiterEngine is not in the reference note): the vertex k
and, for ``best``, the direction minimising ``|a| (1 + (1 - cos e) + 0.5 (1 - cos h))``
where a = own->vertex, e = angle between a and the onward edge from vertex k, h = angle
between a and own heading: close vertices whose onward edge continues the approach.

Parameters (IvP names): polygon, speed, clockwise (true), capture_radius (3; alias
``radius``), slip_radius (15; alias ``nm_radius``), acquire_dist (10), post_suffix
(appended as ``_SUFFIX`` to the variables it posts), center_activate (false: on becoming
running, move the polygon's centre to the vehicle), center_assign ("x,y" or
"present_position"), xcenter_assign, ycenter_assign. Posts LOITER_INDEX and
LOITER_ACQUIRE on change, and the polygon as VIEW_POLYGON
(``pts={x,y:...},label=<name>``, pMarineViewer style) when it changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.behaviors.waypoint_engine import ArrivalTracker, course_speed_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import bearing_deg, dist_to_polygon, distance, parse_polygon
from uhrisim.autonomy.params import setter, to_bool, to_float, to_point, to_str
from uhrisim.core.errors import ConfigError

Point = tuple[float, float]


def _clockwise(v: object, key: str, where: str) -> str:
    s = to_str(v, key, where).lower()
    if s not in ("true", "false", "best"):
        raise ConfigError(f"{key} must be true, false or best, got {v!r}", where)
    return s


def _center(v: object, key: str, where: str) -> Point | str:
    s = to_str(v, key, where) if not isinstance(v, list | tuple) else v
    if isinstance(s, str) and s.lower() == "present_position":
        return "present_position"
    return to_point(s, key, where)


def centroid(pts: tuple[Point, ...]) -> Point:
    return (sum(p[0] for p in pts) / len(pts), sum(p[1] for p in pts) / len(pts))


def shift(pts: tuple[Point, ...], cx: float, cy: float) -> tuple[Point, ...]:
    ox, oy = centroid(pts)
    return tuple((x - ox + cx, y - oy + cy) for x, y in pts)


@dataclass(frozen=True)
class LoiterParams:
    polygon: tuple[Point, ...] = ()
    speed: float = 0.0
    clockwise: str = "true"
    capture_radius: float = 3.0
    slip_radius: float = 15.0
    acquire_dist: float = 10.0
    center_activate: bool = False
    center_assign: Point | str | None = None
    post_suffix: str = ""


def _polygon(v: object, key: str, where: str) -> tuple[Point, ...]:
    return parse_polygon(v, key, where)


def _xcenter(p: LoiterParams, v: object, key: str, where: str) -> LoiterParams:
    cy = centroid(p.polygon)[1] if p.polygon else 0.0
    return replace(p, center_assign=(to_float(v, key, where), cy))


def _ycenter(p: LoiterParams, v: object, key: str, where: str) -> LoiterParams:
    cx = centroid(p.polygon)[0] if p.polygon else 0.0
    return replace(p, center_assign=(cx, to_float(v, key, where)))


class Loiter(Behavior):
    KIND = "BHV_Loiter"
    Params = LoiterParams
    REQUIRED = ("polygon",)
    HANDLERS: ClassVar[dict] = {
        "polygon": setter("polygon", _polygon),
        "speed": setter("speed", to_float),
        "clockwise": setter("clockwise", _clockwise),
        "capture_radius": setter("capture_radius", to_float),
        "radius": setter("capture_radius", to_float),
        "slip_radius": setter("slip_radius", to_float),
        "nm_radius": setter("slip_radius", to_float),
        "post_suffix": setter("post_suffix", to_str),
        "acquire_dist": setter("acquire_dist", to_float),
        "center_activate": setter("center_activate", to_bool),
        "center_assign": setter("center_assign", _center),
        "xcenter_assign": _xcenter,
        "ycenter_assign": _ycenter,
    }

    def reset(self) -> None:
        p: LoiterParams = self.params
        self.vertices: tuple[Point, ...] = p.polygon
        if isinstance(p.center_assign, tuple) and p.polygon:
            self.vertices = shift(p.polygon, *p.center_assign)
        self.index: int | None = None
        self.direction = -1 if p.clockwise == "false" else 1
        self.acquire_mode = True
        self.arrival = ArrivalTracker(p.capture_radius, p.slip_radius)
        self.laps = 0
        self._pending_center_here = p.center_assign == "present_position"
        self._posted: tuple[int | None, bool] | None = None
        self._posted_poly: tuple[Point, ...] | None = None

    def on_params_changed(self, key: str) -> None:
        p: LoiterParams = self.params
        if key in ("polygon", "center_assign", "xcenter_assign", "ycenter_assign", "clockwise"):
            self.reset()
        elif key in ("capture_radius", "slip_radius", "radius", "nm_radius"):
            self.arrival = ArrivalTracker(p.capture_radius, p.slip_radius)

    def on_run_start(self, ctx: BehaviorContext) -> None:
        if self.params.center_activate:
            self._pending_center_here = True

    def acquire(self, x: float, y: float, heading: float) -> tuple[int, int]:
        """(vertex index, direction +1 clockwise / -1 counter-clockwise) to approach."""
        p: LoiterParams = self.params
        dirs = [1, -1] if p.clockwise == "best" else [self.direction]
        vs, n = self.vertices, len(self.vertices)
        hx, hy = math.sin(math.radians(heading)), math.cos(math.radians(heading))
        best: tuple[float, int, int] | None = None
        for d in dirs:
            for k in range(n):
                ax, ay = vs[k][0] - x, vs[k][1] - y
                L = math.hypot(ax, ay)
                if L < 1e-9:
                    cost = 0.0
                else:
                    ex, ey = vs[(k + d) % n][0] - vs[k][0], vs[(k + d) % n][1] - vs[k][1]
                    cos_e = (ax * ex + ay * ey) / (L * max(math.hypot(ex, ey), 1e-12))
                    cos_h = (ax * hx + ay * hy) / L
                    cost = L * (1.0 + (1.0 - cos_e) + 0.5 * (1.0 - cos_h))
                if best is None or cost < best[0] - 1e-9:
                    best = (cost, k, d)
        assert best is not None
        return best[1], best[2]

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: LoiterParams = self.params
        own = ctx.own
        if own is None or not self.vertices:
            return None
        if self._pending_center_here:
            self.vertices = shift(self.vertices, own.x, own.y)
            self._pending_center_here = False
            self.index = None
        n = len(self.vertices)
        acquire = dist_to_polygon(own.x, own.y, self.vertices) > p.acquire_dist
        if acquire or self.index is None:
            k, d = self.acquire(own.x, own.y, own.heading)
            if k != self.index:
                self.arrival.reset()
            self.index, self.direction = k, d
        self.acquire_mode = acquire
        tx, ty = self.vertices[self.index]
        if self.arrival.arrived(distance(own.x, own.y, tx, ty)):
            self.index = (self.index + self.direction) % n
            if self.index == 0:
                self.laps += 1
            self.arrival.reset()
            tx, ty = self.vertices[self.index]
            self.arrival.arrived(distance(own.x, own.y, tx, ty))
        if self._posted_poly != self.vertices:
            pts = ":".join(f"{x:.2f},{y:.2f}" for x, y in self.vertices)
            ctx.post("VIEW_POLYGON", f"pts={{{pts}}},label={self.name}")
            self._posted_poly = self.vertices
        state = (self.index, self.acquire_mode)
        if state != self._posted:
            sfx = f"_{p.post_suffix.upper()}" if p.post_suffix else ""
            ctx.post(f"LOITER_INDEX{sfx}", float(self.index))
            ctx.post(f"LOITER_ACQUIRE{sfx}", "true" if self.acquire_mode else "false")
            self._posted = state
        crs = bearing_deg(own.x, own.y, tx, ty)
        return course_speed_objective(ctx, crs, p.speed, (0.0, 0.3, 0.0))
