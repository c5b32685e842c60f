"""External ROS 2 subscriber for the camera topics: plain rclpy, no uhrisim imports
(tf2_msgs built at install time: python -m uhrisim.bridges.ros2.interfaces).

Subscribes (sensor-data QoS, best effort; ``--reliable``: reliable, keep-last 5) to one
agent's ``camera/image_raw``, ``camera/camera_info``, ``camera/depth`` and
``camera/labels``, and (reliable) to its ``camera/pose``, ``/tf`` and the latched
``/tf_static``; prints ``READY`` once each has a publisher, and on ``STOP`` prints one JSON
line ``RESULT {...}`` with, per camera topic, the count and a summary of the first message
(header, size, encoding, a checksum of the pixels, K; a pose's position and orientation),
and under ``"tf"`` what a tf user needs to place pixels (after ``STOP`` it waits, up to
``TF_WAIT_S``, for the /tf of every depth image's stamp): ``static`` the /tf_static
transforms, ``dynamic`` "sec.nanosec" -> the /tf transforms of that stamp, ``poses``
"sec.nanosec" -> the camera pose, ``depth`` "sec.nanosec" -> ``[u, v, depth m]`` of
the pixels on a 16-pixel grid that saw something. A transform is ``[parent, child,
[tx, ty, tz], [qx, qy, qz, qw]]``.

    python ros2_camera_listener.py --agent rov [--reliable]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped
from listener_loop import serve
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from ros2_tf_rows import stamp_key, transform_rows
from sensor_msgs.msg import CameraInfo, Image
from tf2_msgs.msg import TFMessage

#: pixels sampled from each depth image: every GRID-th column and row
GRID = 16
#: longest wait (s) after STOP for the /tf of every picture's stamp
TF_WAIT_S = 10.0


def summary(msg) -> dict:
    h = msg.header
    out = {"frame_id": h.frame_id, "stamp": [h.stamp.sec, h.stamp.nanosec]}
    if isinstance(msg, PoseStamped):
        p, q = msg.pose.position, msg.pose.orientation
        out.update(position=[p.x, p.y, p.z], orientation=[q.x, q.y, q.z, q.w])
        return out
    out.update(height=msg.height, width=msg.width)
    if isinstance(msg, Image):
        data = bytes(msg.data)
        out.update(encoding=msg.encoding, step=msg.step, nbytes=len(data),
                   checksum=int(sum(data) % 1_000_003))
    else:
        out.update(k=list(msg.k), p=list(msg.p), distortion_model=msg.distortion_model)
    return out


def depth_samples(msg: Image) -> list:
    """``[u, v, depth]`` of the grid pixels of a 32FC1 image with a finite depth."""
    depth = np.frombuffer(bytes(msg.data), "<f4").reshape(msg.height, msg.width)
    v, u = np.mgrid[GRID // 2:msg.height:GRID, GRID // 2:msg.width:GRID]
    d = depth[v, u]
    seen = np.isfinite(d)
    return [[int(a), int(b), float(c)] for a, b, c in zip(u[seen], v[seen], d[seen],
                                                          strict=True)]


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--agent", required=True)
    parser.add_argument("--reliable", action="store_true")
    args = parser.parse_args()
    qos = qos_profile_sensor_data
    if args.reliable:
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                         reliability=ReliabilityPolicy.RELIABLE)
    rclpy.init()
    node = rclpy.create_node("camera_listener", start_parameter_services=False)
    base = f"/{args.agent}/camera"
    topics = {f"{base}/image_raw": (Image, qos), f"{base}/camera_info": (CameraInfo, qos),
              f"{base}/depth": (Image, qos), f"{base}/labels": (Image, qos),
              f"{base}/pose": (PoseStamped, 10)}
    seen: dict[str, dict] = {t: {"count": 0, "first": None} for t in topics}
    tf: dict = {"static": [], "dynamic": {}, "poses": {}, "depth": {}}

    def callback(topic):
        def on_msg(msg):
            entry = seen[topic]
            entry["count"] += 1
            if entry["first"] is None:
                entry["first"] = summary(msg)
            if topic.endswith("/depth"):
                tf["depth"][stamp_key(msg.header)] = depth_samples(msg)
            elif topic.endswith("/pose"):
                tf["poses"][stamp_key(msg.header)] = summary(msg)
        return on_msg

    def on_tf(msg: TFMessage) -> None:
        for row in transform_rows(msg):
            tf["dynamic"].setdefault(stamp_key(msg.transforms[0].header), []).append(row)

    def on_static(msg: TFMessage) -> None:
        tf["static"] = transform_rows(msg)

    for topic, (kind, topic_qos) in topics.items():
        node.create_subscription(kind, topic, callback(topic), topic_qos)
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(TFMessage, "/tf", on_tf, 100)
    node.create_subscription(TFMessage, "/tf_static", on_static, latched)

    def settle(spin_once) -> None:
        # as tf2's lookup_transform(timeout) would: wait (at most TF_WAIT_S) for the /tf of
        # each picture's stamp; a reliable /tf sample lost under the images' traffic (shared
        # memory full) is repaired only at the writer's next heartbeat, seconds later
        deadline = time.monotonic() + TF_WAIT_S
        while time.monotonic() < deadline and not set(tf["depth"]) <= set(tf["dynamic"]):
            spin_once()

    return serve(node, [*topics, "/tf", "/tf_static"], lambda: {**seen, "tf": tf},
                 settle=settle,
                 received=lambda: {t: entry["count"] for t, entry in seen.items()})

if __name__ == "__main__":
    sys.exit(main())
