"""External ROS 2 subscriber for the bridge tests: plain rclpy, no uhrisim imports.

Subscribes to one agent's odometry, pose and sonar topics, prints ``READY`` once every
topic has a publisher, records each message's receipt time (monotonic wall s), header
stamp (s) and a summary of the first message, and on ``STOP`` (or end of stdin) prints
one JSON line ``RESULT {...}`` and exits.

    python ros2_listener.py --agent rov [--sensor-qos best_effort|reliable]

The environment (ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, ROS_LOG_DIR)
comes from the parent.
"""

from __future__ import annotations

import argparse
import sys
import time

import rclpy
from geometry_msgs.msg import PoseStamped
from listener_loop import serve
from nav_msgs.msg import Odometry
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, PointCloud2


def summary(msg) -> dict:
    h = msg.header
    out = {"frame_id": h.frame_id, "stamp": [h.stamp.sec, h.stamp.nanosec]}
    if isinstance(msg, Odometry):
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        tl, ta = msg.twist.twist.linear, msg.twist.twist.angular
        out.update(
            child_frame_id=msg.child_frame_id,
            position=[p.x, p.y, p.z],
            orientation=[q.x, q.y, q.z, q.w],
            linear=[tl.x, tl.y, tl.z],
            angular=[ta.x, ta.y, ta.z],
        )
    elif isinstance(msg, PoseStamped):
        p, q = msg.pose.position, msg.pose.orientation
        out.update(position=[p.x, p.y, p.z], orientation=[q.x, q.y, q.z, q.w])
    elif isinstance(msg, Image):
        out.update(
            height=msg.height, width=msg.width, encoding=msg.encoding, step=msg.step,
            nbytes=len(msg.data), checksum=int(sum(bytes(msg.data)) % 1_000_003),
        )
    elif isinstance(msg, PointCloud2):
        import struct

        first = struct.unpack_from("<4f", bytes(msg.data[:16])) if msg.width else []
        out.update(
            width=msg.width, point_step=msg.point_step,
            fields=[[f.name, f.offset, f.datatype] for f in msg.fields],
            first_point=list(first),
        )
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", required=True)
    ap.add_argument("--sensor-qos", choices=["best_effort", "reliable"], default="best_effort")
    args = ap.parse_args()

    rclpy.init()
    node = rclpy.create_node("test_listener", start_parameter_services=False)
    sensor_qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=5,
        reliability=(
            ReliabilityPolicy.BEST_EFFORT
            if args.sensor_qos == "best_effort"
            else ReliabilityPolicy.RELIABLE
        ),
    )
    a = args.agent
    topics = {
        f"/{a}/odom": (Odometry, 10),
        f"/{a}/pose": (PoseStamped, 10),
        f"/{a}/sonar/polar": (Image, sensor_qos),
        f"/{a}/sonar/fan": (Image, sensor_qos),
        f"/{a}/sonar/points": (PointCloud2, sensor_qos),
    }
    rec: dict[str, dict] = {t: {"wall": [], "stamp": [], "first": None} for t in topics}

    def make_cb(topic):
        def cb(msg):
            r = rec[topic]
            r["wall"].append(time.monotonic())
            r["stamp"].append(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)
            if r["first"] is None:
                r["first"] = summary(msg)

        return cb

    for topic, (typ, qos) in topics.items():
        node.create_subscription(typ, topic, make_cb(topic), qos)
    return serve(node, list(topics), rec,
                 received=lambda: {t: len(r["stamp"]) for t, r in rec.items()})


if __name__ == "__main__":
    sys.exit(main())
