"""The recorder as a simulation publish hook (``uhrisim.sim.simulation.Hook``).

:class:`McapRecordingHook` turns each :class:`~uhrisim.sim.hooks.TickFrame` into
:class:`~uhrisim.record.McapRecorder` calls: agent odometry, pose, ``/tf`` and
``/clock`` (every ``odom_every`` ticks), sonar pings (images, hits, sonar pose and the
marine_acoustic_msgs/ProjectedSonarImage), each sonar perception frame as markers
(:func:`perception_markers`), camera frames (image, camera info, depth, labels, camera
pose), helm decisions (and the live bridge's ``helm/desired_*`` and ``helm/mode``),
community posts and events; at start it writes the static scene as triangle-list markers,
each sonar's and camera's mount on ``/tf_static`` (:func:`sensor_mounts`) and the run's
seed/step as MCAP metadata; at the end it closes the file (recording an ``error`` event
if the run failed). Every topic the live ROS 2 bridge publishes is recorded under the
same name, type and frame (docs/bridges-ros2.md).

It only reads what it is handed (DESIGN.md: hooks are read-only) and touches the
simulation object only in ``on_start``/``on_end`` for ``seed``, ``dt``, ``t`` and
``scene``, by attribute, so it stays importable without the simulation package.
"""

from __future__ import annotations

import logging
import numbers
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from uhrisim.bridges.ros2.convert import label_image_mono8, optical_rotation
from uhrisim.core.errors import ConfigError
from uhrisim.record.mcap_recorder import McapRecorder
from uhrisim.record.rosbag2 import write_metadata
from uhrisim.sensors.sonar.cloud import cloud_hits

logger = logging.getLogger(__name__)

__all__ = ["McapRecordingHook", "perception_markers", "ros_name", "scene_markers",
           "sensor_mounts"]

# Track colours (r, g, b, a): the diver track, other confirmed tracks, tentative ones.
_DIVER_RGBA = (0.1, 0.9, 0.2, 0.9)
_CLUTTER_RGBA = (1.0, 0.55, 0.0, 0.8)
_TENTATIVE_RGBA = (0.6, 0.6, 0.6, 0.5)
_DETECTION_RGBA = (0.2, 0.6, 1.0, 0.6)
MARKER_HEIGHT_M = 0.1  # thickness of the flat detection and track markers

_NOT_NAME = re.compile(r"[^A-Za-z0-9_]")
# Marker colours by material name (r, g, b, a); others get the default.
_MATERIAL_RGBA = {
    "sand": (0.76, 0.70, 0.50, 1.0),
    "mud": (0.45, 0.38, 0.30, 1.0),
    "rock": (0.50, 0.50, 0.50, 1.0),
    "concrete": (0.70, 0.70, 0.68, 1.0),
    "steel": (0.55, 0.57, 0.60, 1.0),
    "wood": (0.55, 0.40, 0.25, 1.0),
}
_DEFAULT_RGBA = (0.6, 0.6, 0.6, 1.0)


def ros_name(name: str) -> str:
    """A ROS-name-safe version of an agent name: other characters become ``_``.

    Names already valid (letter first, then letters, digits, ``_``) are unchanged.
    """
    out = _NOT_NAME.sub("_", str(name))
    return out if out[:1].isalpha() else f"a_{out}"


def sensor_mounts(agent: Any, frame: Callable[[str], str]
                  ) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """The ``/tf_static`` rows of a simulated agent's sensor mounts, as
    :meth:`McapRecorder.write_static_transforms` and the ROS 2 bridge's
    ``publish_static_transforms`` take them: ``base_link`` → ``<sonar>`` for each sonar
    (the frame of its topics, named as the sonar) and ``base_link`` →
    ``<camera>_optical`` for each camera (the frame of its topics: x right, y down, z
    forward). ``frame(name)`` is the agent's full frame name (``"rov/sonar"``)."""
    rows = []
    for slot in getattr(agent, "sonars", ()):
        rows.append((frame("base_link"), frame(slot.name), slot.sonar.mount_position,
                     slot.sonar.mount_rotation))
    for slot in getattr(agent, "cameras", ()):
        rows.append((frame("base_link"), frame(f"{slot.name}_optical"),
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


class McapRecordingHook:
    """Record a simulation run to ``path`` (see :mod:`uhrisim.record.mcap_recorder`).

    Parameters
    ----------
    path:
        Output ``.mcap`` file.
    odom_every:
        Record odometry every this many ticks (1: every physics tick).
    record_images, record_points:
        Whether sonar pings write their polar/fan images and hit points.
    record_scene:
        Write the static scene as markers at start (``scene_markers``).
    sonar_every:
        Record every this-many-th ping of each sonar (1: all; images are large).
    record_camera, camera_every:
        Whether camera frames are recorded (image, camera info, depth, labels, pose), and
        every this-many-th frame of each camera.
    chunk_size, flush_period_s:
        Passed to :class:`McapRecorder`; by default a chunk is also closed at least every
        simulated second, so a killed run loses at most about one second.
    rosbag2_metadata:
        At the end, write ``metadata.yaml`` beside the file: its folder becomes a rosbag2
        bag (:mod:`uhrisim.record.rosbag2`; keep one recording per folder then).
    """

    def __init__(
        self,
        path: Path | str,
        *,
        odom_every: int = 1,
        record_images: bool = True,
        record_points: bool = True,
        record_scene: bool = True,
        sonar_every: int = 1,
        record_camera: bool = True,
        camera_every: int = 1,
        chunk_size: int = 256 * 1024,
        flush_period_s: float | None = 1.0,
        rosbag2_metadata: bool = True,
    ) -> None:
        if int(odom_every) < 1:
            raise ConfigError(f"odom_every must be >= 1, got {odom_every}",
                              where="McapRecordingHook")
        self.path = Path(path)
        self.odom_every = int(odom_every)
        self.record_images = record_images
        self.record_points = record_points
        self.record_scene = record_scene
        if int(sonar_every) < 1:
            raise ConfigError(f"sonar_every must be >= 1, got {sonar_every}",
                              where="McapRecordingHook")
        self.sonar_every = int(sonar_every)
        self._pings_seen: dict[str, int] = {}
        if int(camera_every) < 1:
            raise ConfigError(f"camera_every must be >= 1, got {camera_every}",
                              where="McapRecordingHook")
        self.record_camera = record_camera
        self.camera_every = int(camera_every)
        self._images_seen: dict[str, int] = {}
        self._chunk_size = chunk_size
        self.rosbag2_metadata = rosbag2_metadata
        self._flush_period_s = flush_period_s
        self._rec: McapRecorder | None = None
        self._names: dict[str, str] = {}

    @property
    def recorder(self) -> McapRecorder | None:
        return self._rec

    def _name(self, agent: str) -> str:
        name = self._names.get(agent)
        if name is None:
            name = ros_name(agent)
            if name != agent:
                logger.info("recording agent %r as %r (ROS name rules)", agent, name)
            self._names[agent] = name
        return name

    def on_start(self, sim: Any) -> None:
        meta = {"seed": str(getattr(sim, "seed", "")), "dt": repr(getattr(sim, "dt", ""))}
        scenario = getattr(sim, "scenario", None)
        if scenario is not None and getattr(scenario, "name", None):
            meta["scenario"] = str(scenario.name)
        self._rec = McapRecorder(
            self.path, chunk_size=self._chunk_size, flush_period_s=self._flush_period_s,
            metadata={"uhrisim": meta},
        )
        t = float(getattr(sim, "t", 0.0))
        if self.record_scene and getattr(sim, "scene", None) is not None:
            markers = scene_markers(sim.scene)
            if markers:
                self._rec.write_scene_markers(t, markers)
        mounts = []
        for agent_name, agent in getattr(sim, "agents", {}).items():
            name = self._name(agent_name)
            mounts += sensor_mounts(agent, lambda frame, name=name: f"{name}/{frame}")
        if mounts:
            self._rec.write_static_transforms(t, mounts)

    def on_tick(self, frame: Any) -> None:
        rec = self._rec
        if rec is None:
            return
        t = float(frame.t)
        if frame.tick % self.odom_every == 0:
            rec.write_clock(t)
            for agent, snap in frame.agents.items():
                nav = snap.nav
                rec.write_odometry(self._name(agent), t, nav.position_ned, nav.yaw,
                                   nav.velocity_body, nav.yaw_rate)
        for key, ping in frame.pings.items():
            seen = self._pings_seen.get(key, 0)
            self._pings_seen[key] = seen + 1
            if seen % self.sonar_every == 0:
                self._write_ping(rec, key, ping)
        for key, image in getattr(frame, "images", {}).items():
            seen = self._images_seen.get(key, 0)
            self._images_seen[key] = seen + 1
            if self.record_camera and seen % self.camera_every == 0:
                agent, sensor = key.split("/", 1)
                self._write_image(rec, self._name(agent), sensor, image)
        for agent, h in frame.helm.items():
            rec.write_helm_topics(self._name(agent), t, h.heading_deg, h.speed, h.depth,
                                  h.mode)
            rec.write_helm_decision(
                self._name(agent), t, h.heading_deg, h.speed, h.depth, h.contributions,
                h.mode, h.active, total=h.total, all_stop_reason=h.all_stop_reason or "",
            )
        for post in frame.posts:
            value = post.value
            if not isinstance(value, (str, numbers.Real)):
                value = str(value)
            rec.write_variable(self._name(post.community), float(post.t), str(post.var),
                               value, str(post.source))
        for ev in frame.events:
            rec.write_event(float(ev.t), str(ev.kind), str(ev.detail))
        for key, seen in getattr(frame, "perception", {}).items():
            name = self._name(key.split("/", 1)[0])
            depth = float(frame.pings[key].position_ned[2])
            detections, tracks = perception_markers(seen, depth)
            rec.write_markers(f"/{name}/perception/detections", t, detections)
            rec.write_markers(f"/{name}/perception/tracks", t, tracks)

    def _write_ping(self, rec: McapRecorder, key: str, ping: Any) -> None:
        agent_name, sensor = key.split("/", 1)
        agent = self._name(agent_name)
        points, intensity = cloud_hits(ping.cloud) if self.record_points else (None, None)
        rec.write_sonar(
            agent,
            float(ping.t),
            ping.polar_u8 if self.record_images else None,
            ping.fan_u8 if self.record_images else None,
            points,
            intensity,
            f"{agent}/{sensor}",
            (ping.position_ned, ping.rotation_ned_from_sonar),
            sensor=sensor,
        )
        if self.record_images:
            rec.write_sonar_image(agent, float(ping.t), ping.polar_u8, ping.beam_angles_rad,
                                  ping.bin_ranges_m, ping.info.frequency_hz,
                                  ping.info.sound_speed_m_s, f"{agent}/{sensor}", sensor=sensor)

    @staticmethod
    def _write_image(rec: McapRecorder, agent: str, sensor: str, image: Any) -> None:
        rec.write_camera(agent, float(image.t), image.rgb, image.depth_m,
                         label_image_mono8(image.labels), image.K,
                         f"{agent}/{sensor}_optical",
                         (image.position_ned, image.rotation_ned_from_camera), sensor=sensor)

    def on_end(self, sim: Any, error: BaseException | None) -> None:
        rec = self._rec
        if rec is None:
            return
        if error is not None and not rec.closed:
            rec.write_event(float(getattr(sim, "t", 0.0)), "error",
                            f"{type(error).__name__}: {error}")
        was_open = not rec.closed
        rec.close()
        if self.rosbag2_metadata and was_open:
            write_metadata(self.path)

    def summary(self) -> dict[str, Any]:
        rec = self._rec
        if rec is None:
            return {"path": str(self.path), "messages": 0}
        counts = rec.message_counts
        return {"path": str(self.path), "messages": sum(counts.values()),
                "topics": counts, "bytes": rec.bytes_written}

