"""External ROS 2 subscriber that keeps every header stamp: plain rclpy, no uhrisim
imports (marine_acoustic_msgs built at install time).

Subscribes best effort (the sensor-data QoS, but keeping the last ``HISTORY_DEPTH``) to
each ``--topic NAME=TYPE`` (``image`` = sensor_msgs/Image, ``sonar`` =
marine_acoustic_msgs/ProjectedSonarImage), prints ``READY`` once every topic has a
publisher and on ``STOP [{topic: count}]`` (tests/support/listener_loop.py) one JSON line
``RESULT {topic: [stamp_ns, ...]}`` in order of arrival.

    python ros2_stamps_listener.py --topic /videoray/sonar/polar=image \\
        --topic /videoray/sonar/image=sonar
"""

from __future__ import annotations

import argparse
import sys

import rclpy
from listener_loop import serve
from marine_acoustic_msgs.msg import ProjectedSonarImage
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

TYPES = {"image": Image, "sonar": ProjectedSonarImage}
#: Messages kept per topic until this process takes them: 6.7 s at 15 Hz. Best effort
#: says nothing about history; a subscriber that must get every image keeps more than it
#: may lag. With the sensor-data QoS's 5 (333 ms at 15 Hz) a listener stalled for 0.6 s
#: (measured: up to 1 s between its takes at load average 22 on 2 cores) lost 3 of 9.
HISTORY_DEPTH = 100
EVERY_MESSAGE_BEST_EFFORT = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=HISTORY_DEPTH,
    reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--topic", action="append", required=True)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("test_stamps_listener", start_parameter_services=False)
    stamps: dict[str, list[int]] = {}
    for spec in args.topic:
        topic, _, kind = spec.partition("=")
        got = stamps[topic] = []

        def on_msg(msg, got=got) -> None:
            got.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)

        node.create_subscription(TYPES[kind], topic, on_msg, EVERY_MESSAGE_BEST_EFFORT)
    return serve(node, list(stamps), lambda: stamps,
                 received=lambda: {t: len(got) for t, got in stamps.items()})


if __name__ == "__main__":
    sys.exit(main())
