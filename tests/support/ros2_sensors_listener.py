"""External ROS 2 subscriber for an agent with several sonars and cameras: plain rclpy, no
uhrisim imports (marine_acoustic_msgs and tf2_msgs built at install time: python -m
uhrisim.bridges.ros2.interfaces).

Subscribes (sensor-data QoS) to each named sonar's ``<sonar>/image``
(marine_acoustic_msgs/ProjectedSonarImage) and ``<sonar>/fan``, each named camera's
``<camera>/image_raw``, and (latched) to ``/tf_static``; prints ``READY`` once every topic
has a publisher and on ``STOP`` one JSON line ``RESULT {...}``: per topic the number of
messages and the frame ids seen, per sonar image the beam count and the beam azimuths'
span (rad), per image its width and height; ``static``: the /tf_static transforms
``[parent, child, [tx, ty, tz], [qx, qy, qz, qw]]``.

    python ros2_sensors_listener.py --agent videoray --sonars narrow wide --cameras camera
"""

from __future__ import annotations

import argparse
import math
import sys

import rclpy
from listener_loop import serve
from marine_acoustic_msgs.msg import ProjectedSonarImage
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from ros2_tf_rows import transform_rows
from sensor_msgs.msg import Image
from tf2_msgs.msg import TFMessage


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", required=True)
    ap.add_argument("--sonars", nargs="*", default=[])
    ap.add_argument("--cameras", nargs="*", default=[])
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("test_sensors_listener", start_parameter_services=False)
    a = args.agent
    topics = {f"/{a}/{s}/image": ProjectedSonarImage for s in args.sonars}
    topics |= {f"/{a}/{s}/fan": Image for s in args.sonars}
    topics |= {f"/{a}/{c}/image_raw": Image for c in args.cameras}
    result: dict = {"topics": {t: {"count": 0, "frames": [], "first": None} for t in topics},
                    "static": []}

    def make_cb(topic):
        def cb(msg):
            r = result["topics"][topic]
            r["count"] += 1
            if msg.header.frame_id not in r["frames"]:
                r["frames"].append(msg.header.frame_id)
            if r["first"] is None:
                if isinstance(msg, ProjectedSonarImage):
                    angles = [math.atan2(v.y, v.z) for v in msg.beam_directions]
                    r["first"] = {"beam_count": msg.image.beam_count,
                                  "span": max(angles) - min(angles),
                                  "far_range": float(msg.ranges[-1])}
                else:
                    r["first"] = {"width": msg.width, "height": msg.height}

        return cb

    for topic, kind in topics.items():
        node.create_subscription(kind, topic, make_cb(topic), qos_profile_sensor_data)

    def on_static(msg: TFMessage) -> None:
        result["static"] = transform_rows(msg)

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(TFMessage, "/tf_static", on_static, latched)
    return serve(node, [*topics, "/tf_static"], result,
                 received=lambda: {t: r["count"] for t, r in result["topics"].items()})


if __name__ == "__main__":
    sys.exit(main())
