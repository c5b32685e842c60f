"""External ROS 2 command publisher that follows a plan: plain rclpy, no uhrisim imports.

``--plan`` is JSON: a list of phases ``[seconds, {key: [value, ...]}]``; during a phase,
every cycle (``--rate`` Hz) publishes each value of each key in turn on
``/<agent>/cmd/<key>``: ``desired_heading|speed|depth`` as std_msgs/Float64 (``NaN``
allowed, JSON's), ``thrusters`` as std_msgs/Float64MultiArray (a list, of any length).
A phase lasts its seconds of *simulated* time, read on ``--clock`` (the bridge's
``/clock``): on a busy machine the simulation may run slower than the wall clock, and
the plan follows it. Waits until the bridge subscribes and the clock ticks, prints
``READY``, runs the plan, prints ``DONE`` and exits (its commands then go stale).
``--rosout`` also prints each ``/rosout`` line of the node ``--bridge-node`` as
``ROSOUT <level> <text>``.

    python ros2_command_plan.py --agent rov \\
        --plan '[[2.0, {"desired_speed": [1e6, -5], "thrusters": [[1, 2]]}]]'
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import rclpy
from rcl_interfaces.msg import Log
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, Float64MultiArray

#: Bound on waiting for the bridge (discovery takes ms to seconds; a busy machine more).
WAIT_S = 300.0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", required=True)
    ap.add_argument("--plan", required=True)
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--rosout", action="store_true")
    ap.add_argument("--bridge-node", default="uhrisim")
    ap.add_argument("--clock", default="/clock", help="the simulation's clock topic")
    args = ap.parse_args()
    plan = json.loads(args.plan)

    rclpy.init()
    node = rclpy.create_node("test_command_plan", start_parameter_services=False)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    keys = sorted({key for _, phase in plan for key in phase})
    pubs = {key: node.create_publisher(Float64MultiArray if key == "thrusters" else Float64,
                                       f"/{args.agent}/cmd/{key}", 10) for key in keys}
    if args.rosout:
        def on_log(msg: Log) -> None:
            if msg.name.endswith(args.bridge_node):
                print(f"ROSOUT {msg.level} {msg.msg}", flush=True)

        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(Log, "/rosout", on_log, qos)
    now: list[float] = []  # the latest simulation time heard (s)

    def on_clock(msg: Clock) -> None:
        now[:] = [msg.clock.sec + msg.clock.nanosec * 1e-9]

    node.create_subscription(Clock, args.clock, on_clock, qos_profile_sensor_data)
    deadline = time.monotonic() + WAIT_S
    while not (now and all(p.get_subscription_count() > 0 for p in pubs.values())):
        if time.monotonic() > deadline:
            print("TIMEOUT waiting for the bridge's subscriptions and clock", flush=True)
            return 2
        executor.spin_once(timeout_sec=0.02)
    executor.spin_once(timeout_sec=0.5)  # let the bridge's readers see our writers
    print("READY", flush=True)
    period = 1.0 / args.rate
    for seconds, phase in plan:
        t0 = now[0]
        while now[0] - t0 < seconds:
            for key, values in phase.items():
                for value in values:
                    if key == "thrusters":
                        pubs[key].publish(Float64MultiArray(data=[float(x) for x in value]))
                    else:
                        pubs[key].publish(Float64(data=float(value)))
            cycle_end = time.monotonic() + period
            while (left := cycle_end - time.monotonic()) > 0:
                executor.spin_once(timeout_sec=left)
    print("DONE", flush=True)
    end = time.monotonic() + (3.0 if args.rosout else 0.0)
    while time.monotonic() < end:  # the last /rosout lines
        executor.spin_once(timeout_sec=0.05)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
