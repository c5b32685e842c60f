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
from sensor_msgs.msg import CameraInfo, Image, PointCloud2, PointField
from visualization_msgs.msg import Marker

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import enu_from_ned
from uhrisim.record.cdr import (
    CDR_LE_HEADER,
    CdrBuffer,
    encode_projected_sonar_image,
)

from .convert import (
    CLOUD_FIELDS,
    CLOUD_POINT_STEP,
    cloud_xyzi_flu,
    mount_transform,
    odom_fields_from_ned,
    pose_enu_from_ned,
    stamp_from_sim_time,
)

#: World frame of every pose and marker (REP-105 "map", ENU).
WORLD_FRAME = "map"

def static_tf_msg(t_sim: float, transforms: Sequence[tuple[str, str, ArrayLike, ArrayLike]]
                  ) -> Any:
    """tf2_msgs/TFMessage of ``(parent, child, position_frd, rotation_frd)`` mounts (see
    :func:`mount_transform`), stamped ``t_sim``: what ``/tf_static`` carries."""
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage

    msg = TFMessage()
    for parent, child, position_frd, rotation_frd in transforms:
        ts = TransformStamped()
        _set_stamp(ts.header, t_sim, parent)
        ts.child_frame_id = child
        (x, y, z), (qx, qy, qz, qw) = mount_transform(position_frd, rotation_frd)
        tr = ts.transform
        tr.translation.x, tr.translation.y, tr.translation.z = x, y, z
        tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w = qx, qy, qz, qw
        msg.transforms.append(ts)
    return msg


def _sonar_image_inputs(polar_u8: np.ndarray, beam_angles_rad: ArrayLike, ranges_m: ArrayLike
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The checked image, beam directions ``(n_beams, 3)`` and ranges of a sonar image."""
    image = mono8(polar_u8, "Ros2Bridge.publish_sonar_image.polar_u8")
    angles = np.asarray(beam_angles_rad, dtype=float).reshape(-1)
    ranges = np.asarray(ranges_m, dtype=float).reshape(-1)
    if image.shape != (ranges.size, angles.size):
        raise ConfigError(f"polar image {image.shape} does not match {ranges.size} ranges x "
                          f"{angles.size} beams", "Ros2Bridge.publish_sonar_image")
    directions = np.stack([np.zeros_like(angles), np.sin(angles), np.cos(angles)], -1)
    return image, directions, ranges


def projected_sonar_image_bytes(t_sim: float, frame_id: str, polar_u8: np.ndarray,
                                beam_angles_rad: ArrayLike, ranges_m: ArrayLike,
                                frequency_hz: float, sound_speed_m_s: float) -> bytes:
    """The serialised :func:`projected_sonar_image_msg` (the pixels copied once)."""
    image, directions, ranges = _sonar_image_inputs(polar_u8, beam_angles_rad, ranges_m)
    sec, nanosec = stamp_from_sim_time(t_sim)
    return encode_projected_sonar_image(sec, nanosec, frame_id, image, directions, ranges,
                                        float(frequency_hz), float(sound_speed_m_s))


def projected_sonar_image_msg(t_sim: float, frame_id: str, polar_u8: np.ndarray,
                              beam_angles_rad: ArrayLike, ranges_m: ArrayLike,
                              frequency_hz: float, sound_speed_m_s: float) -> Any:
    """marine_acoustic_msgs/ProjectedSonarImage of a polar image ``(n_bins, n_beams)``
    (row = range bin near -> far, column = beam port -> starboard), stamped ``t_sim``.

    Following the message's convention (its .msg comment: Z forward in the plane of the
    fan, X up, hence Y starboard), beam ``i`` at azimuth ``theta_i`` (> 0 starboard) has
    the direction ``(0, sin theta_i, cos theta_i)``; ``ranges`` are the bin centres (m);
    the image data is ``uint8``, one row of ``beam_count`` samples per range bin.
    """
    from geometry_msgs.msg import Vector3
    from marine_acoustic_msgs.msg import ProjectedSonarImage, SonarImageData

    image, directions, ranges = _sonar_image_inputs(polar_u8, beam_angles_rad, ranges_m)
    msg = ProjectedSonarImage()
    _set_stamp(msg.header, t_sim, frame_id)
    msg.ping_info.frequency = float(frequency_hz)
    msg.ping_info.sound_speed = float(sound_speed_m_s)
    msg.beam_directions = [Vector3(x=x, y=y, z=z) for x, y, z in directions.tolist()]
    msg.ranges = array.array("f", ranges.astype(np.float32).tobytes())
    msg.image.is_bigendian = False
    msg.image.dtype = SonarImageData.DTYPE_UINT8
    msg.image.beam_count = int(directions.shape[0])
    data = array.array("B")
    data.frombytes(memoryview(image.reshape(-1)))
    msg.image.data = data
    return msg

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


def camera_info_msg(t_sim: float, frame_id: str, shape_hw: tuple[int, int],
                    K: ArrayLike) -> CameraInfo:
    """sensor_msgs/CameraInfo of an ideal pinhole camera: intrinsics ``K`` (3x3,
    pixels), no distortion (``plumb_bob`` with zeros), identity rectification,
    projection [K | 0]; ``shape_hw`` = (height, width) in pixels."""
    k = np.asarray(K, dtype=float)
    if k.shape != (3, 3) or not np.all(np.isfinite(k)):
        raise ConfigError(f"K must be a finite 3x3 matrix, got {k.shape}", "camera_info_msg")
    msg = CameraInfo()
    _set_stamp(msg.header, t_sim, frame_id)
    msg.height, msg.width = int(shape_hw[0]), int(shape_hw[1])
    msg.distortion_model = "plumb_bob"
    msg.d = [0.0] * 5
    msg.k = k.reshape(-1).tolist()
    msg.r = np.eye(3).reshape(-1).tolist()
    msg.p = np.hstack([k, np.zeros((3, 1))]).reshape(-1).tolist()
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


def marker_msg(t_sim: float, i: int, spec: Mapping[str, Any],
               world_frame: str = WORLD_FRAME) -> Marker:
    """visualization_msgs/Marker number ``i`` of ``/scene/markers`` from its mapping (see
    :meth:`~uhrisim.bridges.ros2.bridge.Ros2Bridge.publish_scene`), stamped ``t_sim`` (s),
    frame ``world_frame``; a ConfigError names the marker and the key at fault."""
    where = f"Ros2Bridge.publish_scene.markers[{i}]"
    try:
        kind = spec["type"]
        if kind not in _MARKER_TYPES:
            raise ConfigError(
                f"type {kind!r} not one of {sorted(_MARKER_TYPES)}", f"{where}.type"
            )
        m = Marker()
        _set_stamp(m.header, t_sim, world_frame)
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
