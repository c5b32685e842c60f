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
import sys

import rclpy
from listener_loop import serve
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
    return serve(node, topics, rec)


if __name__ == "__main__":
    sys.exit(main())
