"""A ROS 2 node in its own process that subscribes to given topics and counts messages:
the consumer the bridge benchmarks publish to, so DDS really serialises and sends.

Parent side: :class:`Listener` (a context manager). Child side (plain rclpy, no
simulation code): ``python -m uhrisim.bench._ros2_listener TOPICS_JSON`` where
``TOPICS_JSON`` is a list of ``[topic, "pkg/msg/Type", qos]`` with ``qos`` one of
``"reliable"`` (keep last 10), ``"sensor"`` (``qos_profile_sensor_data``) or
``"latched"`` (reliable, transient local, keep last 1). Subscriptions are raw (the
listener never deserialises). The child prints ``READY``, answers ``COUNTS`` with a
JSON line of messages per topic, and exits on ``STOP`` or end of stdin. Its
environment (ROS_DOMAIN_ID, discovery range, log folder) comes from the parent.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import threading
from collections.abc import Sequence
from typing import Any

#: How long the parent waits for the child's lines (s).
LINE_TIMEOUT_S = 30.0


def qos_label(qos: Any) -> str:
    """The listener's name for the subscription that matches a publisher's QoS."""
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        return "latched"
    return "sensor" if qos.reliability == ReliabilityPolicy.BEST_EFFORT else "reliable"


def type_name(msg_type: type) -> str:
    """``"pkg/msg/Type"`` of a ROS 2 message class."""
    return f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"


class Listener:
    """Starts the listener process on ``topics`` (``(topic, "pkg/msg/Type", qos)``) in
    ROS domain ``domain`` and waits for it to say READY."""

    def __init__(self, topics: Sequence[tuple[str, str, str]], domain: int) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", __name__, json.dumps([list(t) for t in topics])],
            env={**os.environ, "ROS_DOMAIN_ID": str(domain)},
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            text=True,
        )
        self._line("READY")

    def _line(self, prefix: str) -> str:
        assert self.proc.stdout is not None
        found: list[str] = []

        def read() -> None:
            assert self.proc.stdout is not None
            for line in self.proc.stdout:
                if line.startswith(prefix):
                    found.append(line[len(prefix):].strip())
                    return

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        reader.join(LINE_TIMEOUT_S)
        if not found:
            self.close()
            raise RuntimeError(f"ROS 2 listener process gave no {prefix!r} line "
                               f"within {LINE_TIMEOUT_S:g} s")
        return found[0]

    def counts(self) -> dict[str, int]:
        """Messages received so far, per topic."""
        assert self.proc.stdin is not None
        self.proc.stdin.write("COUNTS\n")
        self.proc.stdin.flush()
        return json.loads(self._line("COUNTS "))

    def close(self) -> None:
        """Stop the process (killed if it does not end within 10 s)."""
        try:
            assert self.proc.stdin is not None
            self.proc.stdin.write("STOP\n")
            self.proc.stdin.flush()
            self.proc.wait(timeout=10)
        except (OSError, ValueError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()

    def __enter__(self) -> Listener:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _main(topics: list[list[str]]) -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

    qos = {"reliable": QoSProfile(depth=10), "sensor": qos_profile_sensor_data,
           "latched": QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)}
    rclpy.init()
    node = rclpy.create_node(f"uhrisim_bench_listener_{os.getpid()}",
                             start_parameter_services=False)
    counts: dict[str, int] = {}
    for topic, type_path, kind in topics:
        package, _, name = type_path.split("/")
        msg_type = getattr(importlib.import_module(f"{package}.msg"), name)
        counts[topic] = 0

        def count(_raw: bytes, topic: str = topic) -> None:
            counts[topic] += 1

        node.create_subscription(msg_type, topic, count, qos[kind], raw=True)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()

    def commands() -> None:
        for line in sys.stdin:
            if line.strip() == "COUNTS":
                print("COUNTS " + json.dumps(counts), flush=True)
            elif line.strip() == "STOP":
                break
        stop.set()

    threading.Thread(target=commands, daemon=True).start()
    print("READY", flush=True)
    while not stop.is_set():
        executor.spin_once(timeout_sec=0.05)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    _main(json.loads(sys.argv[1]))
