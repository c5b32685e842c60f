"""External ROS 2 subscriber for the perception markers: plain rclpy, no uhrisim imports.

Subscribes (reliable, as RViz2's default) to ``/<agent>/perception/tracks`` and
``/<agent>/perception/detections`` (visualization_msgs/MarkerArray), prints ``READY``
once both have a publisher, and on ``STOP`` (or end of stdin) prints one JSON line
``RESULT {topic: [{"stamp": s, "markers": [[ns, id, action, frame_id, x, y, text], ...]},
...]}`` and exits.

    python ros2_marker_listener.py --agent videoray
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from visualization_msgs.msg import MarkerArray


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", required=True)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("marker_listener", start_parameter_services=False)
    topics = [f"/{args.agent}/perception/tracks", f"/{args.agent}/perception/detections"]
    rec: dict[str, list] = {t: [] for t in topics}

    def make_cb(topic):
        def cb(msg):
            markers = [[m.ns, m.id, m.action, m.header.frame_id, m.pose.position.x,
                        m.pose.position.y, m.text] for m in msg.markers]
            stamp = msg.markers[0].header.stamp if msg.markers else None
            rec[topic].append({"stamp": stamp.sec + 1e-9 * stamp.nanosec if stamp else None,
                               "markers": markers})

        return cb

    for topic in topics:
        node.create_subscription(MarkerArray, topic, make_cb(topic), 10)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    stop = threading.Event()

    def read_stdin():
        for line in sys.stdin:
            if line.strip() == "STOP":
                break
        stop.set()

    threading.Thread(target=read_stdin, daemon=True).start()
    ready = False
    deadline = time.monotonic() + 40.0
    while not stop.is_set():
        ex.spin_once(timeout_sec=0.02)
        if not ready and all(node.count_publishers(t) > 0 for t in topics):
            ready = True
            print("READY", flush=True)
        if not ready and time.monotonic() > deadline:
            print("TIMEOUT waiting for publishers", flush=True)
            return 2
    print("RESULT " + json.dumps(rec), flush=True)
    ex.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
