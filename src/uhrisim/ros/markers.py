"""Markers (visualization_msgs/MarkerArray) of what the simulation shows: the static scene,
the sonar perception's detections and tracks; and the sensor mounts on ``/tf_static``.

A marker is first a spec, a dict in uhrisim's frames (world NED): ``ns``, ``id``,
``type`` (``"box"``, ``"sphere"``, ``"cylinder"``, ``"line_strip"``, ``"line_list"``,
``"points"``, ``"mesh"``, ``"triangle_list"``), ``position_ned`` (m, default origin),
``rotation`` (3x3 body FRD -> NED, default identity), ``scale`` (m, full extents along
the body axes), ``color`` (r, g, b, a in 0..1), ``points_ned`` ((N, 3) world NED, for the
lines, points and triangle lists — three vertices a triangle, the way to ship a mesh
inside a message), ``mesh_resource`` (URI, for ``mesh``), optional ``action``
(``"add"``, ``"delete"``, ``"deleteall"``) and ``text``; unknown keys are errors. Points
are written in the marker's own frame (world ENU -> local FLU). :func:`markers` is the one
translation of specs to the message, for the recording and the live bridge alike.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import enu_from_ned, enu_rotation_from_ned, quaternion_from_matrix
from uhrisim.ros import cdr
from uhrisim.ros.convert import optical_rotation
from uhrisim.ros.messages import rotation, vector
from uhrisim.ros.topics import camera_frame

logger = logging.getLogger(__name__)

#: visualization_msgs/Marker type constants of the marker kinds uhrisim writes.
MARKER_TYPES: dict[str, int] = {
    "box": 1,  # CUBE
    "sphere": 2,  # SPHERE
    "cylinder": 3,  # CYLINDER
    "line_strip": 4,  # LINE_STRIP
    "line_list": 5,  # LINE_LIST
    "points": 8,  # POINTS
    "mesh": 10,  # MESH_RESOURCE
    "triangle_list": 11,  # TRIANGLE_LIST
}
_MARKER_ACTIONS = {"add": 0, "delete": 2, "deleteall": 3}
_MARKER_KEYS = frozenset(
    {"ns", "id", "type", "position_ned", "rotation", "scale", "color", "points_ned",
     "mesh_resource", "action", "text"}
)
_MARKER_REQUIRED = ("ns", "id", "type")
_POINT_MARKERS = frozenset({"line_strip", "line_list", "points", "triangle_list"})
#: Triangles per scene object sent to live ROS viewers; larger meshes (a fine sea floor)
#: are thinned, every k-th triangle kept, to keep the one-off scene message small and fast.
SCENE_MAX_TRIANGLES_PER_OBJECT = 20_000

# Track colours (r, g, b, a): the diver track, other confirmed tracks, tentative ones.
_DIVER_RGBA = (0.1, 0.9, 0.2, 0.9)
_CLUTTER_RGBA = (1.0, 0.55, 0.0, 0.8)
_TENTATIVE_RGBA = (0.6, 0.6, 0.6, 0.5)
_DETECTION_RGBA = (0.2, 0.6, 1.0, 0.6)
MARKER_HEIGHT_M = 0.1  # thickness of the flat detection and track markers

# Marker colours by material name (r, g, b, a); others get the default.
_MATERIAL_RGBA = {
    "sand": (0.76, 0.70, 0.50, 1.0),
    "sand_rippled": (0.76, 0.70, 0.50, 1.0),
    "mud": (0.45, 0.38, 0.30, 1.0),
    "rock": (0.50, 0.50, 0.50, 1.0),
    "concrete": (0.70, 0.70, 0.68, 1.0),
    "steel": (0.55, 0.57, 0.60, 1.0),
    "wood": (0.55, 0.40, 0.25, 1.0),
}
_DEFAULT_RGBA = (0.6, 0.6, 0.6, 1.0)



def markers(t_ns: int, specs: Sequence[Mapping[str, Any]], world_frame: str,
            where: str) -> bytes:
    """visualization_msgs/MarkerArray of ``specs`` (module docstring) in the world frame
    (ENU), stamped ``t_ns``."""
    return cdr.encode_marker_array([marker_fields(t_ns, m, i, world_frame, where)
                                    for i, m in enumerate(specs)])


def marker_fields(t_ns: int, spec: Mapping[str, Any], index: int, world_frame: str,
                  where: str) -> dict[str, Any]:
    """The fields of visualization_msgs/Marker number ``index`` of a MarkerArray from its
    spec (:func:`markers`), for :func:`uhrisim.ros.cdr.encode_marker_array`."""
    where = f"{where}: marker[{index}]"
    unknown = set(spec) - _MARKER_KEYS
    if unknown:
        raise ConfigError(
            f"unknown keys {sorted(unknown)} (known: {sorted(_MARKER_KEYS)})", where=where
        )
    missing = [k for k in _MARKER_REQUIRED if k not in spec]
    if missing:
        raise ConfigError(f"missing keys {missing}", where=where)
    kind = spec["type"]
    if kind not in MARKER_TYPES:
        raise ConfigError(
            f"type {kind!r} is not one of {sorted(MARKER_TYPES)}", where=where
        )
    action = spec.get("action", "add")
    if action not in _MARKER_ACTIONS:
        raise ConfigError(
            f"action {action!r} is not one of {sorted(_MARKER_ACTIONS)}", where=where
        )
    pos_ned = vector(spec.get("position_ned", (0.0, 0.0, 0.0)), 3, "position_ned", where)
    rot_ned = rotation(spec.get("rotation", np.eye(3)), "rotation", where)
    scale = vector(spec.get("scale", (1.0, 1.0, 1.0)), 3, "scale", where)
    color = vector(spec.get("color", (0.5, 0.5, 0.5, 1.0)), 4, "color", where)
    pos_enu = enu_from_ned(pos_ned)
    rot_enu = enu_rotation_from_ned(rot_ned)
    q = quaternion_from_matrix(rot_enu)
    points = np.zeros((0, 3))
    if "points_ned" in spec:
        pts = np.asarray(spec["points_ned"], dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
            raise ConfigError("points_ned must be finite with shape (N, 3)", where=where)
        # Marker points live in the marker's own frame: world ENU → local FLU.
        points = (enu_from_ned(pts) - pos_enu) @ rot_enu
        if kind == "triangle_list" and len(points) % 3:
            raise ConfigError(
                f"a triangle_list needs 3k points, got {len(points)}", where=where
            )
    elif kind in ("line_strip", "triangle_list"):
        raise ConfigError(f"a {kind} marker needs points_ned", where=where)
    if kind == "mesh" and "mesh_resource" not in spec:
        raise ConfigError("a mesh marker needs mesh_resource (a URI)", where=where)
    sec, nanosec = divmod(t_ns, 1_000_000_000)
    return {
        "sec": sec,
        "nanosec": nanosec,
        "frame_id": world_frame,
        "ns": str(spec["ns"]),
        "id": int(spec["id"]),
        "type": MARKER_TYPES[kind],
        "action": _MARKER_ACTIONS[action],
        "pose": (*pos_enu.tolist(), *q.tolist()),
        "scale": tuple(scale.tolist()),
        "color": tuple(color.tolist()),
        "points": points,
        "colors": np.zeros((0, 4)),
        "text": str(spec.get("text", "")),
        "mesh_resource": str(spec.get("mesh_resource", "")),
    }


def sensor_mounts(agent: Any, frame: Callable[[str], str]
                  ) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """The ``/tf_static`` rows of a simulated agent's sensor mounts, as
    :func:`uhrisim.ros.messages.static_transforms` takes them: ``base_link`` →
    ``<sonar>`` for each sonar (the frame of its topics, named as the sonar) and
    ``base_link`` →
    ``<camera>_optical`` for each camera (the frame of its topics: x right, y down, z
    forward). ``frame(name)`` is the agent's full frame name (``"rov/sonar"``)."""
    rows = []
    for slot in getattr(agent, "sonars", ()):
        rows.append((frame("base_link"), frame(slot.name), slot.sonar.mount_position,
                     slot.sonar.mount_rotation))
    for slot in getattr(agent, "cameras", ()):
        rows.append((frame("base_link"), frame(camera_frame(slot.name)),
                     slot.camera.mount_position,
                     optical_rotation(slot.camera.mount_rotation)))
    return rows


def scene_markers(scene: Any, max_triangles: int = 200_000) -> list[dict[str, Any]]:
    """The scene's static meshes as ``triangle_list`` marker specs (world NED).

    ``scene.static_objects`` items carry a trimesh ``mesh`` in world NED, a ``label``,
    a ``label_id`` and a ``material`` (its ``name`` picks the colour). Meshes past
    ``max_triangles`` in total are left out (logged), to keep the file small.
    """
    markers: list[dict[str, Any]] = []
    used = 0
    for obj in getattr(scene, "static_objects", ()):
        faces = np.asarray(obj.mesh.faces)
        if used + len(faces) > max_triangles:
            logger.warning(
                "scene object %r (%d triangles) not recorded: over the %d-triangle budget",
                obj.label, len(faces), max_triangles,
            )
            continue
        used += len(faces)
        verts = np.asarray(obj.mesh.vertices, dtype=float)[faces.reshape(-1)]
        markers.append({
            "ns": "scene",
            "id": int(obj.label_id),
            "type": "triangle_list",
            "points_ned": verts,
            "color": _MATERIAL_RGBA.get(getattr(obj.material, "name", ""), _DEFAULT_RGBA),
            "text": str(obj.label),
        })
    return markers


def perception_markers(seen: Any, depth_m: float) -> tuple[list[dict[str, Any]],
                                                           list[dict[str, Any]]]:
    """(detections, tracks) of a perception frame as marker specs in world NED at the
    sonar's depth ``depth_m`` (imaging sonars measure no elevation). Each list starts
    with a ``deleteall`` so a viewer shows only the latest ping's markers.

    Detections (ns ``detections``): a flat box per blob, centred on it, turned to its
    bearing, range extent × cross-range extent. Tracks (ns ``tracks``): a flat cylinder
    per track, 2σ of its position wide (green: the diver track; orange: other confirmed
    tracks; grey: tentative), with ``text`` "track <id> (<kind>) P(diver)=<p>" (kind:
    ``diver``, ``track`` or ``tentative``), and a line
    (ns ``track_velocity``) to where it will be in 1 s.
    """
    clear = {"ns": "detections", "id": 0, "type": "box", "action": "deleteall"}
    detections: list[dict[str, Any]] = [clear]
    yaw = float(seen.view.yaw)
    for i, b in enumerate(seen.blobs.blobs):
        a = yaw + float(b.bearing_rad)
        c, sn = np.cos(a), np.sin(a)
        detections.append({
            "ns": "detections", "id": i + 1, "type": "box",
            "position_ned": (b.north_m, b.east_m, depth_m),
            "rotation": np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]]),
            "scale": (max(b.range_extent_m, 0.05), max(b.cross_extent_m, 0.05),
                      MARKER_HEIGHT_M),
            "color": _DETECTION_RGBA, "text": f"blob {i}: {b.cells} cells"})
    tracks: list[dict[str, Any]] = [{**clear, "ns": "tracks"}]
    for tr in seen.tracks:
        kind = "diver" if tr.id == seen.diver else "track" if tr.confirmed else "tentative"
        colour = {"diver": _DIVER_RGBA, "track": _CLUTTER_RGBA, "tentative": _TENTATIVE_RGBA}[kind]
        width = max(2.0 * tr.position_std_m, 0.1)
        tracks.append({
            "ns": "tracks", "id": tr.id, "type": "cylinder",
            "position_ned": (tr.north, tr.east, depth_m),
            "scale": (width, width, MARKER_HEIGHT_M), "color": colour,
            "text": f"track {tr.id} ({kind}) P(diver)={tr.diver_probability:.2f}"})
        tracks.append({
            "ns": "track_velocity", "id": tr.id, "type": "line_strip", "color": colour,
            "points_ned": np.array([[tr.north, tr.east, depth_m],
                                    [tr.north + tr.v_north, tr.east + tr.v_east, depth_m]])})
    return detections, tracks


def decimate_triangle_markers(
    markers: Sequence[dict[str, Any]], max_triangles: int = SCENE_MAX_TRIANGLES_PER_OBJECT
) -> list[dict[str, Any]]:
    """Copies of ``markers`` whose ``triangle_list`` point lists hold at most
    ``max_triangles`` triangles (every k-th triangle kept, for display only)."""
    out = []
    for m in markers:
        if m.get("type") == "triangle_list":
            pts = np.asarray(m["points_ned"], dtype=float).reshape(-1, 3, 3)
            if len(pts) > max_triangles:
                step = int(np.ceil(len(pts) / max_triangles))
                m = {**m, "points_ned": pts[::step].reshape(-1, 3)}
        out.append(m)
    return out
