"""External ROS 2 command publisher for the bridge tests: plain rclpy, no uhrisim imports.

Waits until the bridge subscribes to ``/<agent>/cmd/*``, prints ``READY``, publishes
desired heading (compass deg), speed (m/s), depth (m, down) as std_msgs/Float64 and
thrusters ``[port, starboard, vertical]`` as std_msgs/Float64MultiArray at ``--rate``
Hz for ``--duration`` s, prints ``DONE`` and exits (the bridge must then see the
commands go stale).

    python ros2_commander.py --agent rov --heading 45 --speed 0.5 --depth 3 \
        --thrusters 10 -20 30 --rate 20 --duration 1.5
"""

from __future__ import annotations

import argparse
import sys
import time

import rclpy
from std_msgs.msg import Float64, Float64MultiArray


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", required=True)
    ap.add_argument("--heading", type=float, required=True)
    ap.add_argument("--speed", type=float, required=True)
    ap.add_argument("--depth", type=float, required=True)
    ap.add_argument("--thrusters", type=float, nargs=3, required=True)
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--duration", type=float, default=1.5)
    args = ap.parse_args()

    rclpy.init()
    node = rclpy.create_node("test_commander", start_parameter_services=False)
    a = args.agent
    pubs = {
        k: node.create_publisher(Float64, f"/{a}/cmd/{k}", 10)
        for k in ("desired_heading", "desired_speed", "desired_depth")
    }
    thr = node.create_publisher(Float64MultiArray, f"/{a}/cmd/thrusters", 10)
    deadline = time.monotonic() + 600.0  # only for one left behind (as listener_loop's)
    while not all(p.get_subscription_count() > 0 for p in [*pubs.values(), thr]):
        if time.monotonic() > deadline:
            print("TIMEOUT waiting for the bridge's subscriptions", flush=True)
            return 2
        time.sleep(0.02)
    print("READY", flush=True)
    values = {
        "desired_heading": args.heading,
        "desired_speed": args.speed,
        "desired_depth": args.depth,
    }
    period = 1.0 / args.rate
    t0 = time.monotonic()
    k = 0
    while time.monotonic() - t0 < args.duration:
        for key, pub in pubs.items():
            pub.publish(Float64(data=values[key]))
        thr.publish(Float64MultiArray(data=list(args.thrusters)))
        k += 1
        time.sleep(max(0.0, t0 + k * period - time.monotonic()))
    print(f"DONE {k}", flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
