"""One function per ROS message uhrisim writes: inputs in uhrisim's frames (NED, FRD;
docs/conventions.md), out the serialised message (CDR little endian, the bytes rclpy
would make of it) in ROS's (REP-103 ENU/FLU, optical frames).

Both outputs call these and only these: the recording writes the bytes into its MCAP
file (:class:`uhrisim.record.McapRecorder`), the live bridge hands them to DDS
(:class:`uhrisim.bridges.ros2.Ros2Bridge`). Stamps are simulation time, as integer
``(sec, nanosec)``; topic and frame names come from :mod:`uhrisim.ros.topics`. Every
input is checked (a ConfigError naming ``where`` and the value) whether or not the
message is then wanted.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable, Mapping
from functools import cache
from typing import Any

import numpy as np
from mcap_ros2._dynamic import serialize_dynamic

from uhrisim.core.errors import ConfigError
from uhrisim.ros import cdr, uhrisim_msgs
from uhrisim.ros.convert import (
    cloud_xyzi_flu,
    mount_transform,
    odom_fields_from_ned,
    optical_rotation,
    pose_enu_from_ned,
    tf_chain,
    tf_chain_frames,
)
from uhrisim.ros.msgdefs import schema_text
from uhrisim.ros.topics import CAMERA_INFO, FRAME_ID, ROS_NAME_TOKEN, camera_frame

_NS = 1_000_000_000
_CLOCK = struct.Struct("<4siI")
_FLOAT64 = struct.Struct("<4sd")


def stamp_ns(t: float, where: str) -> int:
    """Simulation time (s) as integer nanoseconds (rounded), checked finite and >= 0."""
    tf = float(t)
    if not math.isfinite(tf) or tf < 0.0:
        raise ConfigError(f"time must be a finite number >= 0 s, got {t!r}", where=where)
    return round(tf * 1e9)


def check_name(value: str, what: str, where: str) -> str:
    """``value`` if it is one ROS name token, else a ConfigError."""
    if not isinstance(value, str) or not ROS_NAME_TOKEN.match(value):
        raise ConfigError(f"{what} {value!r} is not a ROS name (letter, then "
                          "letters/digits/_)", where=where)
    return value


def check_frame(value: str, where: str) -> str:
    """``value`` if it is a frame id, else a ConfigError."""
    if not isinstance(value, str) or not FRAME_ID.match(value):
        raise ConfigError(f"frame id {value!r} is not a valid ROS frame name", where=where)
    return value


def vector(value: Any, n: int, name: str, where: str) -> np.ndarray:
    """``n`` finite numbers."""
    arr = np.asarray(value, dtype=float)
    # (math.isfinite over a list: a few times cheaper than a ufunc on a few values)
    if arr.shape != (n,) or not all(map(math.isfinite, arr.tolist())):
        raise ConfigError(f"{name} must be {n} finite numbers, got {value!r}", where=where)
    return arr


def rotation(value: Any, name: str, where: str) -> np.ndarray:
    """A proper 3x3 rotation matrix."""
    r = np.asarray(value, dtype=float)
    if r.shape != (3, 3) or not np.all(np.isfinite(r)):
        raise ConfigError(f"{name} must be a finite 3x3 matrix", where=where)
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0.0:
        raise ConfigError(f"{name} is not a proper rotation matrix", where=where)
    return r


def mono8(image: Any, name: str, where: str) -> np.ndarray:
    """A non-empty C-contiguous 2-D uint8 image."""
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim != 2 or arr.size == 0:
        raise ConfigError(f"{name} must be a non-empty 2-D uint8 array, got {arr.dtype} "
                          f"shape {arr.shape}", where=where)
    return np.ascontiguousarray(arr)


def rgb8(image: Any, where: str) -> np.ndarray:
    """A non-empty (H, W, 3) uint8 image."""
    rgb = np.asarray(image)
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.size == 0:
        raise ConfigError(f"rgb_u8 must be a non-empty (H, W, 3) uint8 array, got "
                          f"{rgb.dtype} shape {rgb.shape}", where=where)
    return rgb


def sensor_pose(value: Any, sensor: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """A sensor's ``(position (3,), rotation (3, 3))`` in NED, checked."""
    try:
        position, rot = value
    except (TypeError, ValueError):
        raise ConfigError(f"{sensor}_pose_ned must be (position (3,), rotation (3, 3))",
                          where=where) from None
    return (vector(position, 3, f"{sensor} position", where),
            rotation(rot, f"{sensor} rotation", where))


def clock(sec: int, nanosec: int) -> bytes:
    """rosgraph_msgs/Clock."""
    return _CLOCK.pack(cdr.CDR_LE_HEADER, sec, nanosec)


def float64(value: float) -> bytes:
    """std_msgs/Float64."""
    return _FLOAT64.pack(cdr.CDR_LE_HEADER, value)


def string(text: str) -> bytes:
    """std_msgs/String (uint32 length with the NUL, UTF-8 bytes, NUL)."""
    buf = cdr.CdrBuffer()
    buf.string(text)
    return buf.getvalue()


def joint_state(sec: int, nanosec: int, frame: str, names: Iterable[str], position: Any,
                velocity: Any) -> bytes:
    """sensor_msgs/JointState: joint names, angles (rad) and rates (rad/s); no efforts."""
    names = list(names)
    buf = cdr.CdrBuffer()
    buf.header(sec, nanosec, frame)
    buf.u32(len(names))
    for name in names:
        buf.string(name)
    for values in (np.asarray(position, dtype=float), np.asarray(velocity, dtype=float)):
        buf.u32(values.size)
        if values.size:
            buf.f64s(values.tolist())
    buf.u32(0)  # effort
    return buf.getvalue()


def static_transforms(sec: int, nanosec: int,
                      transforms: Iterable[tuple[str, str, Any, Any]], where: str) -> bytes:
    """tf2_msgs/TFMessage of ``(parent, child, position_frd (3,) m, rotation_frd (3x3)
    child -> parent)`` mounts, in FLU (``/tf_static``)."""
    rows = []
    for parent, child, position_frd, rotation_frd in transforms:
        check_frame(parent, where)
        check_frame(child, where)
        xyz, q = mount_transform(vector(position_frd, 3, "position_frd", where),
                                 rotation(rotation_frd, "rotation_frd", where))
        rows.append((sec, nanosec, parent, child, xyz, q))
    return cdr.encode_tf_message(rows)


def sensor_to_world(sec: int, nanosec: int, world_frame: str, frame: str, p_enu: Any,
                    q: Any) -> bytes:
    """tf2_msgs/TFMessage ``world_frame -> frame`` (a sensor frame without a mount on
    ``/tf_static``)."""
    return transforms([(sec, nanosec, world_frame, frame, p_enu, q)])


def transforms(rows: Iterable[tuple[int, int, str, str, Any, Any]]) -> bytes:
    """tf2_msgs/TFMessage of ``(sec, nanosec, parent, child, xyz, quaternion xyzw)``
    rows, already in ROS frames."""
    return cdr.encode_tf_message(list(rows))


@cache
def _camera_info_encoder() -> Any:
    """mcap_ros2's schema-driven encoder of sensor_msgs/CameraInfo."""
    return serialize_dynamic(CAMERA_INFO, schema_text(CAMERA_INFO))[CAMERA_INFO]


def camera_info(sec: int, nanosec: int, frame: str, shape_hw: tuple[int, int],
                k: np.ndarray) -> bytes:
    """sensor_msgs/CameraInfo of an ideal pinhole camera: ``k`` (3x3, pixels), no
    distortion (``plumb_bob`` with zeros), identity rectification, projection [K | 0]."""
    p = np.zeros((3, 4))
    p[:, :3] = k
    return _camera_info_encoder()({
        "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame},
        "height": int(shape_hw[0]), "width": int(shape_hw[1]), "distortion_model": "plumb_bob",
        "d": [0.0] * 5, "k": k.reshape(-1).tolist(), "r": np.eye(3).reshape(-1).tolist(),
        "p": p.reshape(-1).tolist(), "binning_x": 0, "binning_y": 0,
        "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False}})


def intrinsics(value: Any, where: str) -> np.ndarray:
    """A finite 3x3 intrinsic matrix."""
    k = np.asarray(value, dtype=float)
    if k.shape != (3, 3) or not np.all(np.isfinite(k)):
        raise ConfigError(f"K must be a finite 3x3 matrix, got shape {k.shape}", where=where)
    return k


def sonar_image(sec: int, nanosec: int, frame: str, polar_u8: Any, beam_angles_rad: Any,
                ranges_m: Any, frequency_hz: float, sound_speed_m_s: float,
                where: str) -> bytes:
    """marine_acoustic_msgs/ProjectedSonarImage: the polar image ``(n_bins, n_beams)``
    uint8, beam azimuths (rad, > 0 starboard) as directions ``(0, sin, cos)`` (the
    message's Z forward, X up), range-bin centres (m), centre frequency (Hz), sound speed
    (m/s)."""
    polar = mono8(polar_u8, "polar_u8", where)
    angles = np.asarray(beam_angles_rad, dtype=float).reshape(-1)
    ranges = np.asarray(ranges_m, dtype=float).reshape(-1)
    if polar.shape != (ranges.size, angles.size):
        raise ConfigError(f"polar image {polar.shape} does not match {ranges.size} "
                          f"ranges x {angles.size} beams", where=where)
    directions = np.stack([np.zeros_like(angles), np.sin(angles), np.cos(angles)], -1)
    return cdr.encode_projected_sonar_image(sec, nanosec, frame, polar, directions, ranges,
                                            float(frequency_hz), float(sound_speed_m_s))


class AgentMessages:
    """The messages of one agent (``agent``: its ROS name; frames under
    ``frame_prefix + agent``, poses in ``world_frame``), with its precompiled encoders
    (odometry, pose and ``/tf`` go out as packed structs: a few µs, not ~30 µs)."""

    def __init__(self, agent: str, world_frame: str, frame_prefix: str = "") -> None:
        self.agent = agent
        self.world_frame = world_frame
        #: the agent's frames are ``<frame_base>/base_link``, ``/odom``, ``/<sonar>``
        self.frame_base = f"{frame_prefix}{agent}"
        # REP 105: odometry in the agent's odom frame (map -> odom is the identity on /tf)
        self._odometry = cdr.OdometryEncoder(self.frame("odom"), self.frame("base_link"))
        self._pose = cdr.PoseStampedEncoder(world_frame)
        first, *more = tf_chain_frames(self.frame_base, world_frame)
        self._tf = cdr.TransformEncoder(*first, *more)

    def topic(self, key: str) -> str:
        """The topic ``key`` of this agent, relative (``"videoray/odom"``)."""
        return f"{self.agent}/{key}"

    def frame(self, name: str) -> str:
        """One of the agent's frames: ``"base_link"``, ``"odom"``, a sonar's name, a
        camera's optical frame (:func:`~uhrisim.ros.topics.camera_frame`)."""
        return f"{self.frame_base}/{name}"

    def odometry(self, sec: int, nanosec: int, f: Any) -> bytes:
        """nav_msgs/Odometry ``map -> <agent>/base_link`` of :func:`odom_fields_from_ned`'s
        fields ``f``: pose in ENU, twist in the body FLU frame, covariances 0 (truth)."""
        return self._odometry(sec, nanosec, f.position_enu, f.orientation_xyzw,
                              f.linear_flu, f.angular_flu)

    def pose(self, sec: int, nanosec: int, position_enu: Any, orientation_xyzw: Any) -> bytes:
        """geometry_msgs/PoseStamped in the world frame (the agent's, a sensor's)."""
        return self._pose(sec, nanosec, position_enu, orientation_xyzw)

    def tf(self, sec: int, nanosec: int, f: Any) -> bytes:
        """tf2_msgs/TFMessage ``map -> <agent>/odom`` (identity) ``-> <agent>/base_link``
        (the odometry pose; REP 105)."""
        (t0, q0), second = tf_chain(f.position_enu, f.orientation_xyzw)
        return self._tf(sec, nanosec, t0, q0, second)

    def image(self, sec: int, nanosec: int, frame: str, image: np.ndarray,
              encoding: str = "mono8") -> bytes:
        """sensor_msgs/Image of ``image`` (mono8, rgb8 or 32FC1) in ``frame``."""
        return cdr.encode_image(sec, nanosec, frame, image, encoding)

    def cloud(self, sec: int, nanosec: int, sonar: str, points_frd: Any,
              intensity: Any) -> bytes:
        """sensor_msgs/PointCloud2 (x, y, z, intensity float32) of sonar-frame FRD hits,
        written in the sonar's FLU frame."""
        return cdr.encode_pointcloud2(sec, nanosec, self.frame(sonar),
                                      cloud_xyzi_flu(points_frd, intensity))

    def camera_pose(self, sec: int, nanosec: int, camera_pose_ned: tuple[Any, Any]
                    ) -> tuple[bytes, tuple[Any, Any]]:
        """geometry_msgs/PoseStamped of a camera's optical frame (x right, y down, z
        forward) from its FRD-like pose in NED, and that pose in ENU (for /tf)."""
        position, rot = camera_pose_ned
        p_enu, q = pose_enu_from_ned(position, optical_rotation(rot))
        return self.pose(sec, nanosec, p_enu, q), (p_enu, q)

    def camera_frame(self, camera: str) -> str:
        return self.frame(camera_frame(camera))

    def helm_decision(self, t_ns: int, heading_deg: float | None, speed: float | None,
                      depth: float | None, contributions: Mapping[str, float], mode: str,
                      active: Iterable[str], total: float | None, all_stop_reason: str,
                      where: str) -> bytes:
        """uhrisim_msgs/HelmDecision (see :func:`uhrisim.ros.uhrisim_msgs.helm_decision_bytes`)."""
        return uhrisim_msgs.helm_decision_bytes(t_ns, heading_deg, speed, depth,
                                                contributions, mode, active, total,
                                                all_stop_reason, where)

    @staticmethod
    def variable(t_ns: int, name: str, value: float | str, source: str, where: str) -> bytes:
        """uhrisim_msgs/Variable of a community posting."""
        return uhrisim_msgs.variable_bytes(t_ns, name, value, source, where)


def odometry_fields(position_ned: Any, yaw_rad: float, velocity_body_frd: Any,
                    yaw_rate: float, where: str) -> Any:
    """The ENU/FLU odometry of a NED/FRD pose and velocity, every input checked."""
    p_ned = vector(position_ned, 3, "position_ned", where)
    v_frd = vector(velocity_body_frd, 3, "velocity_body_frd", where)
    yaw, r = float(yaw_rad), float(yaw_rate)
    if not (math.isfinite(yaw) and math.isfinite(r)):
        raise ConfigError("yaw_rad and yaw_rate must be finite", where=where)
    return odom_fields_from_ned(p_ned, yaw, v_frd, r)


def split_stamp(t_ns: int) -> tuple[int, int]:
    """``(sec, nanosec)`` of nanoseconds."""
    return divmod(t_ns, _NS)
