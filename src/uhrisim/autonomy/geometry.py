"""Plane geometry in MOOS local coordinates (x east, y north, metres; compass degrees).

Polygons are stored as vertex tuples in clockwise order seen from above (compass order).
Specifications accepted (MOOS-IvP ``XYPolygon`` strings):

* ``format=radial, x=10, y=-20, radius=20, pts=8 [, snap=0.1] [, label=..]`` or the older
  ``radial:: x=10, y=-20, radius=20, pts=8`` (also ``radial:: 10,-20, radius=20, pts=8``)
  - a regular polygon; vertex k at compass bearing 180/pts + k*360/pts from the centre
  (the paper's octagon: 22.5 + k*45 deg). Display-only fields (label, colours, sizes,
  active, source, msg) are accepted and do not change the vertices;
* ``x1,y1 : x2,y2 : ...`` or ``pts={x1,y1:x2,y2:...}``.
"""

from __future__ import annotations

import math

from uhrisim.autonomy.params import to_float, to_points
from uhrisim.core.errors import ConfigError

__all__ = [
    "bearing_deg",
    "dist_to_polygon",
    "distance",
    "is_convex",
    "parse_polygon",
    "point_in_polygon",
    "signed_area",
    "signed_dist_to_polygon",
]

Point = tuple[float, float]


def bearing_deg(x0: float, y0: float, x1: float, y1: float) -> float:
    """Compass bearing (deg, [0, 360)) from (x0, y0) to (x1, y1)."""
    return math.degrees(math.atan2(x1 - x0, y1 - y0)) % 360.0


def distance(x0: float, y0: float, x1: float, y1: float) -> float:
    """Euclidean distance (m) between (x0, y0) and (x1, y1), MOOS local metres."""
    return math.hypot(x1 - x0, y1 - y0)


def signed_area(pts: tuple[Point, ...]) -> float:
    """Shoelace area: > 0 counter-clockwise, < 0 clockwise (x east, y north)."""
    n = len(pts)
    return 0.5 * sum(
        pts[i][0] * pts[(i + 1) % n][1] - pts[(i + 1) % n][0] * pts[i][1] for i in range(n)
    )


def is_convex(pts: tuple[Point, ...], tol: float = 1e-9) -> bool:
    """True for a simple convex polygon (collinear vertices allowed), >= 3 vertices."""
    n = len(pts)
    if n < 3 or abs(signed_area(pts)) <= tol:
        return False
    sign = 0
    turning = 0.0
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = pts[i], pts[(i + 1) % n], pts[(i + 2) % n]
        cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
        if abs(cross) > tol:
            s = 1 if cross > 0 else -1
            if sign and s != sign:
                return False
            sign = s
        turning += math.atan2(cross, (bx - ax) * (cx - bx) + (by - ay) * (cy - by))
    return abs(abs(turning) - 2.0 * math.pi) < 1e-6


def point_in_polygon(x: float, y: float, pts: tuple[Point, ...]) -> bool:
    """Even-odd rule containment test."""
    inside = False
    n = len(pts)
    for i in range(n):
        (ax, ay), (bx, by) = pts[i], pts[(i + 1) % n]
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def _dist_to_segment(x: float, y: float, a: Point, b: Point) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    L2 = dx * dx + dy * dy
    t = 0.0 if L2 == 0 else max(0.0, min(1.0, ((x - a[0]) * dx + (y - a[1]) * dy) / L2))
    return math.hypot(x - a[0] - t * dx, y - a[1] - t * dy)


def dist_to_polygon(x: float, y: float, pts: tuple[Point, ...]) -> float:
    """0 inside the polygon, else the distance to its boundary."""
    return max(signed_dist_to_polygon(x, y, pts), 0.0)


def signed_dist_to_polygon(x: float, y: float, pts: tuple[Point, ...]) -> float:
    """Distance to the boundary, negative inside (IvP Loiter's inner/outer test)."""
    if not pts:
        raise ValueError("signed_dist_to_polygon needs a polygon with vertices")
    d = math.inf
    inside = False
    (bx, by) = pts[-1]
    for ax, ay in pts:  # segment (previous vertex -> this one); _dist_to_segment inlined
        sx, sy = ax - bx, ay - by
        L2 = sx * sx + sy * sy
        t = 0.0 if L2 == 0 else max(0.0, min(1.0, ((x - bx) * sx + (y - by) * sy) / L2))
        di = math.hypot(x - bx - t * sx, y - by - t * sy)
        if di < d:
            d = di
        if (by > y) != (ay > y) and x < bx + (y - by) * (ax - bx) / (ay - by):
            inside = not inside  # point_in_polygon's test of the same edge
        bx, by = ax, ay
    return -d if inside else d


_DISPLAY_FIELDS = {
    "label", "label_color", "edge_color", "vertex_color", "edge_size", "vertex_size",
    "active", "source", "msg", "fill_color", "fill_transparency", "duration", "time",
}  # fmt: skip


#: More vertices than this is refused: a loiter's helm tick is linear in them.
MAX_POLYGON_POINTS = 1000


def _radial(spec: str, key: str, where: str) -> tuple[Point, ...]:
    body = spec.split("::", 1)[1] if "::" in spec else spec
    fields: dict[str, str] = {}
    bare: list[str] = []
    for part in body.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            bare.append(part.strip())
            continue
        k, v = part.split("=", 1)
        fields[k.strip().lower()] = v.strip()
    if bare:  # "radial:: 10,-20, radius=..": the first two bare numbers are the centre
        if len(bare) != 2 or "x" in fields or "y" in fields:
            raise ConfigError(f"{key}: cannot read radial polygon {spec!r}", where)
        fields["x"], fields["y"] = bare
    unknown = set(fields) - {"format", "x", "y", "radius", "pts", "snap"} - _DISPLAY_FIELDS
    if unknown:
        raise ConfigError(f"{key}: unknown radial polygon field(s) {sorted(unknown)}", where)
    try:
        cx, cy = to_float(fields["x"], key, where), to_float(fields["y"], key, where)
        radius = to_float(fields["radius"], key, where)
        n = int(to_float(fields["pts"], key, where))
    except KeyError as e:
        raise ConfigError(f"{key}: radial polygon needs {e.args[0]}=", where) from None
    if radius <= 0 or not 3 <= n <= MAX_POLYGON_POINTS:
        raise ConfigError(f"{key}: radial polygon needs radius > 0 and 3 <= pts <= "
                          f"{MAX_POLYGON_POINTS}", where)
    snap = to_float(fields.get("snap", 0), key, where)
    pts = []
    for k in range(n):
        b = math.radians(180.0 / n + k * 360.0 / n)
        px, py = cx + radius * math.sin(b), cy + radius * math.cos(b)
        if snap > 0:
            px, py = snap_to_step(px, snap), snap_to_step(py, snap)
        pts.append((px, py))
    return tuple(pts)


def snap_to_step(value: float, step: float) -> float:
    """``value`` on the nearest multiple of ``step``, halves away from zero (MOOS-IvP
    MBUtils ``snapToStep``; a step <= 0 leaves it)."""
    if step <= 0:
        return value
    q = value / step
    return float(int(q + 0.5) if q >= 0.0 else int(q - 0.5)) * step


def parse_polygon(v: object, key: str = "polygon", where: str = "polygon") -> tuple[Point, ...]:
    """Polygon spec -> clockwise vertex tuple; a non-convex polygon is a ConfigError."""
    s = v if isinstance(v, list | tuple) else str(v).strip()
    if isinstance(s, str) and (
        s.lower().startswith("radial::") or ("format" in s.lower() and "radial" in s.lower())
    ):
        pts = _radial(s, key, where)
    else:
        if isinstance(s, str):
            s = ":".join(p for p in s.split(":") if not p.strip().lower().startswith("label"))
        pts = to_points(s, key, where)
        if len(pts) > MAX_POLYGON_POINTS:
            raise ConfigError(f"{key} has {len(pts)} points, more than {MAX_POLYGON_POINTS}",
                              where)
    if not is_convex(pts):
        raise ConfigError(f"{key} is not a convex polygon: {v!r}", where)
    if signed_area(pts) > 0:
        pts = (pts[0], *reversed(pts[1:]))
    return pts
