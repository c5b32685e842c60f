"""External ROS 2 subscriber that keeps every header stamp: plain rclpy, no uhrisim
imports (marine_acoustic_msgs built at install time).

Subscribes best effort (sensor-data QoS, keep the last 5) to each ``--topic NAME=TYPE``
(``image`` = sensor_msgs/Image, ``sonar`` = marine_acoustic_msgs/ProjectedSonarImage),
prints ``READY`` once every topic has a publisher and on ``STOP`` one JSON line
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
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Image

TYPES = {"image": Image, "sonar": ProjectedSonarImage}


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

        node.create_subscription(TYPES[kind], topic, on_msg, qos_profile_sensor_data)
    return serve(node, list(stamps), lambda: stamps, ready_timeout_s=300.0)


if __name__ == "__main__":
    sys.exit(main())
