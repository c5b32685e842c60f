"""External ROS 2 subscriber for the camera topics: plain rclpy, no uhrisim imports.

Subscribes (sensor-data QoS, best effort; ``--reliable``: reliable, keep-last 5) to one
agent's ``camera/image_raw``,
``camera/camera_info`` and ``camera/depth``, prints ``READY`` once each has a publisher,
and on ``STOP`` prints one JSON line ``RESULT {...}`` with, per topic, the count and a
summary of the first message (header, size, encoding, a checksum of the pixels, K).

    python ros2_camera_listener.py --agent rov [--reliable]
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image


def summary(msg) -> dict:
    h = msg.header
    out = {"frame_id": h.frame_id, "stamp": [h.stamp.sec, h.stamp.nanosec],
           "height": msg.height, "width": msg.width}
    if isinstance(msg, Image):
        data = bytes(msg.data)
        out.update(encoding=msg.encoding, step=msg.step, nbytes=len(data),
                   checksum=int(sum(data) % 1_000_003))
    else:
        out.update(k=list(msg.k), p=list(msg.p), distortion_model=msg.distortion_model)
    return out


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
    topics = {f"/{args.agent}/camera/image_raw": Image,
              f"/{args.agent}/camera/camera_info": CameraInfo,
              f"/{args.agent}/camera/depth": Image}
    seen: dict[str, dict] = {t: {"count": 0, "first": None} for t in topics}

    def callback(topic):
        def on_msg(msg):
            entry = seen[topic]
            entry["count"] += 1
            if entry["first"] is None:
                entry["first"] = summary(msg)
        return on_msg

    for topic, kind in topics.items():
        node.create_subscription(kind, topic, callback(topic), qos)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()

    def read_stdin():
        for line in sys.stdin:
            if line.strip() == "STOP":
                break
        stop.set()

    threading.Thread(target=read_stdin, daemon=True).start()
    ready = False
    deadline = time.monotonic() + 30.0
    while not stop.is_set():  # spin on this thread; stdin is read on another
        executor.spin_once(timeout_sec=0.02)
        if not ready and all(node.count_publishers(t) > 0 for t in topics):
            ready = True
            print("READY", flush=True)
        if not ready and time.monotonic() > deadline:
            print("TIMEOUT waiting for publishers", flush=True)
            return 2
    print("RESULT " + json.dumps(seen), flush=True)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
