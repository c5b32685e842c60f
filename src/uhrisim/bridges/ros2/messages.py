"""ROS 2 messages of uhrisim's products, as rclpy message objects or serialised bytes.

The bridge sends most messages pre-serialised (CDR, little endian): the bytes rclpy would
make of the message, without building one (odometry, poses, images, clouds, helm values,
``/clock``); the message builders here are what those bytes must equal, and tests hold
the two together. Frames: poses and markers in ``"map"`` (ENU), bodies in
``"<agent>/base_link"`` (FLU), sensors in ``"<agent>/sonar"``; every conversion from NED/FRD
is :mod:`.convert`'s. Stamps are simulation time.
"""

from __future__ import annotations

import array
import struct
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from geometry_msgs.msg import Point
from nav_msgs.msg import Odometry
from numpy.typing import ArrayLike
from sensor_msgs.msg import Image, PointCloud2, PointField
from visualization_msgs.msg import Marker

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import enu_from_ned
from uhrisim.record.cdr import CDR_LE_HEADER, CdrBuffer

from .convert import (
    CLOUD_FIELDS,
    CLOUD_POINT_STEP,
    cloud_xyzi_flu,
    odom_fields_from_ned,
    pose_enu_from_ned,
    stamp_from_sim_time,
)

#: World frame of every pose and marker (REP-105 "map", ENU).
WORLD_FRAME = "map"

_MARKER_TYPES: dict[str, int] = {
    "box": Marker.CUBE,
    "sphere": Marker.SPHERE,
    "cylinder": Marker.CYLINDER,
    "line_strip": Marker.LINE_STRIP,
    "line_list": Marker.LINE_LIST,
    "points": Marker.POINTS,
    "triangle_list": Marker.TRIANGLE_LIST,
}
#: Marker types whose geometry is a list of world points (``points_ned``).
_POINT_MARKERS = frozenset({"line_strip", "line_list", "points", "triangle_list"})


def _set_stamp(header: Any, t_sim: float, frame_id: str) -> None:
    """Stamp ``header`` with simulation time ``t_sim`` (s) in frame ``frame_id``."""
    sec, nanosec = stamp_from_sim_time(t_sim)
    header.stamp.sec = sec
    header.stamp.nanosec = nanosec
    header.frame_id = frame_id


def mono8(img: np.ndarray, where: str) -> np.ndarray:
    """``img`` as a C-contiguous 2-D uint8 array, or a ConfigError naming ``where``."""
    a = np.asarray(img)
    if a.dtype != np.uint8 or a.ndim != 2:
        raise ConfigError(f"expected a 2-D uint8 image, got {a.dtype} {a.shape}", where)
    return np.ascontiguousarray(a)


def image_msg(img: np.ndarray, t_sim: float, frame_id: str, where: str = "image") -> Image:
    """sensor_msgs/Image ``mono8`` of a 2-D uint8 array (row-major, step = width),
    stamped with simulation time ``t_sim`` (s): the message whose bytes
    :meth:`~uhrisim.bridges.ros2.bridge.Ros2Bridge.publish_sonar` sends (tests hold the
    two together)."""
    a = mono8(img, where)
    msg = Image()
    _set_stamp(msg.header, t_sim, frame_id)
    msg.height, msg.width = int(a.shape[0]), int(a.shape[1])
    msg.encoding = "mono8"
    msg.is_bigendian = 0
    msg.step = int(a.shape[1])
    data = array.array("B")
    data.frombytes(memoryview(a.reshape(-1)))
    msg.data = data
    return msg


def odometry_msg(
    agent: str,
    t_sim: float,
    position_ned: ArrayLike,
    yaw_rad: float,
    velocity_body_frd: ArrayLike,
    yaw_rate: float,
) -> Odometry:
    """nav_msgs/Odometry (``"map"`` -> ``"<agent>/base_link"``, REP-103) from NED/FRD
    truth; see :func:`~uhrisim.bridges.ros2.convert.odom_fields_from_ned`."""
    f = odom_fields_from_ned(position_ned, yaw_rad, velocity_body_frd, yaw_rate)
    odom = Odometry()
    _set_stamp(odom.header, t_sim, WORLD_FRAME)
    odom.child_frame_id = f"{agent}/base_link"
    pp = odom.pose.pose
    pp.position.x, pp.position.y, pp.position.z = f.position_enu
    o = pp.orientation
    o.x, o.y, o.z, o.w = f.orientation_xyzw
    tw = odom.twist.twist
    tw.linear.x, tw.linear.y, tw.linear.z = f.linear_flu
    tw.angular.x, tw.angular.y, tw.angular.z = f.angular_flu
    return odom


class PoseStampedEncoder:
    """geometry_msgs/PoseStamped in a fixed frame, serialised (CDR, little endian) by one
    precompiled ``struct``: the bytes rclpy makes of the message, without building one.
    ``tests/integration/test_ros2_convert.py`` holds it to rclpy's serialisation."""

    __slots__ = ("_frame", "_struct")

    def __init__(self, frame_id: str) -> None:
        self._frame = frame_id.encode("utf-8") + b"\x00"
        end_of_frame = 8 + 4 + len(self._frame)  # stamp, string length, string (+ NUL)
        pad = -end_of_frame % 8  # the pose's doubles are 8-aligned
        self._struct = struct.Struct(f"<4siII{len(self._frame)}s{pad}x7d")

    def __call__(self, sec: int, nanosec: int, position: Sequence[float],
                 orientation_xyzw: Sequence[float]) -> bytes:
        return self._struct.pack(CDR_LE_HEADER, sec, nanosec, len(self._frame), self._frame,
                                 *position, *orientation_xyzw)


#: rosgraph_msgs/Clock serialised (CDR little endian): header, int32 sec, uint32 nanosec.
_CLOCK_CDR = struct.Struct("<4siI")
#: std_msgs/Float64 serialised: header, then the double (8-aligned at offset 0).
_FLOAT64_CDR = struct.Struct("<4sd")


def clock_bytes(t_sim: float) -> bytes:
    """The serialised rosgraph_msgs/Clock of simulation time ``t_sim`` (s): what rclpy
    makes of the message (tests/integration/test_ros2_inprocess.py holds it to that)."""
    sec, nanosec = stamp_from_sim_time(t_sim)
    return _CLOCK_CDR.pack(CDR_LE_HEADER, sec, nanosec)


def float64_bytes(value: float) -> bytes:
    """The serialised std_msgs/Float64 of ``value``."""
    return _FLOAT64_CDR.pack(CDR_LE_HEADER, value)


def string_bytes(text: str) -> bytes:
    """The serialised std_msgs/String of ``text`` (uint32 length with the NUL, UTF-8
    bytes, NUL)."""
    cdr = CdrBuffer()
    cdr.string(text)
    return cdr.getvalue()


def pointcloud_msg(
    t_sim: float, frame_id: str, points_frd: ArrayLike, intensity: ArrayLike | None = None
) -> PointCloud2:
    """sensor_msgs/PointCloud2 (height 1; x, y, z, intensity float32 LE, 16 bytes a
    point) of ``(N, 3)`` sensor-frame FRD points, written in the sensor's FLU frame: the
    message whose bytes :meth:`~uhrisim.bridges.ros2.bridge.Ros2Bridge.publish_sonar`
    sends (tests hold the two together)."""
    xyzi = cloud_xyzi_flu(points_frd, intensity)
    n = xyzi.shape[0]
    cloud = PointCloud2()
    _set_stamp(cloud.header, t_sim, frame_id)
    cloud.height, cloud.width = 1, n
    cloud.fields = [
        PointField(name=name, offset=off, datatype=PointField.FLOAT32, count=1)
        for name, off in CLOUD_FIELDS
    ]
    cloud.is_bigendian = False
    cloud.point_step = CLOUD_POINT_STEP
    cloud.row_step = CLOUD_POINT_STEP * n
    cloud.is_dense = True
    data = array.array("B")
    data.frombytes(xyzi.reshape(-1).view(np.uint8))
    cloud.data = data
    return cloud


def marker_msg(t_sim: float, i: int, spec: Mapping[str, Any]) -> Marker:
    """visualization_msgs/Marker number ``i`` of ``/scene/markers`` from its mapping (see
    :meth:`~uhrisim.bridges.ros2.bridge.Ros2Bridge.publish_scene`), stamped ``t_sim`` (s),
    frame ``"map"``; a ConfigError names the marker and the key at fault."""
    where = f"Ros2Bridge.publish_scene.markers[{i}]"
    try:
        kind = spec["type"]
        if kind not in _MARKER_TYPES:
            raise ConfigError(
                f"type {kind!r} not one of {sorted(_MARKER_TYPES)}", f"{where}.type"
            )
        m = Marker()
        _set_stamp(m.header, t_sim, WORLD_FRAME)
        m.ns = str(spec.get("ns", ""))
        m.id = int(spec["id"])
        m.type = _MARKER_TYPES[kind]
        if spec.get("action", "add") == "deleteall":  # clears the display's markers
            m.action = Marker.DELETEALL
            return m
        m.action = Marker.ADD
        if kind in _POINT_MARKERS:
            pts = np.asarray(spec["points_ned"], dtype=float)
            if pts.ndim != 2 or pts.shape[1] != 3:
                raise ConfigError(f"expected (N, 3), got {pts.shape}", f"{where}.points_ned")
            # points are world coordinates: the marker pose is the ENU identity
            pos, quat = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
            m.points = [Point(x=x, y=y, z=z) for x, y, z in enu_from_ned(pts).tolist()]
        else:
            pos, quat = pose_enu_from_ned(spec["position_ned"], spec.get("rotation"))
        m.pose.position.x, m.pose.position.y, m.pose.position.z = pos
        o = m.pose.orientation
        o.x, o.y, o.z, o.w = quat
        if "text" in spec:
            m.text = str(spec["text"])
        scale = np.broadcast_to(np.asarray(spec.get("scale", 1.0), dtype=float), (3,))
        m.scale.x, m.scale.y, m.scale.z = (float(s) for s in scale)
        rgba = [float(c) for c in spec.get("color", (0.7, 0.7, 0.7, 1.0))]
        if len(rgba) != 4:
            raise ConfigError(f"color needs 4 values (rgba), got {len(rgba)}", where)
        m.color.r, m.color.g, m.color.b, m.color.a = rgba
    except KeyError as exc:
        raise ConfigError(f"missing key {exc.args[0]!r}", where) from exc
    except ConfigError:
        raise
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"bad value: {exc}", where) from exc
    return m
