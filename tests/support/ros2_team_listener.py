"""A plain rclpy node that watches the teamwork world on ROS 2 for the bridge tests: every
/tf transform, one diver's sensor_msgs/JointState, the uhrisim_msgs/Event stream, and what
the bridge's node advertises and subscribes to (asked of the ROS graph). No uhrisim
imports (the message packages are built at install time).

Prints ``READY`` once /tf, the joint states and /events have a publisher; on ``STOP``
(stdin) prints ``RESULT <json>``: ``tf``: "sec.nanosec" -> the transforms of that stamp
(``[parent, child, [x, y, z], [qx, qy, qz, qw]]``); ``joints``: "sec.nanosec" ->
``[names, positions]``; ``events``: ``[kind, detail]`` in arrival order; ``published`` and
``subscribed``: the bridge node's topic names.

    python ros2_team_listener.py --diver diver1 --node uhrisim_team_test
"""

from __future__ import annotations

import argparse
import sys

import rclpy
from listener_loop import serve
from ros2_tf_rows import stamp_key, transform_rows
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage
from uhrisim_msgs.msg import Event


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--diver", required=True)
    ap.add_argument("--node", required=True)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("test_team_listener", start_parameter_services=False)
    result: dict = {"tf": {}, "joints": {}, "events": [], "published": [], "subscribed": []}
    joints = f"/{args.diver}/joint_states"
    taken = dict.fromkeys(["/tf", joints, "/events"], 0)  # messages taken per topic

    def counted(topic: str, keep):
        def on_msg(msg) -> None:
            taken[topic] += 1
            keep(msg)
        return on_msg

    def on_tf(msg: TFMessage) -> None:
        if msg.transforms:
            result["tf"].setdefault(stamp_key(msg.transforms[0].header), []).extend(
                transform_rows(msg))

    def on_joints(msg: JointState) -> None:
        result["joints"][stamp_key(msg.header)] = [list(msg.name), list(msg.position)]

    node.create_subscription(TFMessage, "/tf", counted("/tf", on_tf), 1000)
    node.create_subscription(JointState, joints, counted(joints, on_joints), 100)
    node.create_subscription(Event, "/events", counted(
        "/events", lambda m: result["events"].append([m.kind, m.detail])), 100)

    def graph() -> dict:
        result["published"] = sorted(
            n for n, _ in node.get_publisher_names_and_types_by_node(args.node, "/"))
        result["subscribed"] = sorted(
            n for n, _ in node.get_subscriber_names_and_types_by_node(args.node, "/"))
        return result

    return serve(node, list(taken), graph, received=lambda: taken)


if __name__ == "__main__":
    sys.exit(main())
