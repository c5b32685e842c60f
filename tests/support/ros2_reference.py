"""Reference builders of uhrisim's ROS 2 messages as rclpy message objects, field by field.

The ROS translation (uhrisim.ros.messages) writes every message pre-serialised, the
bytes rclpy would make of it, without building one; these builders are what those bytes
must equal, and the tests hold the two together (rclpy deserialises ours into exactly
these). Frames: poses in ``"map"`` (ENU), bodies in ``"<agent>/base_link"`` (FLU),
sensors in ``"<agent>/<sensor>"``; conversions are uhrisim.ros.convert's. Stamps are
simulation time.
"""

from __future__ import annotations

import array
from typing import Any

import numpy as np
from nav_msgs.msg import Odometry
from numpy.typing import ArrayLike
from sensor_msgs.msg import Image, PointCloud2, PointField

from uhrisim.core.errors import ConfigError
from uhrisim.ros.convert import (
    CLOUD_FIELDS,
    CLOUD_POINT_STEP,
    cloud_xyzi_flu,
    odom_fields_from_ned,
    stamp_from_sim_time,
)

#: World frame of every pose and marker (REP-105 "map", ENU).
WORLD_FRAME = "map"

def _sonar_image_inputs(polar_u8: np.ndarray, beam_angles_rad: ArrayLike, ranges_m: ArrayLike
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The checked image, beam directions ``(n_beams, 3)`` and ranges of a sonar image."""
    image = mono8(polar_u8, "projected_sonar_image_msg.polar_u8")
    angles = np.asarray(beam_angles_rad, dtype=float).reshape(-1)
    ranges = np.asarray(ranges_m, dtype=float).reshape(-1)
    if image.shape != (ranges.size, angles.size):
        raise ConfigError(f"polar image {image.shape} does not match {ranges.size} ranges x "
                          f"{angles.size} beams", "projected_sonar_image_msg")
    directions = np.stack([np.zeros_like(angles), np.sin(angles), np.cos(angles)], -1)
    return image, directions, ranges


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
    ``RosWriter.write_sonar`` sends (tests hold the
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
    """nav_msgs/Odometry (``"<agent>/odom"`` -> ``"<agent>/base_link"``: REP 105's odom
    frame, REP-103 axes) from NED/FRD truth; see
    :func:`~uhrisim.ros.convert.odom_fields_from_ned`."""
    f = odom_fields_from_ned(position_ned, yaw_rad, velocity_body_frd, yaw_rate)
    odom = Odometry()
    _set_stamp(odom.header, t_sim, f"{agent}/odom")
    odom.child_frame_id = f"{agent}/base_link"
    pp = odom.pose.pose
    pp.position.x, pp.position.y, pp.position.z = f.position_enu
    o = pp.orientation
    o.x, o.y, o.z, o.w = f.orientation_xyzw
    tw = odom.twist.twist
    tw.linear.x, tw.linear.y, tw.linear.z = f.linear_flu
    tw.angular.x, tw.angular.y, tw.angular.z = f.angular_flu
    return odom


def pointcloud_msg(
    t_sim: float, frame_id: str, points_frd: ArrayLike, intensity: ArrayLike | None = None
) -> PointCloud2:
    """sensor_msgs/PointCloud2 (height 1; x, y, z, intensity float32 LE, 16 bytes a
    point) of ``(N, 3)`` sensor-frame FRD points, written in the sensor's FLU frame: the
    message whose bytes ``RosWriter.write_sonar``
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
