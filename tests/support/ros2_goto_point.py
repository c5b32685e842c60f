"""Drive a uhrisim ROV to a point through the ROS 2 bridge: plain rclpy, no uhrisim code.

This is the example node of docs/bridges-ros2.md (kept here so a test runs it).
It reads ``/<agent>/odom`` (nav_msgs/Odometry, ENU "map" frame) and publishes
``/<agent>/cmd/desired_heading`` (compass degrees: 0 north, 90 east),
``/<agent>/cmd/desired_speed`` (m/s) and ``/<agent>/cmd/desired_depth`` (m, positive
down) at 10 Hz, slowing down near the goal and stopping inside ``--radius``. With
``--reactive`` it answers each odometry message at once instead (the controller of a
lockstep run, ``uhrisim run --lockstep``) and keeps answering until stopped.

    python ros2_goto_point.py --agent rov --x 10 --y 5 --depth 3
    # goal: 10 m east, 5 m north of the map origin, 3 m deep

Environment: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and the simulator's ROS_DOMAIN_ID.
Prints ``ARRIVED <distance>`` once inside the radius and exits after --hold s (not with
``--reactive``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import rclpy
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", default="rov")
    ap.add_argument("--x", type=float, required=True, help="goal east of origin (m, ENU x)")
    ap.add_argument("--y", type=float, required=True, help="goal north of origin (m, ENU y)")
    ap.add_argument("--depth", type=float, required=True, help="goal depth (m, down)")
    ap.add_argument("--max-speed", type=float, default=1.0, help="m/s")
    ap.add_argument("--radius", type=float, default=0.5, help="arrival radius (m)")
    ap.add_argument("--hold", type=float, default=0.5, help="s to keep commanding stop")
    ap.add_argument("--timeout", type=float, default=60.0, help="give up after (wall s)")
    ap.add_argument("--reactive", action="store_true",
                    help="answer each odometry message at once (lockstep runs)")
    args = ap.parse_args()

    rclpy.init()
    node = rclpy.create_node("goto_point")
    a = args.agent
    pub_heading = node.create_publisher(Float64, f"/{a}/cmd/desired_heading", 10)
    pub_speed = node.create_publisher(Float64, f"/{a}/cmd/desired_speed", 10)
    pub_depth = node.create_publisher(Float64, f"/{a}/cmd/desired_depth", 10)
    state = {"odom": None, "arrived_at": None}

    def command(odom: Odometry) -> None:
        """Head for the goal from the pose in ``odom``: the three desired values."""
        p = odom.pose.pose.position  # ENU: x east, y north, z up
        d_east, d_north = args.x - p.x, args.y - p.y
        dist = math.hypot(d_east, d_north)
        heading = math.degrees(math.atan2(d_east, d_north)) % 360.0  # compass
        speed = min(args.max_speed, 0.5 * dist)
        if dist < args.radius and state["arrived_at"] is None:
            state["arrived_at"] = time.monotonic()
            print(f"ARRIVED {dist:.3f}", flush=True)
        if state["arrived_at"] is not None:
            speed = 0.0
        pub_heading.publish(Float64(data=heading))
        pub_speed.publish(Float64(data=speed))
        pub_depth.publish(Float64(data=args.depth))

    def on_odom(msg: Odometry) -> None:
        state["odom"] = msg
        if args.reactive:
            command(msg)

    node.create_subscription(Odometry, f"/{a}/odom", on_odom, 10)

    def on_timer() -> None:
        if state["odom"] is not None:
            command(state["odom"])

    if not args.reactive:
        node.create_timer(0.1, on_timer)
    t0 = time.monotonic()
    try:
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.05)
            done = state["arrived_at"]
            if done is not None and not args.reactive and time.monotonic() - done > args.hold:
                break
            if time.monotonic() - t0 > args.timeout:
                print("TIMEOUT", flush=True)
                return 1
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
