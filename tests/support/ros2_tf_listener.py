"""A plain rclpy node that collects /tf, /tf_static, an agent's sonar points, its
marine_acoustic_msgs/ProjectedSonarImage and its helm decisions (uhrisim_msgs), for the
bridge tests; no uhrisim imports (the message packages are built at install time).

Prints ``READY`` once every topic has a publisher; on ``STOP [{topic: count}]`` (stdin;
tests/support/listener_loop.py) prints ``RESULT <json>``:
``static``: the /tf_static transforms; ``tf``: "sec.nanosec" -> the /tf transforms of
that stamp; ``points``: "sec.nanosec" -> the cloud's (x, y, z) rows (float32 -> float);
``image``: the last ProjectedSonarImage's frame, stamp, beam directions, ranges, dtype,
beam count, data length, frequency and sound speed; ``decisions``: "sec.nanosec" -> the
uhrisim_msgs/HelmDecision's heading, mode, contributions and total. A transform is
``[parent, child, [tx, ty, tz], [qx, qy, qz, qw]]``.

    python ros2_tf_listener.py --agent videoray
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter

import numpy as np
import rclpy
from listener_loop import serve
from marine_acoustic_msgs.msg import ProjectedSonarImage
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from ros2_tf_rows import stamp_key, transform_rows
from sensor_msgs.msg import PointCloud2
from tf2_msgs.msg import TFMessage
from uhrisim_msgs.msg import HelmDecision


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", required=True)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("test_tf_listener", start_parameter_services=False)
    result: dict = {"static": [], "tf": {}, "points": {}, "image": None, "decisions": {}}
    taken: Counter[str] = Counter()
    tf, points, image, decision = ("/tf", f"/{args.agent}/sonar/points",
                                   f"/{args.agent}/sonar/image", f"/{args.agent}/helm/decision")

    def on_tf(msg: TFMessage) -> None:
        taken[tf] += 1
        for tr in transform_rows(msg):
            stamp = stamp_key(msg.transforms[0].header)
            result["tf"].setdefault(stamp, []).append(tr)

    def on_static(msg: TFMessage) -> None:
        result["static"] = transform_rows(msg)

    def on_points(msg: PointCloud2) -> None:
        taken[points] += 1
        xyz = np.frombuffer(bytes(msg.data), "<f4").reshape(-1, 4)[:, :3]
        if len(xyz):
            result["points"][stamp_key(msg.header)] = xyz.astype(float).tolist()

    def on_image(msg: ProjectedSonarImage) -> None:
        taken[image] += 1
        result["image"] = {
            "frame_id": msg.header.frame_id, "stamp": stamp_key(msg.header),
            "directions": [[v.x, v.y, v.z] for v in msg.beam_directions],
            "ranges": [float(r) for r in msg.ranges], "dtype": msg.image.dtype,
            "beam_count": msg.image.beam_count, "n_data": len(msg.image.data),
            "frequency": msg.ping_info.frequency, "sound_speed": msg.ping_info.sound_speed,
        }

    def on_decision(msg: HelmDecision) -> None:
        taken[decision] += 1
        result["decisions"][stamp_key(msg.header)] = {
            "heading": msg.heading_deg if msg.has_heading else None, "mode": msg.mode,
            "contributions": {c.name: c.value for c in msg.contributions},
            "total": msg.total}

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(TFMessage, tf, on_tf, 100)
    node.create_subscription(TFMessage, "/tf_static", on_static, latched)
    node.create_subscription(PointCloud2, points, on_points, qos_profile_sensor_data)
    node.create_subscription(ProjectedSonarImage, image, on_image, qos_profile_sensor_data)
    node.create_subscription(HelmDecision, decision, on_decision, 50)
    return serve(node, [tf, "/tf_static", points, image, decision], result,
                 received=lambda: dict(taken))


if __name__ == "__main__":
    sys.exit(main())
