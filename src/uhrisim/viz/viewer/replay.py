"""Replay an MCAP recording in the web viewer, with a time slider.

The recording is the one ``uhrisim.record.McapRecorder`` writes (topics in its module
docstring): ``/<agent>/odom`` (nav_msgs/Odometry, ENU/FLU), each sonar's
``/<agent>/<sonar>/fan`` (sensor_msgs/Image mono8) and its field of view and range from
the first ``/<agent>/<sonar>/image`` (marine_acoustic_msgs/ProjectedSonarImage: beam
directions and range bins), each camera's ``/<agent>/<camera>/image_raw``
(sensor_msgs/Image rgb8),
``/<agent>/vars`` (uhrisim_msgs/Variable) and
``/scene/markers`` (visualization_msgs/MarkerArray, ENU), the helm's mode from
``/<agent>/helm/decision`` (else a ``MODE`` variable) and, in a team mission, the
articulated divers' ``/<agent>/joint_states``, the ``/events`` topic's teamwork and order
events, and every tool's and load's ``/tf`` frame ``map -> <object>`` with the
``teamwork`` metadata record (kinds, the sites' places: uhrisim.record.hook.team_layout).
Odometry is read with
``uhrisim.record.reader.read_odometry`` (ENU/FLU → NED/FRD); the rest is decoded from
the same file with ``uhrisim.record.reader.iter_messages`` and converted back to NED here
with ``uhrisim.core.frames``. The page receives exactly the live frame schema, so the
same page shows live runs and replays.

A sonar's field of view and range are never guessed: without a ProjectedSonarImage they
come from the agent's recorded ``SONAR_FOV_DEG`` and ``SONAR_MAX_RANGE`` variables (a
recording made without the sonar images), else they are unknown (0: the page draws no
range arcs and no 3-D wedge).
"""

from __future__ import annotations

import bisect
import json
import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uhrisim.core.errors import AssetError
from uhrisim.core.frames import enu_from_ned, enu_rotation_from_ned, rot_z
from uhrisim.dynamics.diver_body import DiverSkeleton
from uhrisim.sim.teamwork import parse_order_detail, parse_site_state
from uhrisim.viz.viewer.adapt import (
    agent_kind,
    decimate_mesh,
    point_from_moos,
    polygon_from_moos,
)
from uhrisim.viz.viewer.protocol import Command
from uhrisim.viz.viewer.server import ViewerServer
from uhrisim.viz.viewer.team import (
    LOG_LENGTH,
    bag_site,
    figure_points,
    flange_site,
    hatch_site,
    load_site,
)
from uhrisim.world.events import parse_line

log = logging.getLogger(__name__)

#: Memory budget for decoded sonar fans and camera pictures kept for scrubbing; beyond it
#: the largest agent's images are thinned.
SONAR_BUDGET_BYTES = 256 * 1024 * 1024
#: Points per agent sent to the page for replay trails.
TRACK_POINTS_MAX = 5000
#: Playback rate used for speed "max" (× real time).
MAX_PLAYBACK_SPEED = 100.0

_MARKER_BOX, _MARKER_SPHERE, _MARKER_CYLINDER, _MARKER_TRIANGLES = 1, 2, 3, 11
_MARKER_DELETE, _MARKER_DELETEALL = 2, 3
_ODOM = re.compile(r"^/([^/]+)/odom$")
_FAN = re.compile(r"^/([^/]+/[^/]+)/fan$")  # group 1: the sensor key "<agent>/<sonar>"
_CAMERA = re.compile(r"^/([^/]+/[^/]+)/image_raw$")
_PROJECTED = re.compile(r"^/([^/]+/[^/]+)/image$")
PROJECTED_SONAR_IMAGE = "marine_acoustic_msgs/msg/ProjectedSonarImage"
_VARS = re.compile(r"^/([^/]+)/vars$")
_HELM = re.compile(r"^/([^/]+)/helm/decision$")
_TRACKS = re.compile(r"^/([^/]+)/perception/tracks$")
_TRACK_TEXT = re.compile(r"^track (\d+) \((diver|track|tentative)\)")
_HELM_MODE = "__helm_mode"  # key under which helm decisions' modes are kept
_JOINTS = re.compile(r"^/([^/]+)/joint_states$")
_EVENTS = "/events"
_TF = "/tf"
_WORLD_FRAME = "map"
# events that change who holds an object (uhrisim.teamwork.acts): the actor takes / lets go
_TAKES, _LETS_GO = ("grasp",), ("release", "drop", "place")
_BAG_STATES = {"bag_inflating": "inflating", "bag_inflation_stopped": "inflation stopped",
               "bag_full": "full"}
_TEAM_EVENT_KINDS = ("teamwork", "order", "team_state")
#: the kinds shown in the panel's log (team_state records a bag's gas, a hatch's angle)
_LOGGED_KINDS = ("teamwork", "order")


@dataclass
class _Pings:
    """Decoded images of one sensor, thinned online to stay within a byte budget."""

    t: list[float] = field(default_factory=list)
    images: list[np.ndarray] = field(default_factory=list)
    stride: int = 1
    seen: int = 0

    def add(self, t: float, img: np.ndarray) -> None:
        if self.seen % self.stride == 0:
            self.t.append(t)
            self.images.append(img)
        self.seen += 1

    def nbytes(self) -> int:
        return sum(i.nbytes for i in self.images)

    def thin(self) -> None:
        self.t = self.t[::2]
        self.images = self.images[::2]
        self.stride *= 2


@dataclass(frozen=True)
class ReplayData:
    """A recording, in viewer terms (NED metres, compass degrees, seconds)."""

    tracks: dict[str, dict[str, np.ndarray]]  # t, north, east, depth, heading_deg, speed
    kinds: dict[str, str]
    pings: dict[str, tuple[np.ndarray, list[np.ndarray]]]  # by sensor key "<agent>/<sonar>"
    variables: dict[str, dict[str, tuple[list[float], list[float | str]]]]
    scene: dict[str, Any]
    t_start: float
    t_end: float
    sonar_fov_deg: dict[str, float]  # by sensor key; 0: unknown
    sonar_range: dict[str, float]  # m, by sensor key; 0: unknown
    shots: dict[str, tuple[np.ndarray, list[np.ndarray]]] = field(default_factory=dict)
    # sonar perception tracks per agent: (times, [[{id, kind, north, east}, ...] per ping])
    perception: dict[str, tuple[list[float], list[list[dict[str, Any]]]]] = field(
        default_factory=dict)
    # articulated divers' joints per agent: (times (N,), joint names, angles (N, J) rad)
    joints: dict[str, tuple[np.ndarray, tuple[str, ...], np.ndarray]] = field(
        default_factory=dict)
    # teamwork and order events in time order: (t, kind, detail)
    team_events: list[tuple[float, str, str]] = field(default_factory=list)
    # orders per diver, from the run's metrics.json beside the recording (when there)
    order_totals: dict[str, int] = field(default_factory=dict)
    # the teamwork layout (uhrisim.record.hook.team_layout; {} without one)
    layout: dict[str, Any] = field(default_factory=dict)
    # tools and loads by name: (times (N,), positions (N, 3) NED m) from /tf
    objects: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


def _image_u8(msg: Any, encodings: tuple[str, ...] = ("mono8", "8uc1")) -> np.ndarray | None:
    """The pixels of a sensor_msgs/Image of one of ``encodings`` (mono8: H×W; rgb8:
    H×W×3), or None."""
    enc = str(msg.encoding).lower()
    if enc not in encodings:
        log.warning("replay: image encoding %r not supported (want %s)", enc,
                    " or ".join(encodings))
        return None
    channels = 3 if enc == "rgb8" else 1
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    buf = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    if buf.size < h * step or step < w * channels:
        return None
    rows = buf[: h * step].reshape(h, step)[:, : w * channels]
    return (rows.reshape(h, w, 3) if channels == 3 else rows).copy()


def _marker_object(m: Any, max_faces: int = 20_000) -> dict[str, Any] | None:
    """visualization_msgs/Marker (ENU/FLU) → viewer scene object (NED/FRD); triangle
    lists are welded and decimated to ``max_faces`` for display."""
    p, o, s, c = m.pose.position, m.pose.orientation, m.scale, m.color
    pos_ned = enu_from_ned(np.array([p.x, p.y, p.z], dtype=float))
    x, y, z, w = o.x, o.y, o.z, o.w
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    r_enu = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    r_ned = enu_rotation_from_ned(r_enu)  # the FLU/ENU ↔ FRD/NED map is an involution
    color = "#{:02x}{:02x}{:02x}".format(*(round(255 * min(max(v, 0.0), 1.0))
                                           for v in (c.r, c.g, c.b)))
    base = {
        "label": f"{m.ns}/{m.id}" if not m.text else str(m.text),
        "position_ned": pos_ned.tolist(),
        "rotation": r_ned.tolist(),
        "color": color,
    }
    if m.type == _MARKER_BOX:
        return {**base, "kind": "box", "size": [s.x, s.y, s.z]}
    if m.type == _MARKER_SPHERE:
        return {**base, "kind": "sphere", "radius": s.x / 2.0}
    if m.type == _MARKER_CYLINDER:
        return {**base, "kind": "cylinder", "radius": s.x / 2.0, "height": s.z}
    if m.type == _MARKER_TRIANGLES and m.points:
        pts = m.points
        local = np.fromiter((c for q in pts for c in (q.x, q.y, q.z)), dtype=float,
                            count=3 * len(pts)).reshape(-1, 3)
        world_enu = local @ r_enu.T + enu_from_ned(pos_ned)
        nf = len(world_enu) // 3
        # a triangle list repeats shared corners: weld them, then decimate for display
        verts, inverse = np.unique(np.round(enu_from_ned(world_enu[: 3 * nf]), 4), axis=0,
                                   return_inverse=True)
        verts, faces = decimate_mesh(verts, inverse.reshape(nf, 3), max_faces)
        return {
            "label": base["label"],
            "kind": "mesh",
            "color": color,
            "vertices": np.round(verts, 3).tolist(),
            "faces": faces.tolist(),
        }
    log.debug("replay: marker %s/%s of type %s not shown", m.ns, m.id, m.type)
    return None


def _kind_of(name: str, has_sonar: bool) -> str:
    kind = agent_kind("", name)
    return "rov" if kind == "vehicle" and has_sonar else kind


def load_replay(recording: Path | str) -> ReplayData:
    """Read a uhrisim MCAP recording into :class:`ReplayData` (tolerates truncated files)."""
    from uhrisim.record.reader import iter_messages, read_odometry

    path = Path(recording)
    if not path.is_file():
        raise AssetError(f"{path}: recording not found")
    odo = read_odometry(path)
    if not odo:
        raise AssetError(f"{path}: no /<agent>/odom topic, nothing to replay")
    tracks: dict[str, dict[str, np.ndarray]] = {}
    for agent, tr in odo.items():
        tracks[agent] = {
            "t": np.asarray(tr.t, dtype=float),
            "north": np.asarray(tr.x_north, dtype=float),
            "east": np.asarray(tr.y_east, dtype=float),
            "depth": np.asarray(tr.depth, dtype=float),
            "heading_deg": np.degrees(np.asarray(tr.yaw)) % 360.0,
            # horizontal speed through the water, as NavState.speed (MOOS NAV_SPEED)
            "speed": np.hypot(np.asarray(tr.u), np.asarray(tr.v)),
        }

    pings: dict[str, _Pings] = {}
    shots: dict[str, _Pings] = {}  # camera pictures, kept like the fans
    variables: dict[str, dict[str, tuple[list[float], list[float | str]]]] = {}
    markers: dict[tuple[str, int], dict[str, Any]] = {}
    from uhrisim.record.reader import read_metadata, summarize

    layout = _layout(path, read_metadata(path))
    frames = {ros: o["name"] for ros, o in layout.get("objects", {}).items()}
    topics = [
        t for t in summarize(path).topics
        if _FAN.match(t) or _CAMERA.match(t) or _VARS.match(t) or _HELM.match(t)
        or _TRACKS.match(t) or _JOINTS.match(t)
        or t in ("/scene/markers", _EVENTS) or (t == _TF and frames)
    ]
    poses: dict[str, tuple[list[float], list[list[float]]]] = {}  # tools, loads
    joints: dict[str, tuple[list[float], tuple[str, ...], list[list[float]]]] = {}
    team_events: list[tuple[float, str, str]] = []
    perception: dict[str, tuple[list[float], list[list[dict[str, Any]]]]] = {}
    total = 0
    for dm in iter_messages(path, topics) if topics else ():
        t = dm.log_time_ns * 1e-9
        fan, shot = _FAN.match(dm.topic), _CAMERA.match(dm.topic)
        if fan is not None or shot is not None:
            img = _image_u8(dm.message) if fan else _image_u8(dm.message, ("rgb8",))
            if img is None:
                continue
            store, m = (pings, fan) if fan else (shots, shot)
            p = store.setdefault(m.group(1), _Pings())
            before = len(p.images)
            p.add(t, img)
            if len(p.images) > before:
                total += img.nbytes
            while total > SONAR_BUDGET_BYTES:
                stores = [*pings.values(), *shots.values()]
                max(stores, key=lambda q: q.nbytes()).thin()
                total = sum(q.nbytes() for q in stores)
        elif (m := _VARS.match(dm.topic)) is not None:
            v = dm.message
            value: float | str = v.string_value if v.kind == 1 else float(v.double_value)
            ts, vs = variables.setdefault(m.group(1), {}).setdefault(str(v.name), ([], []))
            ts.append(t)
            vs.append(value)
        elif (m := _HELM.match(dm.topic)) is not None:
            ts, vs = variables.setdefault(m.group(1), {}).setdefault(_HELM_MODE, ([], []))
            ts.append(t)
            vs.append(str(dm.message.mode))
        elif (m := _TRACKS.match(dm.topic)) is not None:
            ts, seen = perception.setdefault(m.group(1), ([], []))
            ts.append(t)
            seen.append(_tracks_of(dm.message.markers))
        elif (m := _JOINTS.match(dm.topic)) is not None:
            ts, _, qs = joints.setdefault(m.group(1), ([], tuple(dm.message.name), []))
            ts.append(t)
            qs.append(list(dm.message.position))
        elif dm.topic == _TF:
            for tr in dm.message.transforms:
                name = frames.get(str(tr.child_frame_id))
                if name is not None and tr.header.frame_id == _WORLD_FRAME:
                    p = tr.transform.translation
                    ts, ps = poses.setdefault(name, ([], []))
                    ts.append(t)
                    ps.append(enu_from_ned(np.array([p.x, p.y, p.z])).tolist())
        elif dm.topic == _EVENTS:
            if dm.message.kind in _TEAM_EVENT_KINDS:
                team_events.append((t, str(dm.message.kind), str(dm.message.detail)))
        elif dm.topic == "/scene/markers":
            for mk in dm.message.markers:
                if mk.action == _MARKER_DELETEALL:
                    markers.clear()
                elif mk.action == _MARKER_DELETE:
                    markers.pop((mk.ns, mk.id), None)
                else:
                    obj = _marker_object(mk)
                    if obj is not None:
                        markers[(mk.ns, mk.id)] = obj

    t_start = min(float(tr["t"][0]) for tr in tracks.values())
    t_end = max(float(tr["t"][-1]) for tr in tracks.values())
    # initial view: where the agents went, 10 m around (a 240 m sea floor would dwarf it)
    pts = np.concatenate(
        [np.column_stack([tr["north"], tr["east"], tr["depth"]]) for tr in tracks.values()]
    )
    lo, hi = pts.min(axis=0) - 10.0, pts.max(axis=0) + 10.0
    objects = list(markers.values())
    for o in objects:
        zs = [o["position_ned"][2]] if "position_ned" in o else [v[2] for v in o["vertices"]]
        hi[2] = max(hi[2], max(zs, default=hi[2]))
    lo[2] = 0.0
    scene = {"objects": objects, "bounds": [lo.tolist(), hi.tolist()]}

    fov: dict[str, float] = {}
    rng: dict[str, float] = {}
    geometry = _sonar_geometry(path, [t for t, (kind, _) in summarize(path).topics.items()
                                      if kind == PROJECTED_SONAR_IMAGE])
    for key in pings:
        av = variables.get(key.partition("/")[0], {})
        recorded = (float(av["SONAR_FOV_DEG"][1][-1]) if "SONAR_FOV_DEG" in av else 0.0,
                    float(av["SONAR_MAX_RANGE"][1][-1]) if "SONAR_MAX_RANGE" in av else 0.0)
        fov[key], rng[key] = geometry.get(key, recorded)
    sonar_agents = {key.partition("/")[0] for key in pings}
    kinds = {a: _kind_of(a, a in sonar_agents) for a in tracks}
    return ReplayData(
        tracks=tracks,
        kinds=kinds,
        pings={a: (np.asarray(p.t), p.images) for a, p in pings.items()},
        variables=variables,
        scene=scene,
        t_start=t_start,
        t_end=t_end,
        sonar_fov_deg=fov,
        sonar_range=rng,
        shots={a: (np.asarray(p.t), p.images) for a, p in shots.items()},
        perception=perception,
        joints={a: (np.asarray(ts), names, np.asarray(qs, dtype=float))
                for a, (ts, names, qs) in joints.items()},
        team_events=team_events,
        order_totals=_order_totals(path),
        layout=layout,
        objects={name: (np.asarray(ts), np.asarray(ps, dtype=float))
                 for name, (ts, ps) in poses.items()},
    )


def _layout(path: Path, metadata: dict[str, dict[str, str]]) -> dict[str, Any]:
    """The recording's teamwork layout ({} when it has none: a recording made before the
    recorder wrote it, or not a team mission)."""
    text = metadata.get("teamwork", {}).get("layout")
    try:
        return json.loads(text) if text else {}
    except ValueError:
        log.warning("%s: unreadable teamwork layout; tools and sites not drawn", path)
        return {}


def _order_totals(recording: Path) -> dict[str, int]:
    """Orders per diver from the run's ``metrics.json`` next to the recording ({} when
    there is none or it has no team section)."""
    import json

    metrics = recording.parent / "metrics.json"
    try:
        divers = json.loads(metrics.read_text())["team"]["divers"]
        return {name: int(d["orders"]) for name, d in divers.items()}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def fan_geometry(beam_angles_rad: Any, bin_ranges_m: Any) -> tuple[float, float]:
    """(field of view deg, range m) of a recorded sonar image from its beam angles (rad)
    and range-bin centres (m), as a ProjectedSonarImage carries them: the span of the
    beam centres (the outer beams point at the fan's edges) and the far end of the last
    bin (bins of equal size; 0 when the image is empty)."""
    beams = np.asarray(beam_angles_rad, dtype=float).reshape(-1)
    bins = np.asarray(bin_ranges_m, dtype=float).reshape(-1)
    fov = float(np.degrees(beams.max() - beams.min())) if beams.size else 0.0
    half_bin = 0.5 * float(bins[-1] - bins[-2]) if bins.size > 1 else 0.0
    return fov, float(bins[-1]) + half_bin if bins.size else 0.0


def _sonar_geometry(path: Path, topics: list[str]) -> dict[str, tuple[float, float]]:
    """Per sonar key, (field of view deg, range m) from the first ProjectedSonarImage
    on each of ``topics`` (:func:`fan_geometry`)."""
    from uhrisim.record.reader import iter_messages

    out: dict[str, tuple[float, float]] = {}
    wanted = {t for t in topics if _PROJECTED.match(t)}
    for dm in iter_messages(path, sorted(wanted)) if wanted else ():
        key = _PROJECTED.match(dm.topic).group(1)  # type: ignore[union-attr]
        if key not in out:
            d = dm.message.beam_directions
            angles = np.arctan2([v.y for v in d], [v.z for v in d])
            out[key] = fan_geometry(angles, np.asarray(dm.message.ranges, dtype=float))
            if len(out) == len(wanted):
                break
    return out


def _due(store: dict[str, tuple[np.ndarray, list[np.ndarray]]], t: float,
         sent: dict[str, int]) -> list[tuple[str, float, np.ndarray]]:
    """Per sensor key, the latest image at or before ``t`` not sent yet: (key, its time,
    the image); ``sent`` remembers what went out."""
    out = []
    for name, (ts, images) in store.items():
        i = int(np.searchsorted(ts, t, side="right")) - 1
        if i < 0 or sent.get(name) == i:
            continue
        sent[name] = i
        out.append((name, float(ts[i]), images[i]))
    return out


def _tracks_of(markers: Any) -> list[dict[str, Any]]:
    """The perception tracks of one ``/<agent>/perception/tracks`` MarkerArray (ENU →
    north/east; the kind from the marker's text, uhrisim.record.hook.perception_markers)."""
    out = []
    for mk in markers:
        if mk.ns != "tracks" or mk.action == _MARKER_DELETEALL:
            continue
        m = _TRACK_TEXT.match(str(mk.text))
        if m is not None:
            out.append({"id": int(m.group(1)), "kind": m.group(2),
                        "north": float(mk.pose.position.y), "east": float(mk.pose.position.x)})
    return out


def _interp_heading(t: float, ts: np.ndarray, hd: np.ndarray, i: int) -> float:
    """Heading (deg) at t between samples i-1 and i, the short way round."""
    t0, t1 = ts[i - 1], ts[i]
    a = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
    d = (hd[i] - hd[i - 1] + 180.0) % 360.0 - 180.0
    return float((hd[i - 1] + a * d) % 360.0)


class ReplayPlayer:
    """Plays :class:`ReplayData` into a :class:`ViewerServer` (runs in the server thread)."""

    def __init__(self, data: ReplayData, server: ViewerServer) -> None:
        self.data = data
        self.server = server
        self.t = data.t_start
        self.playing = True
        self.speed = 1.0
        self._last_wall: float | None = None
        self._dirty = True
        self._sent_ping: dict[str, int] = {}
        self._sent_shot: dict[str, int] = {}
        self._jumped = False  # the next frame follows a seek (the page breaks its plots)
        dts = [np.median(np.diff(tr["t"])) for tr in data.tracks.values() if len(tr["t"]) > 1]
        self.step_s = float(min(dts)) if dts else 0.1
        rovs = [a for a, k in data.kinds.items() if k == "rov"]
        divers = [a for a, k in data.kinds.items() if k == "diver"]
        self._pair = (rovs[0], divers[0]) if rovs and divers else None
        self._skeleton = DiverSkeleton()  # the recorded joints' figure (default build)
        self._kinds = {o["name"]: o["kind"] for o in data.layout.get("objects", {}).values()}

    # -------------------------------------------------------------- control
    def on_message(self, msg: Command | dict[str, Any]) -> bool:
        """Apply a page command to playback; True when it was consumed here."""
        if isinstance(msg, dict):
            if msg.get("type") != "seek":
                return False
            try:
                t = float(msg["t"])
            except (KeyError, TypeError, ValueError):
                log.warning("replay: bad seek message dropped")
                return True
            if math.isfinite(t):
                self.seek(t)
            return True
        if msg.kind == "pause":
            self.playing = False
        elif msg.kind == "resume":
            if self.t >= self.data.t_end:
                self.seek(self.data.t_start)
            self.playing = True
        elif msg.kind == "speed":
            v = float(msg.value) if msg.value is not None else 1.0
            self.speed = MAX_PLAYBACK_SPEED if math.isinf(v) else v
        elif msg.kind == "step":
            self.playing = False
            n = float(msg.value) if isinstance(msg.value, float) else 1.0
            self.seek(self.t + n * self.step_s)
        else:
            return False  # select / post: nothing to do in a replay
        self._dirty = True
        return True

    def seek(self, t: float) -> None:
        self.t = min(max(t, self.data.t_start), self.data.t_end)
        self._sent_ping.clear()
        self._sent_shot.clear()
        self._jumped = True
        self._dirty = True

    def tick(self, wall: float) -> None:
        """Advance playback to wall-clock ``wall`` (s) and publish a frame if time moved."""
        if self.playing and self._last_wall is not None:
            self.t += (wall - self._last_wall) * self.speed
            if self.t >= self.data.t_end:
                self.t = self.data.t_end
                self.playing = False
            self._dirty = True
        self._last_wall = wall
        if self._dirty:
            self._dirty = False
            frame = self.frame_at(self.t)
            frame["jump"], self._jumped = self._jumped, False
            self.server.publish(frame)

    # -------------------------------------------------------------- frames
    def _var_at(self, agent: str, name: str, t: float) -> float | str | None:
        entry = self.data.variables.get(agent, {}).get(name)
        if entry is None:
            return None
        i = bisect.bisect_right(entry[0], t) - 1
        return entry[1][i] if i >= 0 else None

    def frame_at(self, t: float) -> dict[str, Any]:
        """The live-schema frame at recording time ``t`` (s): positions interpolated."""
        agents = []
        pos: dict[str, tuple[float, float, float]] = {}
        for name, tr in self.data.tracks.items():
            ts = tr["t"]
            i = int(np.searchsorted(ts, t, side="left"))
            if i <= 0 or len(ts) == 1:
                j = 0
                vals = {k: float(tr[k][j]) for k in ("north", "east", "depth", "speed")}
                hd = float(tr["heading_deg"][j])
            elif i >= len(ts):
                vals = {k: float(tr[k][-1]) for k in ("north", "east", "depth", "speed")}
                hd = float(tr["heading_deg"][-1])
            else:
                a = (t - ts[i - 1]) / (ts[i] - ts[i - 1]) if ts[i] > ts[i - 1] else 1.0
                vals = {k: float(tr[k][i - 1] + a * (tr[k][i] - tr[k][i - 1]))
                        for k in ("north", "east", "depth", "speed")}
                hd = _interp_heading(t, ts, tr["heading_deg"], i)
            mode = self._var_at(name, _HELM_MODE, t)
            if mode is None:
                mode = self._var_at(name, "MODE", t)
            agents.append({
                "name": name, "kind": self.data.kinds[name], "heading_deg": hd,
                "mode": "" if mode is None else str(mode), **vals,
            })
            pos[name] = (vals["north"], vals["east"], vals["depth"])
        sonars = [{"agent": key.partition("/")[0], "sensor": key.partition("/")[2], "t": ti,
                   "fan": image, "fov_deg": self.data.sonar_fov_deg[key],
                   "max_range": self.data.sonar_range[key]}
                  for key, ti, image in _due(self.data.pings, t, self._sent_ping)]
        camera = [{"agent": key.partition("/")[0], "sensor": key.partition("/")[2],
                   "t": ti, "image": image}
                  for key, ti, image in _due(self.data.shots, t, self._sent_shot)]
        rng = None
        if self._pair is not None:
            a, b = pos[self._pair[0]], pos[self._pair[1]]
            rng = math.dist(a, b)
        return {
            "t": float(t),
            "paused": not self.playing,
            "speed_factor": self.speed,
            "rtf": self.speed if self.playing else 0.0,
            "agents": agents,
            "overlays": self._overlays(t),
            "sonar": sonars or None,
            "camera": camera or None,
            "team": self._team(t, agents),
            "plots": {
                "range_to_diver": rng,
                "depth": {n: p[2] for n, p in pos.items()},
                "speed": {a["name"]: a["speed"] for a in agents},
            },
        }

    def _team(self, t: float, agents: list[dict[str, Any]]) -> dict[str, Any] | None:
        """The frame's ``team`` entry at ``t`` from the recorded joint states and events
        (uhrisim.viz.viewer.team): each diver's figure, its progress through its orders
        (done so far; the total from metrics.json), the latest events, and the tools,
        loads and sites (:meth:`_world`)."""
        data = self.data
        if not data.joints and not data.team_events and not data.objects:
            return None
        figures = {}
        where = {a["name"]: a for a in agents}
        for name, (ts, names, qs) in data.joints.items():
            i = int(np.searchsorted(ts, t, side="right")) - 1
            a = where.get(name)
            if i < 0 or a is None or tuple(names) != self._skeleton.joint_names:
                continue
            figures[name] = figure_points(self._skeleton, qs[i],
                                          (a["north"], a["east"], a["depth"]),
                                          rot_z(math.radians(a["heading_deg"])))
        k = bisect.bisect_right(data.team_events, (t, "\uffff"))
        progress: dict[str, dict[str, Any]] = {}
        for _, kind, detail in data.team_events[:k]:
            step = parse_order_detail(detail) if kind == "order" else None
            if step is None:
                continue
            p = progress.setdefault(step["diver"], {
                "done": 0, "total": data.order_totals.get(step["diver"]),
                "current": None, "failed": False})
            p["done"] += step["outcome"] == "done" and not step["fetched"]
            p["failed"] = step["outcome"] == "failed"
            p["last"] = f"{step['order']} ({step['outcome']})"
        logged = [(te, kind, detail) for te, kind, detail in data.team_events[:k]
                  if kind in _LOGGED_KINDS]
        log = [{"t": round(te, 2), "kind": kind, "text": detail}
               for te, kind, detail in logged[-LOG_LENGTH:]]
        objects, sites = self._world(t, data.team_events[:k])
        return {"objects": objects, "sites": sites, "progress": progress,
                "figures": figures, "log": log}

    def _position(self, name: str, t: float) -> np.ndarray:
        """Where object ``name`` was at ``t`` (NED m; linear between /tf samples)."""
        ts, ps = self.data.objects[name]
        return np.array([np.interp(t, ts, ps[:, i]) for i in range(3)])

    def _nearest_load(self, bag: str, t: float) -> str | None:
        """The load nearest to ``bag`` at ``t``: the one it was made fast to, for a
        recording whose bag_attached lines do not name it (made before they did)."""
        loads = [n for n in self.data.objects
                 if self._kinds.get(n) == "load" and bag in self.data.objects]
        return min(loads, default=None, key=lambda n: float(np.linalg.norm(
            self._position(n, t) - self._position(bag, t))))

    def _world(self, t: float, events: list[tuple[float, str, str]]
               ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        """Tools and loads at their recorded ``/tf`` poses, held by whoever grasped them
        and has not let go, and the sites' states as the teamwork ``events`` (those up
        to ``t``) tell them: bolts out and cover off, a hatch's last move and its lid's
        angle, a bag's inflation and gas (the ``team_state`` records; a recording made
        before them: a hatch fully open or closed, a full bag at its capacity) and the
        load it is on, a load's rise since the first sample."""
        holders = {o["name"]: list(o.get("held_by", []))
                   for o in self.data.layout.get("objects", {}).values()}
        bolts_out: dict[str, int] = {}
        cover_off: set[str] = set()
        hatch: dict[str, str] = {}
        bag_state: dict[str, str] = {}
        attached: dict[str, str | None] = {}
        recorded: dict[str, float] = {}  # a bag's gas (surface L), a hatch's angle (deg)
        for te, kind, detail in events:
            state = parse_site_state(detail) if kind == "team_state" else None
            if state is not None:
                recorded[state[0]] = state[2]
            ev = parse_line(detail) if kind == "teamwork" else None
            if ev is None or not ev.ok:
                continue
            held = holders.setdefault(ev.subject, [])
            if ev.kind in _TAKES and ev.actor not in held:
                held.append(ev.actor)
            elif ev.kind in _LETS_GO and ev.actor in held:
                held.remove(ev.actor)
            elif ev.kind == "bolt_removed":
                bolts_out[ev.subject] = bolts_out.get(ev.subject, 0) + 1
            elif ev.kind == "cover_removed":
                cover_off.add(ev.subject)
            elif ev.kind.startswith("hatch_"):
                hatch[ev.subject] = ev.kind.removeprefix("hatch_")
            elif ev.kind == "bag_attached":  # "(on <load>)"; older recordings: nearest
                on = ev.reason.removeprefix("on ")
                attached[ev.subject] = on if on in self._kinds else self._nearest_load(
                    ev.subject, te)
            elif ev.kind in _BAG_STATES:
                bag_state[ev.subject] = _BAG_STATES[ev.kind]
        objects, loads, sites = [], [], []
        for name, (_, ps) in self.data.objects.items():
            n, e, d = (float(v) for v in self._position(name, t))
            kind = self._kinds.get(name, "tool")
            objects.append({"name": name, "kind": kind, "north": n, "east": e, "depth": d,
                            "held_by": holders.get(name, []), "where": ""})
            if kind == "load":
                loads.append(load_site(name, (n, e, d), float(ps[0, 2]) - d))
        layout = self.data.layout
        for name, f in layout.get("flanges", {}).items():
            sites.append(flange_site(name, f["position"], int(f["bolts"]),
                                     bolts_out.get(name, 0), name not in cover_off))
        for name, h in layout.get("hatches", {}).items():
            move = hatch.get(name, "closed")
            is_open = move in ("opened", "closing")
            text = {"opened": "open"}.get(move, move)
            angle = recorded.get(name)  # older recordings: fully open or closed
            if angle is None:
                angle = float(h["open_angle_deg"]) if is_open else 0.0
            sites.append(hatch_site(name, h["position"], text, angle, is_open))
        for name, b in layout.get("bags", {}).items():
            if name not in self.data.objects:
                continue
            capacity = float(b["capacity_litres"])
            state = bag_state.get(name, "")
            litres = recorded.get(name)  # older recordings: known only when full
            if litres is None and state == "full":
                litres = capacity
            sites.append(bag_site(name, self._position(name, t), litres, capacity,
                                  attached.get(name), state or "not inflated"))
        return objects, sites + loads

    def _overlays(self, t: float) -> dict[str, list[dict[str, Any]]]:
        """pMarineViewer-style VIEW_POLYGON / VIEW_POINT postings (MOOS x east, y north)."""
        polys, points = [], []
        for agent in self.data.variables:
            text = self._var_at(agent, "VIEW_POLYGON", t)
            poly = polygon_from_moos(text) if isinstance(text, str) else None
            if poly is not None and poly[2] and len(poly[1]) >= 2:
                polys.append({"agent": agent, "label": poly[0], "points": poly[1]})
            text = self._var_at(agent, "VIEW_POINT", t)
            pt = point_from_moos(text) if isinstance(text, str) else None
            if pt is not None and pt[3]:
                points.append({"agent": agent, "label": pt[0], "north": pt[1], "east": pt[2]})
        tracks = []
        for agent, (ts, seen) in self.data.perception.items():
            i = bisect.bisect_right(ts, t) - 1
            if i >= 0:
                tracks += [{"agent": agent, **tr} for tr in seen[i]]
        return {"polygons": polys, "points": points, "circles": [], "tracks": tracks}

    def hello_extra(self) -> dict[str, Any]:
        """Replay range and decimated tracks (for trails), added to the hello message."""
        tracks = {}
        for name, tr in self.data.tracks.items():
            stride = max(1, math.ceil(len(tr["t"]) / TRACK_POINTS_MAX))
            tracks[name] = {
                "t": tr["t"][::stride].tolist(),
                "n": tr["north"][::stride].tolist(),
                "e": tr["east"][::stride].tolist(),
                "d": tr["depth"][::stride].tolist(),
            }
        return {
            "replay": {"t_start": self.data.t_start, "t_end": self.data.t_end},
            "tracks": tracks,
        }


def serve_replay(
    recording: Path | str,
    host: str = "127.0.0.1",
    port: int = 8765,
    *,
    max_fps: float = 20.0,
    start: bool = True,
) -> ViewerServer:
    """Serve the viewer over an MCAP recording; the page gets a time slider.

    Returns the (started, unless ``start=False``) :class:`ViewerServer`; ``server.url``
    is the page address, ``server.start()`` is idempotent. Playback starts at the first
    odometry sample at ×1; the page's pause / resume / speed / step act on playback, the
    slider seeks.
    """
    data = load_replay(recording)
    server = ViewerServer(data.scene, [], host=host, port=port, max_fps=max_fps)
    player = ReplayPlayer(data, server)
    server.mode = "replay"
    server._hello_extra = player.hello_extra()
    server._tick_hook = player.tick
    server._command_hook = player.on_message
    server.player = player
    if start:
        server.start()
    log.info("replaying %s (%.1f s to %.1f s)", recording, data.t_start, data.t_end)
    return server


__all__ = ["ReplayData", "ReplayPlayer", "load_replay", "serve_replay"]
