"""Record a simulation run to MCAP with ROS 2 message schemas.

The recorder is a read-only publish hook: the simulation loop hands it copies of
what happened (poses, sonar images, helm decisions, variables, scene, events) and it
writes them, converted to ROS conventions, into an MCAP file that Foxglove/Lichtblick,
``ros2 bag`` and ``rosbags`` open.

Frames (docs/conventions.md, reference/ros2.md): inside uhrisim the world is NED and
bodies are FRD; ROS speaks REP-103, world ENU and body FLU. The conversion happens
here and only here, with ``uhrisim.core.frames``:

* world frame ``map`` (configurable) is ENU: x east, y north, z up;
* ``<agent>/base_link`` is the vehicle's FLU body frame (x forward, y port, z up);
* a sonar frame (e.g. ``rov/sonar``) is the sonar's FLU frame;
* a camera optical frame (e.g. ``rov/camera_optical``) follows REP-103's optical
  convention: x right, y down, z along the optical axis.

Topics (``<agent>`` is the community name, ``<sonar>`` and ``<camera>`` a sensor's name
on it, by default ``sonar`` and ``camera``; the live ROS 2 bridge publishes the same):

==================================  ============================================  ==================
topic                               type                                          frame
==================================  ============================================  ==================
``/<agent>/odom``                   nav_msgs/msg/Odometry                         map → base_link
``/<agent>/pose``                   geometry_msgs/msg/PoseStamped                 map
``/tf``                             tf2_msgs/msg/TFMessage                        map → odom →
                                                                                  base_link
``/tf_static``                      tf2_msgs/msg/TFMessage                        base_link → sonar;
                                                                                  base_link →
                                                                                  camera optical
``/<agent>/<sonar>/polar``          sensor_msgs/msg/Image (mono8)                 sonar frame
``/<agent>/<sonar>/fan``            sensor_msgs/msg/Image (mono8)                 sonar frame
``/<agent>/<sonar>/points``         sensor_msgs/msg/PointCloud2                   sonar frame (FLU)
``/<agent>/<sonar>/pose``           geometry_msgs/msg/PoseStamped                 map
``/<agent>/<sonar>/image``          marine_acoustic_msgs/msg/ProjectedSonarImage  sonar frame
``/<agent>/<camera>/image_raw``      sensor_msgs/msg/Image (rgb8)                  camera optical
``/<agent>/<camera>/camera_info``     sensor_msgs/msg/CameraInfo                    camera optical
``/<agent>/<camera>/depth``         sensor_msgs/msg/Image (32FC1)                 camera optical
``/<agent>/<camera>/labels``        sensor_msgs/msg/Image (mono8)                 camera optical
``/<agent>/<camera>/pose``          geometry_msgs/msg/PoseStamped                 map
``/<agent>/helm/desired_*``         std_msgs/msg/Float64                          —
``/<agent>/helm/mode``              std_msgs/msg/String                           —
``/<agent>/helm/decision``          uhrisim_msgs/msg/HelmDecision                 —
``/<agent>/vars``                   uhrisim_msgs/msg/Variable                     —
``/scene/markers``                  visualization_msgs/msg/MarkerArray            map (ENU)
``/events``                         uhrisim_msgs/msg/Event                        map
``/clock``                          rosgraph_msgs/msg/Clock                       —
==================================  ============================================  ==================

A sensor frame on ``/tf_static`` (:meth:`McapRecorder.write_static_transforms`: the sonar
and camera mounts) is not written on ``/tf`` at each ping or picture; without one, each
puts ``map → sensor frame`` there.
The latched topics carry their offered QoS in the channel metadata
(:mod:`uhrisim.record.rosbag2`, which writes the folder's ``metadata.yaml``).

Time: ``header.stamp`` and the MCAP ``log_time``/``publish_time`` are all the
simulation time (nanoseconds since the start of the run); nothing in the file depends
on the wall clock, so the same sequence of calls gives a byte-identical file (for a
given ``mcap``/``zstandard`` version).

Crash safety: messages are grouped in chunks of about ``chunk_size`` bytes; each
finished chunk (with its schemas, channels and message index) is handed to the
operating system at once, without user-space buffering. A run killed with SIGKILL
leaves a file without summary or footer that ``uhrisim.record.reader`` reads up to
its last complete chunk. ``flush_period_s`` bounds how much simulated time a kill can
lose.
"""

from __future__ import annotations

import logging
import math
import os
import re
import struct
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType
from mcap.writer import Writer as McapWriter
from mcap_ros2._dynamic import serialize_dynamic

from uhrisim import __version__ as uhrisim_version
from uhrisim.bridges.ros2.convert import (
    cloud_xyzi_flu,
    mount_transform,
    odom_fields_from_ned,
    optical_rotation,
    pose_enu_from_ned,
    tf_chain,
    tf_chain_frames,
)
from uhrisim.bridges.ros2.spec import ROS_NAME_TOKEN
from uhrisim.core.errors import ConfigError, UhrisimError
from uhrisim.core.frames import (
    enu_from_ned,
    enu_rotation_from_ned,
    quaternion_from_matrix,
)
from uhrisim.record import cdr, uhrisim_msgs
from uhrisim.record.msgdefs import schema_text
from uhrisim.record.rosbag2 import channel_metadata

logger = logging.getLogger(__name__)

__all__ = ["MARKER_TYPES", "McapRecorder"]

# visualization_msgs/Marker type constants for the marker kinds the scene uses.
MARKER_TYPES: dict[str, int] = {
    "box": 1,  # CUBE
    "sphere": 2,  # SPHERE
    "cylinder": 3,  # CYLINDER
    "line_strip": 4,  # LINE_STRIP
    "mesh": 10,  # MESH_RESOURCE
    "triangle_list": 11,  # TRIANGLE_LIST
}
_MARKER_ACTIONS = {"add": 0, "delete": 2, "deleteall": 3}
_MARKER_KEYS = frozenset(
    {"ns", "id", "type", "position_ned", "rotation", "scale", "color", "points_ned",
     "mesh_resource", "action", "text"}
)
_MARKER_REQUIRED = ("ns", "id", "type")

_COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}
_FRAME_ID = re.compile(r"^[A-Za-z][A-Za-z0-9_/]*$")


def _library_identifier() -> str:
    return f"uhrisim/{uhrisim_version}; {LIBRARY_IDENTIFIER}"


class _UnbufferedSink:
    """Append-only file that hands every write straight to the OS (no user-space buffer).

    The MCAP writer writes a chunk only once it is complete, so after a SIGKILL the
    file ends at a chunk boundary or inside the one chunk being written.
    """

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._pos = 0

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data).cast("B")
        total = len(view)
        while view:
            written = os.write(self._fd, view)
            view = view[written:]
        self._pos += total
        return total

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered here; the OS holds what was written."""

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


def _stamp_ns(t: float, where: str) -> int:
    """Simulation time in seconds → integer nanoseconds (rounded), checked finite and ≥ 0."""
    tf = float(t)
    if not math.isfinite(tf) or tf < 0.0:
        raise ConfigError(f"time must be a finite number >= 0 s, got {t!r}", where=where)
    return round(tf * 1e9)


def _vec(value: Any, n: int, name: str, where: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n,) or not np.isfinite(arr).all():
        raise ConfigError(f"{name} must be {n} finite numbers, got {value!r}", where=where)
    return arr


def _rotation(value: Any, name: str, where: str) -> np.ndarray:
    r = np.asarray(value, dtype=float)
    if r.shape != (3, 3) or not np.all(np.isfinite(r)):
        raise ConfigError(f"{name} must be a finite 3x3 matrix", where=where)
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0.0:
        raise ConfigError(f"{name} is not a proper rotation matrix", where=where)
    return r


def _check_name(value: str, what: str, where: str) -> str:
    if not isinstance(value, str) or not ROS_NAME_TOKEN.match(value):
        raise ConfigError(
            f"{what} {value!r} is not a ROS name (letter, then letters/digits/_)", where=where
        )
    return value


def _check_frame(value: str, where: str) -> str:
    if not isinstance(value, str) or not _FRAME_ID.match(value):
        raise ConfigError(f"frame id {value!r} is not a valid ROS frame name", where=where)
    return value


def _mono8(image: Any, name: str, where: str) -> np.ndarray:
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim != 2 or arr.size == 0:
        raise ConfigError(
            f"{name} must be a non-empty 2-D uint8 array, got {arr.dtype} shape {arr.shape}",
            where=where,
        )
    return arr


def _pose(value: Any, sensor: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """A sensor's ``(position (3,), rotation (3, 3))`` in NED, checked."""
    try:
        position, rotation = value
    except (TypeError, ValueError):
        raise ConfigError(
            f"{sensor}_pose_ned must be (position (3,), rotation (3, 3))", where=where
        ) from None
    return (_vec(position, 3, f"{sensor} position", where),
            _rotation(rotation, f"{sensor} rotation", where))


def _intrinsics(value: Any, where: str) -> np.ndarray:
    """A finite 3x3 intrinsic matrix."""
    k = np.asarray(value, dtype=float)
    if k.shape != (3, 3) or not np.all(np.isfinite(k)):
        raise ConfigError(f"K must be a finite 3x3 matrix, got shape {k.shape}", where=where)
    return k


class McapRecorder:
    """Write a run to an MCAP file with ROS 2 (``ros2msg``/CDR) schemas.

    Parameters
    ----------
    path:
        Output file (``.mcap``); created or truncated. Its folder must exist.
    chunk_size:
        Target uncompressed chunk size in bytes: a chunk is closed and written as soon
        as it holds more than this. Smaller chunks lose less on a crash and compress less.
    world_frame:
        The ENU world frame id (REP-105 ``map``).
    compression:
        ``"zstd"`` (default), ``"lz4"`` or ``"none"``, per chunk.
    flush_period_s:
        If given, also close the current chunk whenever this much *simulation* time has
        passed since the last one, bounding what a crash loses. ``None``: by size only.
    metadata:
        Optional MCAP metadata records ``{name: {key: value}}`` written after the header
        (e.g. scenario name and seed). Keep wall-clock times out of it for reproducible
        files.

    Use as a context manager, or call :meth:`close` (idempotent).
    """

    def __init__(
        self,
        path: Path | str,
        chunk_size: int = 256 * 1024,
        world_frame: str = "map",
        *,
        compression: str = "zstd",
        flush_period_s: float | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
    ) -> None:
        where = "McapRecorder"
        if int(chunk_size) < 1:
            raise ConfigError(f"chunk_size must be >= 1 byte, got {chunk_size}", where=where)
        if compression not in _COMPRESSION:
            raise ConfigError(
                f"compression must be one of {sorted(_COMPRESSION)}, got {compression!r}",
                where=where,
            )
        if flush_period_s is not None and not (flush_period_s > 0.0):
            raise ConfigError(
                f"flush_period_s must be > 0 or None, got {flush_period_s}", where=where
            )
        self.path = Path(path)
        self.world_frame = _check_frame(world_frame, where)
        self._flush_period_ns = (
            None if flush_period_s is None else _stamp_ns(flush_period_s, where)
        )
        try:
            self._sink = _UnbufferedSink(self.path)
        except OSError as exc:
            raise UhrisimError(f"{self.path}: cannot open for writing ({exc.strerror})") from exc
        self._writer = McapWriter(
            self._sink,
            chunk_size=int(chunk_size),
            compression=_COMPRESSION[compression],
        )
        self._writer.start(profile="ros2", library=_library_identifier())
        for name, data in (metadata or {}).items():
            self._writer.add_metadata(str(name), {str(k): str(v) for k, v in data.items()})
        self._schema_ids: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self._odom_encoders: dict[str, tuple[cdr.OdometryEncoder, cdr.TransformEncoder]] = {}
        self._pose = cdr.PoseStampedEncoder(self.world_frame)
        self._static_children: set[str] = set()  # frames placed by /tf_static
        self._helm_modes: dict[str, str] = {}  # the last /<agent>/helm/mode written
        self._counts: dict[str, int] = {}
        self._dynamic: dict[str, Any] = {}  # typename -> mcap_ros2's encoder
        self._last_flush_ns = 0
        self._closed = False

    # ------------------------------------------------------------------ plumbing
    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def message_counts(self) -> dict[str, int]:
        """Messages written so far, per topic (a copy)."""
        return dict(self._counts)

    @property
    def bytes_written(self) -> int:
        """Bytes handed to the OS so far (the open chunk is not counted)."""
        return self._sink.tell()

    def _check_open(self, where: str) -> None:
        if self._closed:
            raise UhrisimError(f"McapRecorder.{where}: recorder for {self.path} is closed")

    def _channel(self, topic: str, typename: str) -> int:
        channel_id = self._channels.get(topic)
        if channel_id is None:
            schema_id = self._schema_ids.get(typename)
            if schema_id is None:
                schema_id = self._writer.register_schema(
                    typename, "ros2msg", schema_text(typename).encode("utf-8")
                )
                self._schema_ids[typename] = schema_id
            channel_id = self._writer.register_channel(topic, "cdr", schema_id,
                                                       channel_metadata(topic))
            self._channels[topic] = channel_id
            self._sequence[channel_id] = 0
        return channel_id

    def _write(self, topic: str, typename: str, t_ns: int, data: bytes) -> None:
        channel_id = self._channel(topic, typename)
        seq = self._sequence[channel_id]
        self._sequence[channel_id] = seq + 1
        self._writer.add_message(
            channel_id=channel_id, log_time=t_ns, data=data, publish_time=t_ns, sequence=seq
        )
        self._counts[topic] = self._counts.get(topic, 0) + 1
        if self._flush_period_ns is not None and t_ns - self._last_flush_ns >= (
            self._flush_period_ns
        ):
            self._writer.flush()
            self._last_flush_ns = t_ns

    def _encode_dynamic(self, typename: str, message: Mapping[str, Any]) -> bytes:
        """Encode with mcap_ros2's schema-driven encoder (the general, reference path)."""
        encoder = self._dynamic.get(typename)
        if encoder is None:
            encoder = serialize_dynamic(typename, schema_text(typename))[typename]
            self._dynamic[typename] = encoder
        return encoder(message)

    @staticmethod
    def _header(t_ns: int, frame_id: str) -> dict[str, Any]:
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame_id}

    # ------------------------------------------------------------------ writers
    def write_odometry(
        self,
        agent: str,
        t: float,
        position_ned: Sequence[float] | np.ndarray,
        yaw_rad: float,
        velocity_body_frd: Sequence[float] | np.ndarray,
        yaw_rate: float,
    ) -> None:
        """An agent's pose and velocity: ``/<agent>/odom``, ``/<agent>/pose`` and ``/tf``
        ``map`` → ``<agent>/odom`` (identity) → ``<agent>/base_link`` (REP 105).

        ``position_ned`` (m, world NED), ``yaw_rad`` (compass yaw, rad),
        ``velocity_body_frd`` (m/s, body FRD: surge, sway, heave), ``yaw_rate`` (rad/s,
        clockwise from above). Written as pose in ENU, twist in the FLU child frame
        (REP-103; nav_msgs/Odometry gives the twist in ``child_frame_id``). Roll and
        pitch are zero (conventions). Covariances are zero: this is ground truth.
        """
        where = "McapRecorder.write_odometry"
        self._check_open("write_odometry")
        _check_name(agent, "agent", where)
        t_ns = _stamp_ns(t, where)
        p_ned = _vec(position_ned, 3, "position_ned", where)
        v_frd = _vec(velocity_body_frd, 3, "velocity_body_frd", where)
        yaw = float(yaw_rad)
        r = float(yaw_rate)
        if not (math.isfinite(yaw) and math.isfinite(r)):
            raise ConfigError("yaw_rad and yaw_rate must be finite", where=where)
        f = odom_fields_from_ned(p_ned, yaw, v_frd, r)
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        encoders = self._odom_encoders.get(agent)
        if encoders is None:
            child = f"{agent}/base_link"
            first, *more = tf_chain_frames(agent, self.world_frame)
            encoders = (cdr.OdometryEncoder(self.world_frame, child),
                        cdr.TransformEncoder(*first, *more))
            self._odom_encoders[agent] = encoders
        p, qq = f.position_enu, f.orientation_xyzw
        self._write(
            f"/{agent}/odom",
            "nav_msgs/msg/Odometry",
            t_ns,
            encoders[0](sec, nanosec, p, qq, f.linear_flu, f.angular_flu),
        )
        self._write(f"/{agent}/pose", "geometry_msgs/msg/PoseStamped", t_ns,
                    self._pose(sec, nanosec, p, qq))
        (t0, q0), second = tf_chain(p, qq)
        self._write("/tf", "tf2_msgs/msg/TFMessage", t_ns,
                    encoders[1](sec, nanosec, t0, q0, second))

    def write_static_transforms(self, t: float, transforms: Sequence[tuple[str, str, Any, Any]]
                                ) -> None:
        """``/tf_static`` (one message with every static transform): each ``(parent,
        child, position_frd (3,) m, rotation_frd (3x3) child → parent)`` in body FRD
        terms, written in FLU (e.g. a sonar mount ``("rov/base_link", "rov/sonar", ...)``).
        A sensor frame placed here (a sonar's, a camera's optical frame) is no longer
        written on ``/tf`` with each ping or picture."""
        where = "McapRecorder.write_static_transforms"
        self._check_open("write_static_transforms")
        t_ns = _stamp_ns(t, where)
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        rows = []
        for parent, child, position_frd, rotation_frd in transforms:
            _check_frame(parent, where)
            _check_frame(child, where)
            xyz, q = mount_transform(_vec(position_frd, 3, "position_frd", where),
                                     _rotation(rotation_frd, "rotation_frd", where))
            rows.append((sec, nanosec, parent, child, xyz, q))
            self._static_children.add(child)
        self._write("/tf_static", "tf2_msgs/msg/TFMessage", t_ns, cdr.encode_tf_message(rows))

    def write_clock(self, t: float) -> None:
        """``/clock`` (rosgraph_msgs/msg/Clock): simulation time ``t`` (s)."""
        t_ns = _stamp_ns(t, "McapRecorder.write_clock")
        self._check_open("write_clock")
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        self._write("/clock", "rosgraph_msgs/msg/Clock", t_ns,
                    cdr.CDR_LE_HEADER + struct.pack("<iI", sec, nanosec))

    def write_sonar(
        self,
        agent: str,
        t: float,
        polar_u8: np.ndarray | None,
        fan_u8: np.ndarray | None,
        points_sonar_frame: np.ndarray | None,
        intensity: np.ndarray | None,
        sonar_frame: str,
        sonar_pose_ned: tuple[Sequence[float] | np.ndarray, np.ndarray],
        sensor: str = "sonar",
    ) -> None:
        """One ping of the agent's sonar named ``sensor``: polar and fan images, hit
        points, and the sonar's pose on /tf (topics ``/<agent>/<sensor>/...``).

        ``polar_u8`` ``(n_bins, n_beams)`` uint8 (row = range bin, column = beam) and
        ``fan_u8`` ``(H, W)`` uint8 go out as mono8 images; either may be ``None``.
        ``points_sonar_frame`` ``(N, 3)`` (m, sonar FRD) with ``intensity`` ``(N,)``
        (``None``: zeros) become a PointCloud2 (x, y, z, intensity float32) in the
        sonar's FLU frame. ``sonar_pose_ned = (position (3,), rotation (3, 3))`` is the
        sonar frame's world pose (FRD → NED); it is published on /tf as
        ``map → sonar_frame`` (ENU/FLU) with the ping's stamp.
        """
        where = "McapRecorder.write_sonar"
        self._check_open("write_sonar")
        _check_name(agent, "agent", where)
        _check_frame(sonar_frame, where)
        _check_name(sensor, "sensor", where)
        t_ns = _stamp_ns(t, where)
        pos_ned, rot_ned = _pose(sonar_pose_ned, "sonar", where)
        p_enu, q = pose_enu_from_ned(pos_ned, rot_ned)
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        polar = None if polar_u8 is None else _mono8(polar_u8, "polar_u8", where)
        fan = None if fan_u8 is None else _mono8(fan_u8, "fan_u8", where)
        cloud = None
        if points_sonar_frame is not None:
            pts = np.asarray(points_sonar_frame, dtype=float)
            if pts.size == 0:
                pts = pts.reshape(0, 3)
            if pts.ndim != 2 or pts.shape[1] != 3:
                raise ConfigError(
                    f"points_sonar_frame must have shape (N, 3), got {pts.shape}", where=where
                )
            if intensity is None:
                inten = np.zeros(pts.shape[0])
            else:
                inten = np.asarray(intensity, dtype=float).reshape(-1)
                if inten.shape[0] != pts.shape[0]:
                    raise ConfigError(
                        f"intensity has {inten.shape[0]} values for {pts.shape[0]} points",
                        where=where,
                    )
            if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(inten))):
                raise ConfigError("points and intensity must be finite", where=where)
            cloud = cloud_xyzi_flu(pts, inten)
        elif intensity is not None:
            raise ConfigError("intensity given without points_sonar_frame", where=where)

        if sonar_frame not in self._static_children:  # else base_link → sonar on /tf_static
            self._write(
                "/tf",
                "tf2_msgs/msg/TFMessage",
                t_ns,
                cdr.encode_tf_message([(sec, nanosec, self.world_frame, sonar_frame, p_enu,
                                        q)]),
            )
        self._write(f"/{agent}/{sensor}/pose", "geometry_msgs/msg/PoseStamped", t_ns,
                    self._pose(sec, nanosec, p_enu, q))
        if polar is not None:
            self._write(
                f"/{agent}/{sensor}/polar",
                "sensor_msgs/msg/Image",
                t_ns,
                cdr.encode_image(sec, nanosec, sonar_frame, polar),
            )
        if fan is not None:
            self._write(
                f"/{agent}/{sensor}/fan",
                "sensor_msgs/msg/Image",
                t_ns,
                cdr.encode_image(sec, nanosec, sonar_frame, fan),
            )
        if cloud is not None:
            self._write(
                f"/{agent}/{sensor}/points",
                "sensor_msgs/msg/PointCloud2",
                t_ns,
                cdr.encode_pointcloud2(sec, nanosec, sonar_frame, cloud),
            )

    def write_camera(
        self,
        agent: str,
        t: float,
        rgb_u8: np.ndarray,
        depth_m: np.ndarray | None,
        labels_u8: np.ndarray | None,
        K: np.ndarray,
        camera_frame: str,
        camera_pose_ned: tuple[Sequence[float] | np.ndarray, np.ndarray],
        sensor: str = "camera",
    ) -> None:
        """One frame of the agent's camera named ``sensor`` (topics
        ``/<agent>/<sensor>/...``): the rgb8 image, its CameraInfo (pinhole, no distortion), the
        depth image (32FC1, metres along the optical axis, NaN where nothing was hit;
        REP-118) and the label image (mono8: label id + 1, 0 for open water), each
        optional but the image; and the optical frame's pose on ``/<agent>/camera/pose``
        (PoseStamped in the world frame, as ``sonar/pose``).

        ``camera_pose_ned = (position (3,), rotation (3, 3))`` is the camera's pose with
        the camera frame x forward, y right, z down (FRD-like) → NED; the optical frame
        (x right, y down, z forward) published is derived from it. A ``camera_frame`` on
        ``/tf_static`` (:meth:`write_static_transforms`, the mount) is not written on
        ``/tf``; without one, each frame puts ``map → camera_frame`` there.
        """
        where = "McapRecorder.write_camera"
        self._check_open("write_camera")
        _check_name(agent, "agent", where)
        _check_name(sensor, "sensor", where)
        _check_frame(camera_frame, where)
        t_ns = _stamp_ns(t, where)
        rgb = np.asarray(rgb_u8)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.size == 0:
            raise ConfigError(f"rgb_u8 must be a non-empty (H, W, 3) uint8 array, got "
                              f"{rgb.dtype} shape {rgb.shape}", where=where)
        height, width = rgb.shape[:2]
        k = _intrinsics(K, where)
        pos_ned, rot_ned = _pose(camera_pose_ned, "camera", where)
        p_enu, q = pose_enu_from_ned(pos_ned, optical_rotation(rot_ned))
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        if camera_frame not in self._static_children:  # else the mount on /tf_static
            self._write("/tf", "tf2_msgs/msg/TFMessage", t_ns, cdr.encode_tf_message(
                [(sec, nanosec, self.world_frame, camera_frame, p_enu, q)]))
        base = f"/{agent}/{sensor}"
        self._write(f"{base}/pose", "geometry_msgs/msg/PoseStamped", t_ns,
                    self._pose(sec, nanosec, p_enu, q))
        self._write(f"{base}/image_raw", "sensor_msgs/msg/Image", t_ns,
                    cdr.encode_image(sec, nanosec, camera_frame, rgb, "rgb8"))
        p = np.zeros((3, 4))
        p[:, :3] = k
        info = {
            "header": self._header(t_ns, camera_frame), "height": height, "width": width,
            "distortion_model": "plumb_bob", "d": [0.0] * 5, "k": k.reshape(-1).tolist(),
            "r": np.eye(3).reshape(-1).tolist(), "p": p.reshape(-1).tolist(),
            "binning_x": 0, "binning_y": 0,
            "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0,
                    "do_rectify": False},
        }
        self._write(f"{base}/camera_info", "sensor_msgs/msg/CameraInfo", t_ns,
                    self._encode_dynamic("sensor_msgs/msg/CameraInfo", info))
        if depth_m is not None:
            depth = np.asarray(depth_m, dtype="<f4")
            if depth.shape != (height, width):
                raise ConfigError(f"depth_m must have shape {(height, width)}, got "
                                  f"{depth.shape}", where=where)
            self._write(f"{base}/depth", "sensor_msgs/msg/Image", t_ns,
                        cdr.encode_image(sec, nanosec, camera_frame, depth, "32FC1"))
        if labels_u8 is not None:
            labels = _mono8(labels_u8, "labels_u8", where)
            if labels.shape != (height, width):
                raise ConfigError(f"labels_u8 must have shape {(height, width)}, got "
                                  f"{labels.shape}", where=where)
            self._write(f"{base}/labels", "sensor_msgs/msg/Image", t_ns,
                        cdr.encode_image(sec, nanosec, camera_frame, labels))

    def write_sonar_image(self, agent: str, t: float, polar_u8: np.ndarray,
                          beam_angles_rad: Sequence[float] | np.ndarray,
                          ranges_m: Sequence[float] | np.ndarray, frequency_hz: float,
                          sound_speed_m_s: float, sonar_frame: str, sensor: str = "sonar"
                          ) -> None:
        """One ping of the sonar ``sensor`` as ``/<agent>/<sensor>/image``
        (marine_acoustic_msgs/msg/ProjectedSonarImage,
        the live bridge's message): the polar image ``(n_bins, n_beams)`` uint8, beam
        azimuths (rad, > 0 starboard) as directions ``(0, sin, cos)`` (the message's Z
        forward, X up), range-bin centres (m), centre frequency (Hz), sound speed (m/s)."""
        where = "McapRecorder.write_sonar_image"
        self._check_open("write_sonar_image")
        _check_name(agent, "agent", where)
        _check_name(sensor, "sensor", where)
        _check_frame(sonar_frame, where)
        t_ns = _stamp_ns(t, where)
        polar = _mono8(polar_u8, "polar_u8", where)
        angles = np.asarray(beam_angles_rad, dtype=float).reshape(-1)
        ranges = np.asarray(ranges_m, dtype=float).reshape(-1)
        if polar.shape != (ranges.size, angles.size):
            raise ConfigError(f"polar image {polar.shape} does not match {ranges.size} "
                              f"ranges x {angles.size} beams", where=where)
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        directions = np.stack([np.zeros_like(angles), np.sin(angles), np.cos(angles)], -1)
        self._write(f"/{agent}/{sensor}/image", "marine_acoustic_msgs/msg/ProjectedSonarImage",
                    t_ns, cdr.encode_projected_sonar_image(
                        sec, nanosec, sonar_frame, polar, directions, ranges,
                        float(frequency_hz), float(sound_speed_m_s)))

    def write_helm_topics(self, agent: str, t: float, heading_deg: float | None,
                          speed: float | None, depth: float | None, mode: str) -> None:
        """The live bridge's helm topics: ``/<agent>/helm/desired_heading`` (compass deg),
        ``desired_speed`` (m/s), ``desired_depth`` (m, down) as std_msgs/msg/Float64 (each
        skipped when ``None``) and ``/<agent>/helm/mode`` (std_msgs/msg/String) when it
        changes."""
        where = "McapRecorder.write_helm_topics"
        self._check_open("write_helm_topics")
        _check_name(agent, "agent", where)
        t_ns = _stamp_ns(t, where)
        for key, value in (("desired_heading", heading_deg), ("desired_speed", speed),
                           ("desired_depth", depth)):
            if value is None:
                continue
            if not math.isfinite(float(value)):
                raise ConfigError(f"{key} must be finite, got {value!r}", where=where)
            self._write(f"/{agent}/helm/{key}", "std_msgs/msg/Float64", t_ns,
                        cdr.CDR_LE_HEADER + struct.pack("<d", float(value)))
        mode = str(mode)
        if self._helm_modes.get(agent) != mode:
            self._helm_modes[agent] = mode
            buf = cdr.CdrBuffer()
            buf.string(mode)
            self._write(f"/{agent}/helm/mode", "std_msgs/msg/String", t_ns, buf.getvalue())

    def write_helm_decision(
        self,
        agent: str,
        t: float,
        heading_deg: float | None,
        speed: float | None,
        depth: float | None,
        contributions: Mapping[str, float],
        mode: str,
        active: Iterable[str],
        *,
        total: float | None = None,
        all_stop_reason: str = "",
    ) -> None:
        """One helm cycle on ``/<agent>/helm/decision`` (uhrisim_msgs/msg/HelmDecision).

        ``heading_deg`` compass degrees (MOOS/helm convention, kept as is), ``speed``
        m/s, ``depth`` m; each may be ``None`` (not decided, e.g. all-stop: its
        ``has_*`` flag is false and the value 0). ``contributions`` is each behavior's
        objective value at the decision, ``total`` the helm's total (default: their
        sum), ``mode`` the helm mode string, ``active`` the behaviors that produced an
        objective this cycle, ``all_stop_reason`` why the helm stopped ("" if it did not).
        """
        where = "McapRecorder.write_helm_decision"
        self._check_open("write_helm_decision")
        _check_name(agent, "agent", where)
        t_ns = _stamp_ns(t, where)
        self._write(f"/{agent}/helm/decision", uhrisim_msgs.HELM_DECISION, t_ns,
                    uhrisim_msgs.helm_decision_bytes(t_ns, heading_deg, speed, depth,
                                                     contributions, mode, active, total,
                                                     all_stop_reason, where))

    def write_variable(
        self, agent: str, t: float, name: str, value: float | str, source: str
    ) -> None:
        """A community variable posting on ``/<agent>/vars`` (uhrisim_msgs/msg/Variable).

        Numbers (and booleans, as 0/1) go to ``double_value`` with ``kind = DOUBLE``;
        strings to ``string_value`` with ``kind = STRING``.
        """
        where = "McapRecorder.write_variable"
        self._check_open("write_variable")
        _check_name(agent, "agent", where)
        t_ns = _stamp_ns(t, where)
        self._write(f"/{agent}/vars", uhrisim_msgs.VARIABLE, t_ns,
                    uhrisim_msgs.variable_bytes(t_ns, name, value, source, where))

    def _marker(self, t_ns: int, spec: Mapping[str, Any], index: int, writer: str
                ) -> dict[str, Any]:
        where = f"{writer}: marker[{index}]"
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
        pos_ned = _vec(spec.get("position_ned", (0.0, 0.0, 0.0)), 3, "position_ned", where)
        rot_ned = _rotation(spec.get("rotation", np.eye(3)), "rotation", where)
        scale = _vec(spec.get("scale", (1.0, 1.0, 1.0)), 3, "scale", where)
        color = _vec(spec.get("color", (0.5, 0.5, 0.5, 1.0)), 4, "color", where)
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
            "frame_id": self.world_frame,
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

    def write_scene_markers(self, t: float, markers: Sequence[Mapping[str, Any]]) -> None:
        """The scene as ``/scene/markers`` (visualization_msgs/msg/MarkerArray, ENU).

        Each marker is a dict: ``ns`` (str), ``id`` (int), ``type`` (``"box"``,
        ``"cylinder"``, ``"sphere"``, ``"mesh"``, ``"line_strip"``, ``"triangle_list"``),
        ``position_ned``
        (m, default origin), ``rotation`` (3x3 body FRD → NED, default identity),
        ``scale`` (m, full extents along the body axes), ``color`` (r, g, b, a in 0..1),
        ``points_ned`` ((N, 3) world NED, for ``line_strip``, and for ``triangle_list``
        with three vertices per triangle — the way to ship an arbitrary mesh inside
        the file), ``mesh_resource`` (URI, for ``mesh``; ROS renders it in the marker's
        FLU frame, so the mesh file must be authored in ROS axes), optional ``action``
        (``"add"``, ``"delete"``, ``"deleteall"``) and ``text``. Unknown keys are
        errors. Points are written in the marker's own frame (world ENU → local FLU).
        """
        self.write_markers("/scene/markers", t, markers)

    def write_markers(self, topic: str, t: float, markers: Sequence[Mapping[str, Any]]
                      ) -> None:
        """Markers (the dicts of :meth:`write_scene_markers`) as a
        visualization_msgs/msg/MarkerArray on ``topic``, in the world frame (ENU)."""
        where = f"McapRecorder.write_markers({topic})"
        self._check_open("write_markers")
        t_ns = _stamp_ns(t, where)
        specs = [self._marker(t_ns, m, i, where) for i, m in enumerate(markers)]
        self._write(topic, "visualization_msgs/msg/MarkerArray", t_ns,
                    cdr.encode_marker_array(specs))

    def write_event(self, t: float, kind: str, detail: str) -> None:
        """Something that happened once (e.g. ``"collision"``) on ``/events``."""
        where = "McapRecorder.write_event"
        self._check_open("write_event")
        t_ns = _stamp_ns(t, where)
        self._write("/events", uhrisim_msgs.EVENT, t_ns,
                    uhrisim_msgs.event_bytes(t_ns, self.world_frame, kind, detail))

    # ------------------------------------------------------------------ lifecycle
    def flush(self) -> None:
        """Close the open chunk (if it holds messages) and hand it to the OS."""
        if self._closed:
            return
        self._writer.flush()

    def close(self) -> None:
        """Write the summary and footer and close the file. Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
        finally:
            self._sink.close()
        logger.info(
            "recorded %d messages on %d topics to %s (%d bytes)",
            sum(self._counts.values()), len(self._counts), self.path, self._sink.tell(),
        )

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
