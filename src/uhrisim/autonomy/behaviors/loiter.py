"""BHV_Loiter: loop the vertices of a convex polygon.

docs/reference/helm.md. Course: ZAIC peak at the bearing to the next vertex (pw 0, bw 180,
wrap: linear to zero at +-180 deg); speed: peak at ``speed`` (pw 0, bw 0.3, a triangle);
coupled ``patience`` / 100 - ``patience`` (default 50/50; BHV_Loiter.cpp:532) and
normalised to 0..100. Vertices are snapped to 0.1 m (as pHelmIvP does). Vertices advance
on ``capture_radius`` or by slip (``slip_radius``). As in pHelmIvP (BHV_Loiter.cpp:
270-310), the loiter starts at vertex 0; it picks the vertex to approach (below) when it
goes from idle to running, and each tick while it is farther than ``acquire_dist``
outside the polygon (*acquire mode*). ``clockwise = true | false | best``.

Acquire vertex (IvP ``LoiterEngine`` semantics, re-implemented; docs/reference/helm.md is
silent). With turn(k) = the signed turn (deg, right/clockwise positive) from the approach
own -> vertex k onto the onward edge k -> k+dir:

* outside the polygon: among the vertices visible from the vehicle (the sight line
  crosses no edge), clockwise takes the largest turn(k), counter-clockwise the smallest
  (the gentle entry onto the onward edge);
* inside: the smallest |turn(k)|, with a 2 deg bonus for the vertex nearest the current
  heading (IvP's default spiral factor);
* ``clockwise = best`` (outside only): the direction whose acquired vertex needs the
  smaller turn from the current heading.

Parameters (IvP names): polygon, speed, clockwise (true), capture_radius (3; alias
``radius``), slip_radius (15; alias ``nm_radius``), acquire_dist (10), post_suffix
(appended as ``_SUFFIX`` to the variables it posts), patience (50, in [1, 99]: the
course's share of the coupling), center_activate (false: on becoming
running, move the polygon's centre to the vehicle), center_assign ("x,y" or
"present_position"), xcenter_assign, ycenter_assign. Posts LOITER_INDEX and
LOITER_ACQUIRE on change, and the polygon as VIEW_POLYGON
(``pts={x,y:...},label=<name>``, pMarineViewer style) when it changes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.behaviors.waypoint_engine import ArrivalTracker, course_speed_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import (
    bearing_deg,
    distance,
    parse_polygon,
    point_in_polygon,
    signed_dist_to_polygon,
    snap_to_step,
)
from uhrisim.autonomy.params import (
    one_of,
    setter,
    to_bool,
    to_float,
    to_point_or_present,
    to_str,
)
from uhrisim.autonomy.zaic import ZaicMemo
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import wrap_180

Point = tuple[float, float]


_CROSS_EPS = 1e-9  # m^2: |cross product| below this is "touching", not crossing


def centroid(pts: tuple[Point, ...]) -> Point:
    return (sum(p[0] for p in pts) / len(pts), sum(p[1] for p in pts) / len(pts))


def shift(pts: tuple[Point, ...], cx: float, cy: float) -> tuple[Point, ...]:
    ox, oy = centroid(pts)
    return tuple((x - ox + cx, y - oy + cy) for x, y in pts)


@dataclass(frozen=True)
class LoiterParams:
    """BHV_Loiter parameters (IvP names and defaults; module docstring).

    ``polygon`` vertices MOOS local (x east, y north), m; ``speed`` m/s; ``clockwise``
    "true" | "false" | "best"; ``capture_radius``, ``slip_radius``, ``acquire_dist`` m;
    ``center_assign`` a point (m) or "present_position".
    """

    polygon: tuple[Point, ...] = ()
    speed: float = 0.0
    clockwise: str = "true"
    capture_radius: float = 3.0
    slip_radius: float = 15.0
    acquire_dist: float = 10.0
    center_activate: bool = False
    center_assign: Point | str | None = None
    post_suffix: str = ""
    patience: float = 50.0


VERTEX_SNAP_M = 0.1
#: The speed ZAIC of BHV_Loiter: (peakwidth, basewidth, summitdelta), m/s.
LOITER_SPEED_ZAIC = (0.0, 0.3, 0.0)


def _polygon(v: object, key: str, where: str) -> tuple[Point, ...]:
    """A convex polygon, its vertices snapped to 0.1 m as pHelmIvP always does
    (BHV_Loiter.cpp:104: the bearings to the vertices follow from the snapped points)."""
    return tuple(
        (snap_to_step(x, VERTEX_SNAP_M), snap_to_step(y, VERTEX_SNAP_M))
        for x, y in parse_polygon(v, key, where)
    )


def _patience(v: object, key: str, where: str) -> float:
    x = to_float(v, key, where)
    if not 1.0 <= x <= 99.0:
        raise ConfigError(f"{key} must be in [1, 99], got {v!r}", where)
    return x


def _xcenter(p: LoiterParams, v: object, key: str, where: str) -> LoiterParams:
    cy = centroid(p.polygon)[1] if p.polygon else 0.0
    return replace(p, center_assign=(to_float(v, key, where), cy))


def _ycenter(p: LoiterParams, v: object, key: str, where: str) -> LoiterParams:
    cx = centroid(p.polygon)[0] if p.polygon else 0.0
    return replace(p, center_assign=(cx, to_float(v, key, where)))


class Loiter(Behavior):
    KIND = "BHV_Loiter"
    Params = LoiterParams
    HANDLERS: ClassVar[dict] = {
        "polygon": setter("polygon", _polygon),
        "speed": setter("speed", to_float),
        "clockwise": setter("clockwise", one_of("true", "false", "best")),
        "capture_radius": setter("capture_radius", to_float),
        "radius": setter("capture_radius", to_float),
        "slip_radius": setter("slip_radius", to_float),
        "nm_radius": setter("slip_radius", to_float),
        "post_suffix": setter("post_suffix", to_str),
        "patience": setter("patience", _patience),
        "acquire_dist": setter("acquire_dist", to_float),
        "center_activate": setter("center_activate", to_bool),
        "center_assign": setter("center_assign", to_point_or_present),
        "xcenter_assign": _xcenter,
        "ycenter_assign": _ycenter,
    }

    def reset(self) -> None:
        p: LoiterParams = self.params
        self.vertices: tuple[Point, ...] = p.polygon
        if isinstance(p.center_assign, tuple) and p.polygon:
            self.vertices = shift(p.polygon, *p.center_assign)
        self.index = 0
        self.acquire_now = False  # pick the vertex at the next run (idle -> running)
        self.direction = -1 if p.clockwise == "false" else 1
        self.acquire_mode = True
        self.arrival = ArrivalTracker(p.capture_radius, p.slip_radius)
        self.laps = 0
        self._pending_center_here = p.center_assign == "present_position"
        self._posted: tuple[int, bool] | None = None
        self._posted_poly: tuple[Point, ...] | None = None
        self._speed_memo = ZaicMemo()
        self._edge_memo: tuple | None = None  # (vertices, edges, cross products, bearings)

    def on_params_changed(self, key: str) -> None:
        p: LoiterParams = self.params
        if key in ("polygon", "center_assign", "xcenter_assign", "ycenter_assign", "clockwise"):
            self.reset()
        elif key in ("capture_radius", "slip_radius", "radius", "nm_radius"):
            self.arrival = ArrivalTracker(p.capture_radius, p.slip_radius)

    def on_run_start(self, ctx: BehaviorContext) -> None:
        self.acquire_now = True
        if self.params.center_activate:
            self._pending_center_here = True

    def _approaches(self, x: float, y: float) -> list[float]:
        """The bearing (deg) from (x, y) to each vertex."""
        return [bearing_deg(x, y, vx, vy) for vx, vy in self.vertices]

    def _turn(self, approaches: list[float], k: int, d: int) -> float:
        """The turn (deg, [-180, 180)) onto vertex k's onward edge in direction d, coming
        along ``approaches[k]`` (:meth:`_approaches`)."""
        return wrap_180(self._edges()[2][k, d] - approaches[k])

    def _visible_vertices(self, x: float, y: float) -> list[int]:
        """The vertices whose sight line from (x, y) properly crosses no edge (one touching
        it does not count): an edge blocks when its two cross products with the line's ends
        have strictly opposite signs, and the line's with the edge's ends too. The edge's
        cross product with (x, y) is the same for every vertex, and with each vertex fixed
        by the polygon: both are worked out once (the same products, in the same order)."""
        vs, n, eps = self.vertices, len(self.vertices), _CROSS_EPS
        edges, at_vertex, _ = self._edges()
        at_own = [ex * (y - ay) - ey * (x - ax) for ax, ay, _, _, ex, ey in edges]
        seen = []
        for k in range(n):
            kx, ky = vs[k]
            for i in range(n):
                if k == i or k == (i + 1) % n:
                    continue
                d1, d2 = at_own[i], at_vertex[i][k]
                if not ((d1 > eps and d2 < -eps) or (d1 < -eps and d2 > eps)):
                    continue
                ax, ay, bx, by, _, _ = edges[i]
                sx, sy = kx - x, ky - y
                d3 = sx * (ay - y) - sy * (ax - x)
                d4 = sx * (by - y) - sy * (bx - x)
                if (d3 > eps and d4 < -eps) or (d3 < -eps and d4 > eps):
                    break
            else:
                seen.append(k)
        return seen

    def _edges(self) -> tuple[list[tuple[float, ...]], list[list[float]],
                              dict[tuple[int, int], float]]:
        """Each edge i (vertex i to i + 1) as (ax, ay, bx, by, ex, ey), its cross product
        with every vertex k, ``[i][k]``, and the bearing (deg) from each vertex k to the
        next in direction d (+1 / -1), ``[k, d]`` (kept while the vertices are)."""
        if self._edge_memo is None or self._edge_memo[0] is not self.vertices:
            vs, n = self.vertices, len(self.vertices)
            edges = []
            for i in range(n):
                (ax, ay), (bx, by) = vs[i], vs[(i + 1) % n]
                edges.append((ax, ay, bx, by, bx - ax, by - ay))
            at_vertex = [[ex * (ky - ay) - ey * (kx - ax) for kx, ky in vs]
                         for ax, ay, _, _, ex, ey in edges]
            onward = {(k, d): bearing_deg(*vs[k], *vs[(k + d) % n])
                      for k in range(n) for d in (1, -1)}
            self._edge_memo = (vs, edges, at_vertex, onward)
        return self._edge_memo[1:]

    def acquire(self, x: float, y: float, heading: float) -> tuple[int, int]:
        """(vertex index, direction +1 clockwise / -1 counter-clockwise) to approach."""
        p: LoiterParams = self.params
        vs, n = self.vertices, len(self.vertices)
        approach = self._approaches(x, y)
        if point_in_polygon(x, y, vs):
            d = self.direction
            near = min(range(n), key=lambda k: abs(wrap_180(heading - approach[k])))
            score = [abs(self._turn(approach, k, d)) - (2.0 if k == near else 0.0)
                     for k in range(n)]
            return min(range(n), key=lambda k: score[k]), d

        seen = self._visible_vertices(x, y) or list(range(n))

        def out(d: int) -> int:
            pick = max if d == 1 else min
            return pick(seen, key=lambda k: self._turn(approach, k, d))

        if p.clockwise != "best":
            return out(self.direction), self.direction
        cw, ccw = out(1), out(-1)
        dcw = abs(wrap_180(heading - approach[cw]))
        dccw = abs(wrap_180(heading - approach[ccw]))
        return (cw, 1) if dcw < dccw else (ccw, -1)

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: LoiterParams = self.params
        own = ctx.own
        if not self.vertices:  # pHelmIvP loads it, then idles (BHV_Loiter.cpp:366-370)
            ctx.post("BHV_WARNING", f"{self.name}: Empty/NULL Loiter Specification.")
            return None
        if own is None:
            return None
        if self._pending_center_here:
            self.vertices = shift(self.vertices, own.x, own.y)
            self._pending_center_here = False
        n = len(self.vertices)
        acquire = signed_dist_to_polygon(own.x, own.y, self.vertices) > p.acquire_dist
        if acquire or self.acquire_now:
            self.acquire_now = False
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
        return course_speed_objective(
            ctx, crs, p.speed, LOITER_SPEED_ZAIC, self._speed_memo, (p.patience, 100.0 - p.patience)
        )
