"""Our CDR bytes against real ROS 2 type support (rclpy, Kilted wheels), when installed.

``rclpy.serialization`` uses the rmw's own (Fast DDS) type support: the bytes ROS 2
nodes exchange. Our messages must deserialise there into the message built directly
with the ROS message classes, have the same length as rclpy's serialisation, and differ
from it only in padding bytes (Fast CDR leaves padding uninitialised; we write zeros).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
serialization = pytest.importorskip("rclpy.serialization")
nav_msgs = pytest.importorskip("nav_msgs.msg")
sensor_msgs = pytest.importorskip("sensor_msgs.msg")
visualization_msgs = pytest.importorskip("visualization_msgs.msg")
geometry_msgs = pytest.importorskip("geometry_msgs.msg")

from uhrisim.ros import cdr  # noqa: E402


def same_up_to_padding(ours: bytes, ros_msg) -> None:
    theirs = serialization.serialize_message(ros_msg)
    assert len(ours) == len(theirs)
    differ = [i for i in range(len(ours)) if ours[i] != theirs[i]]
    assert all(ours[i] == 0 for i in differ), f"non-padding differences at {differ[:8]}"
    assert len(differ) <= 7 * 8  # a few padding runs, never a field


def test_odometry() -> None:
    ours = cdr.OdometryEncoder("map", "rov/base_link")(
        12, 345, (4.0, 3.0, -2.0), (0.0, 0.0, 0.0, 1.0), (1.0, -0.5, -0.2), (0.0, 0.0, -0.1)
    )
    m = nav_msgs.Odometry()
    m.header.stamp.sec, m.header.stamp.nanosec, m.header.frame_id = 12, 345, "map"
    m.child_frame_id = "rov/base_link"
    m.pose.pose.position = geometry_msgs.Point(x=4.0, y=3.0, z=-2.0)
    m.twist.twist.linear = geometry_msgs.Vector3(x=1.0, y=-0.5, z=-0.2)
    m.twist.twist.angular = geometry_msgs.Vector3(x=0.0, y=0.0, z=-0.1)
    assert serialization.deserialize_message(ours, nav_msgs.Odometry) == m
    same_up_to_padding(ours, m)


def test_image_and_pointcloud() -> None:
    img = np.arange(35, dtype=np.uint8).reshape(5, 7)
    ours = cdr.encode_image(1, 2, "rov/sonar", img)
    m = sensor_msgs.Image(height=5, width=7, encoding="mono8", is_bigendian=0, step=7,
                          data=img.tobytes())
    m.header.stamp.sec, m.header.stamp.nanosec, m.header.frame_id = 1, 2, "rov/sonar"
    assert serialization.deserialize_message(ours, sensor_msgs.Image) == m
    same_up_to_padding(ours, m)

    pts = np.array([[1, 2, 3, 0.5], [4, 5, 6, 1.0]], dtype="<f4")
    ours = cdr.encode_pointcloud2(3, 4, "rov/sonar", pts)
    got = serialization.deserialize_message(ours, sensor_msgs.PointCloud2)
    assert (got.height, got.width, got.point_step, got.row_step) == (1, 2, 16, 32)
    assert [(f.name, f.offset, f.datatype, f.count) for f in got.fields] == [
        ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("intensity", 12, 7, 1)]
    np.testing.assert_array_equal(np.frombuffer(bytes(got.data), "<f4").reshape(2, 4), pts)
    same_up_to_padding(ours, got)


def test_marker_array() -> None:
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    spec = {"sec": 0, "nanosec": 5, "frame_id": "map", "ns": "scene", "id": 3, "type": 11,
            "action": 0, "pose": (20.0, 10.0, -5.0, 0.0, 0.0, 0.0, 1.0),
            "scale": (1.0, 1.0, 1.0), "color": (0.5, 0.25, 1.0, 1.0), "points": pts,
            "colors": np.zeros((0, 4)), "text": "piling_1", "mesh_resource": ""}
    ours = cdr.encode_marker_array([spec])
    got = serialization.deserialize_message(ours, visualization_msgs.MarkerArray)
    (mk,) = got.markers
    assert (mk.ns, mk.id, mk.type, mk.text, mk.header.frame_id) == ("scene", 3, 11,
                                                                     "piling_1", "map")
    assert (mk.pose.position.x, mk.pose.position.y, mk.pose.position.z) == (20, 10, -5)
    assert [(p.x, p.y, p.z) for p in mk.points] == [tuple(p) for p in pts.tolist()]
    assert (mk.color.r, mk.color.g, mk.color.b) == (0.5, 0.25, 1.0)
    same_up_to_padding(ours, got)
