"""Turn the simulation's per-tick output into viewer frames (docs/viewer.md schema).

:class:`FrameBuilder` is what a publish hook calls: ``builder.observe(tick_frame)`` on
every tick, and ``server.publish(builder.build(tick_frame, paused=..., speed_factor=...,
rtf=...))`` on the ticks it wants to show (every tick is fine too: publish is O(1)).
It reads the simulation's ``TickFrame`` by duck typing (``t``, ``agents`` mapping of
snapshots with ``name``, ``model``, ``mode`` and ``nav`` — ``position_ned`` (m),
``yaw`` (rad, compass), ``speed`` (m/s) — and ``pings`` / ``images`` (keyed
``"<agent>/<sensor>"``) / ``posts``), so the viewer does not import the simulation.

Overlays come from two places: fixed ones given at construction (e.g. contact and
alert range circles from the scenario), and pMarineViewer-style postings seen in
``posts`` — ``VIEW_POLYGON`` (``"pts={x,y:x,y:...},label=..."``) and ``VIEW_POINT``
(``"x=..,y=..,label=.."``) in MOOS local coordinates (x east, y north;
docs/conventions.md), converted here to (north, east). The latest posting per
(agent, label) wins; ``active=false`` removes it, as in MOOS.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

_PTS = re.compile(r"pts\s*=\s*\{([^}]*)\}")


def agent_kind(model: str, name: str = "") -> str:
    """Viewer drawing kind of an agent: ``"rov"``, ``"diver"`` or ``"vehicle"``."""
    text = f"{model} {name}".lower()
    if "diver" in text:
        return "diver"
    if "videoray" in text or "rov" in text:
        return "rov"
    return "vehicle"


def parse_moos_fields(text: str) -> dict[str, str]:
    """``"x=1,y=2,label=a"`` → ``{"x": "1", ...}``; a ``pts={...}`` field is kept whole."""
    out: dict[str, str] = {}
    m = _PTS.search(text)
    if m:
        out["pts"] = m.group(1)
        text = text[: m.start()] + text[m.end():]
    for part in text.split(","):
        if "=" in part:
            k, v = part.split("=", 1)
            out[k.strip().lower()] = v.strip()
    return out


def polygon_from_moos(text: str) -> tuple[str, list[list[float]], bool] | None:
    """``VIEW_POLYGON`` string → (label, [[north, east], ...], active); None if unusable."""
    f = parse_moos_fields(text)
    pts: list[list[float]] = []
    for pair in f.get("pts", "").split(":"):
        xy = pair.split(",")
        if len(xy) < 2:
            continue
        try:
            x, y = float(xy[0]), float(xy[1])
        except ValueError:
            continue
        pts.append([y, x])  # MOOS (x east, y north) → (north, east)
    active = f.get("active", "true").lower() != "false"
    if not pts and active:
        return None
    return f.get("label", ""), pts, active


def point_from_moos(text: str) -> tuple[str, float, float, bool] | None:
    """``VIEW_POINT`` string → (label, north, east, active); None if unusable."""
    f = parse_moos_fields(text)
    active = f.get("active", "true").lower() != "false"
    try:
        return f.get("label", ""), float(f["y"]), float(f["x"]), active
    except (KeyError, ValueError):
        return (f.get("label", ""), math.nan, math.nan, False) if not active else None


def track_kind(seen: Any, track: Any) -> str:
    """How the viewer draws a perception track: ``diver``, ``track`` (confirmed) or
    ``tentative``."""
    return "diver" if track.id == seen.diver else "track" if track.confirmed else "tentative"


def sonar_marks(seen: Any) -> list[dict[str, Any]]:
    """The perception tracks of a ``PerceptionFrame`` in the sonar's fan: range (m) and
    bearing (deg, > 0 starboard) from the sonar, with their kind and id."""
    view = seen.view
    c, s = math.cos(view.yaw), math.sin(view.yaw)
    marks = []
    for tr in seen.tracks:
        dn, de = tr.north - view.north, tr.east - view.east
        x, y = c * dn + s * de, -s * dn + c * de
        marks.append({"id": int(tr.id), "kind": track_kind(seen, tr),
                      "range": round(math.hypot(x, y), 3),
                      "bearing_deg": round(math.degrees(math.atan2(y, x)), 2)})
    return marks


def sonar_entry(key: str, ping: Any, seen: Any = None) -> dict[str, Any]:
    """A frame's ``sonar`` entry from the ``SonarPing`` of the sonar ``key``
    (``"<agent>/<sensor>"``): fan image, fov (deg) and range (m) as the ping carries them
    (``ping.info``), and the perception's tracks on the fan (:func:`sonar_marks`) when
    ``seen`` is given.

    Uses the colour-mapped ``fan_rgb`` (BGR in the ping, RGB here) when present, else the
    grey ``fan_u8``. The arrays are referenced, not copied: ``ViewerServer.publish``
    copies them.
    """
    rgb = getattr(ping, "fan_rgb", None)
    fan = rgb[:, :, ::-1] if rgb is not None else ping.fan_u8
    agent, _, sensor = key.partition("/")
    return {
        "agent": agent,
        "sensor": sensor,
        "t": float(ping.t),
        "fan": fan,
        "fov_deg": float(ping.info.fov_deg),
        "max_range": float(ping.info.range_max_m),
        "marks": sonar_marks(seen) if seen is not None else [],
    }


def camera_entry(key: str, frame: Any) -> dict[str, Any]:
    """A frame's ``camera`` entry from the ``CameraFrame`` of the camera ``key``
    (``"<agent>/<sensor>"``): the sRGB picture (referenced, not copied:
    ``ViewerServer.publish`` copies it)."""
    agent, _, sensor = key.partition("/")
    return {"agent": agent, "sensor": sensor, "t": float(frame.t), "image": frame.rgb}


class FrameBuilder:
    """Builds viewer frames from simulation ticks; keeps the overlays posted so far.

    Parameters
    ----------
    circles:
        Fixed range circles ``[{"agent", "label", "radius"}]`` (m), e.g. the contact
        manager's alert and contact ranges.
    kinds:
        Optional ``{agent: "rov"|"diver"|"vehicle"}``; otherwise :func:`agent_kind`.
    range_pair:
        ``(rov, diver)`` agent names for the range plot; default: the first ROV and the
        first diver seen.

    ``team`` (set it before the first tick): a :class:`~uhrisim.viz.viewer.team.TeamView`
    whose entry goes into every frame as ``team`` (None: no team mission).
    """

    def __init__(
        self,
        circles: Sequence[Mapping[str, Any]] = (),
        kinds: Mapping[str, str] | None = None,
        range_pair: tuple[str, str] | None = None,
    ) -> None:
        self._circles = [dict(c) for c in circles]
        self._kinds = dict(kinds or {})
        self._pair = range_pair
        self._polygons: dict[tuple[str, str], list[list[float]]] = {}
        self._points: dict[tuple[str, str], tuple[float, float]] = {}
        self._pending_pings: dict[str, Any] = {}
        self._pending_images: dict[str, Any] = {}
        self._perception: dict[str, Any] = {}  # the newest PerceptionFrame per agent
        self.team: Any = None

    def _take_posts(self, posts: Sequence[Any]) -> None:
        for p in posts:
            if not isinstance(p.value, str):
                continue
            if p.var == "VIEW_POLYGON":
                poly = polygon_from_moos(p.value)
                if poly is not None:
                    label, pts, active = poly
                    if active:
                        self._polygons[(p.community, label)] = pts
                    else:
                        self._polygons.pop((p.community, label), None)
            elif p.var == "VIEW_POINT":
                pt = point_from_moos(p.value)
                if pt is not None:
                    label, n, e, active = pt
                    if active:
                        self._points[(p.community, label)] = (n, e)
                    else:
                        self._points.pop((p.community, label), None)

    def observe(self, tick: Any) -> None:
        """Take note of a tick's postings and pings without building a frame (cheap).

        Call it on every tick you do not :meth:`build`, so no overlay posting or sonar
        ping is missed when frames are built at the viewer's rate only.
        """
        self._take_posts(getattr(tick, "posts", ()))
        for key, ping in (getattr(tick, "pings", None) or {}).items():
            self._pending_pings[key] = ping
        for key, image in (getattr(tick, "images", None) or {}).items():
            self._pending_images[key] = image
        self._perception.update(getattr(tick, "perception", None) or {})
        if self.team is not None:
            self.team.observe(getattr(tick, "events", ()))

    def build(
        self,
        tick: Any,
        *,
        paused: bool = False,
        speed_factor: float = 1.0,
        rtf: float | None = None,
    ) -> dict[str, Any]:
        """The frame for ``tick`` (a ``TickFrame``), with every ping observed since the
        last build (the newest per sonar)."""
        self.observe(tick)
        agents = []
        pos: dict[str, np.ndarray] = {}
        kinds: dict[str, str] = {}
        for name, snap in tick.agents.items():
            nav = snap.nav
            p = np.asarray(nav.position_ned, dtype=float)
            kind = self._kinds.get(name) or agent_kind(getattr(snap, "model", ""), name)
            kinds[name] = kind
            pos[name] = p
            agents.append({
                "name": name,
                "kind": kind,
                "north": float(p[0]),
                "east": float(p[1]),
                "depth": float(p[2]),
                "heading_deg": math.degrees(float(nav.yaw)) % 360.0,
                "speed": float(nav.speed),
                "mode": str(getattr(snap, "mode", "") or ""),
            })
        pair = self._pair
        if pair is None:
            rovs = [a for a, k in kinds.items() if k == "rov"]
            divers = [a for a, k in kinds.items() if k == "diver"]
            pair = (rovs[0], divers[0]) if rovs and divers else None
        rng = None
        if pair is not None and pair[0] in pos and pair[1] in pos:
            rng = float(np.linalg.norm(pos[pair[0]] - pos[pair[1]]))
        sonar = [sonar_entry(key, ping, self._perception.get(key))
                 for key, ping in self._pending_pings.items()]
        tracks = [{"agent": key.partition("/")[0], "id": int(tr.id),
                   "kind": track_kind(seen, tr), "north": float(tr.north),
                   "east": float(tr.east)}
                  for key, seen in self._perception.items() for tr in seen.tracks]
        self._pending_pings = {}
        camera = [camera_entry(key, image) for key, image in self._pending_images.items()]
        self._pending_images = {}
        return {
            "t": float(tick.t),
            "paused": bool(paused),
            "speed_factor": float(speed_factor),
            "rtf": None if rtf is None else float(rtf),
            "agents": agents,
            "overlays": {
                "polygons": [{"agent": a, "label": lab, "points": pts}
                             for (a, lab), pts in self._polygons.items()],
                "points": [{"agent": a, "label": lab, "north": n, "east": e}
                           for (a, lab), (n, e) in self._points.items()],
                "circles": list(self._circles),
                "tracks": tracks,
            },
            "sonar": sonar or None,
            "camera": camera or None,
            "team": None if self.team is None else self.team.entry(),
            "plots": {
                "range_to_diver": rng,
                "depth": {a["name"]: a["depth"] for a in agents},
                "speed": {a["name"]: a["speed"] for a in agents},
            },
        }


def _round(a: np.ndarray, decimals: int = 3) -> list[Any]:
    return np.round(np.asarray(a, dtype=float), decimals).tolist()


def scene_from_world(scene: Any, *, seafloor_cells: int = 100,
                     mesh_max_faces: int = 20_000) -> dict[str, Any]:
    """The viewer's scene dict (docs/viewer.md) from a ``uhrisim.world.scene.Scene``.

    The sea floor (a depth grid) is resampled to at most ``seafloor_cells`` cells a side
    (every k-th grid line, the last one kept), triangulated like the world's mesh. Other
    static objects become ``"mesh"`` objects (NED vertices, mm precision), decimated
    to ``mesh_max_faces`` by :func:`decimate_mesh` (display only). Dynamic
    bodies (ROV, diver) are left out: the page draws agents from the frames.
    """
    out: dict[str, Any] = {"objects": []}
    floor = getattr(scene, "seafloor", None)
    floor_faces = -1
    if floor is not None:
        n, e, d = np.asarray(floor.north), np.asarray(floor.east), np.asarray(floor.depth)
        floor_faces = 2 * (len(n) - 1) * (len(e) - 1)

        def idx(m: int) -> np.ndarray:
            k = max(1, math.ceil((m - 1) / seafloor_cells))
            i = np.arange(0, m, k)
            return i if i[-1] == m - 1 else np.append(i, m - 1)

        ii, jj = idx(len(n)), idx(len(e))
        nn, ee = np.meshgrid(n[ii], e[jj], indexing="ij")
        verts = np.column_stack([nn.ravel(), ee.ravel(), d[np.ix_(ii, jj)].ravel()])
        cols = len(jj)
        a = (np.arange(len(ii) - 1)[:, None] * cols + np.arange(cols - 1)[None, :]).ravel()
        faces = np.concatenate([np.column_stack([a, a + cols, a + cols + 1]),
                                np.column_stack([a, a + cols + 1, a + 1])])
        out["seafloor"] = {"vertices": _round(verts), "faces": faces.tolist()}
    for obj in getattr(scene, "static_objects", ()):
        mesh = obj.mesh
        if len(mesh.faces) == floor_faces and floor is not None:
            continue  # the sea floor's own full-resolution mesh
        verts, faces = decimate_mesh(mesh.vertices, mesh.faces, mesh_max_faces)
        used, inverse = np.unique(faces, return_inverse=True)
        out["objects"].append({
            "label": str(obj.label),
            "kind": "mesh",
            "vertices": _round(verts[used]),
            "faces": inverse.reshape(-1, 3).tolist(),
        })
    try:
        b = np.asarray(scene.bounds(), dtype=float)
        b[0, 2] = min(b[0, 2], 0.0)
        out["bounds"] = _round(b)
    except Exception:  # an empty scene has no bounds: the page fits to the agents
        pass
    return out


def decimate_mesh(vertices: Any, faces: Any, max_faces: int = 20_000,
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Vertex-clustering decimation for display: at most ``max_faces`` triangles.

    Vertices are binned in a cubic grid; each occupied cell becomes one vertex (the mean
    of its members); triangles that collapse are dropped, duplicates removed. The cell
    starts at ``sqrt(A / (max_faces / 2))`` with ``A`` the product of the two largest
    bounding-box extents (a terrain of ``max_faces / 2`` cells) and grows by 25 % until
    the budget is met. Units are those of ``vertices`` (here NED metres). Returns
    ``(vertices (M, 3), faces (K, 3))``; meshes within budget come back unchanged.
    """
    v = np.asarray(vertices, dtype=float).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) <= max_faces:
        return v, f
    lo = v.min(axis=0)
    ext = np.sort(v.max(axis=0) - lo)
    cell = math.sqrt(max(ext[1] * ext[2], 1e-12) / (max_faces / 2.0))
    for _ in range(40):
        key = np.floor((v - lo) / cell).astype(np.int64)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        inverse = inverse.reshape(-1)
        nv = np.column_stack([np.bincount(inverse, weights=v[:, k]) for k in range(3)])
        nv /= counts[:, None]
        nf = inverse[f]
        ok = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
        nf = nf[ok]
        _, first = np.unique(np.sort(nf, axis=1), axis=0, return_index=True)
        nf = nf[np.sort(first)]
        if len(nf) <= max_faces:
            used, remap = np.unique(nf, return_inverse=True)
            return nv[used], remap.reshape(-1, 3)
        cell *= 1.25
    raise ValueError(f"could not decimate a mesh of {len(f)} faces to {max_faces}")
