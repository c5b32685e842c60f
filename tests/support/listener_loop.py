"""The loop of the external rclpy listeners (``ros2_listener.py``, ``ros2_marker_listener.py``,
``ros2_camera_listener.py``, ...): spin ``node`` until ``STOP`` on stdin (or its end), print
``READY`` once every topic has a publisher (``TIMEOUT ...`` and exit status 2 if none comes
within ``ready_timeout_s``: only a bound for a listener left behind, a test waits for
``READY`` as long as its own ``expect`` says), let ``settle(spin_once)`` spin on for what is
still due, then print one JSON line ``RESULT <result>`` (``result()`` when it is callable)
and shut down.

``STOP {"topic": count, ...}`` (what the test published) makes the listener spin on until
``received()`` (messages taken per topic) has reached every count, or ``STOP_WAIT_S`` has
passed (a best-effort message may be lost: then the test's own check decides), so a test
waits for its messages in flight, not for a guessed time. Plain rclpy, no uhrisim."""

from __future__ import annotations

import json
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import rclpy
from children import STOP_WAIT_S
from rclpy.executors import SingleThreadedExecutor


def serve(node: Any, topics: list[str], result: Any, ready_timeout_s: float = 600.0,
          settle: Callable[[Callable[[], None]], None] | None = None,
          received: Callable[[], dict[str, int]] | None = None) -> int:
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    stop = threading.Event()
    expected: dict[str, int] = {}

    def read_stdin():
        for line in sys.stdin:
            word, _, counts = line.strip().partition(" ")
            if word == "STOP":
                expected.update(json.loads(counts) if counts else {})
                break
        stop.set()

    threading.Thread(target=read_stdin, daemon=True).start()
    ready = False
    deadline = time.monotonic() + ready_timeout_s
    while not stop.is_set():
        ex.spin_once(timeout_sec=0.02)
        if not ready and all(node.count_publishers(t) > 0 for t in topics):
            ready = True
            print("READY", flush=True)
        if not ready and time.monotonic() > deadline:
            print("TIMEOUT waiting for publishers", flush=True)
            return 2
    if expected:
        if received is None:
            raise SystemExit("STOP with counts: this listener has no received()")
        deadline = time.monotonic() + STOP_WAIT_S
        while time.monotonic() < deadline and any(
                received().get(t, 0) < n for t, n in expected.items()):
            ex.spin_once(timeout_sec=0.02)
    if settle is not None:
        settle(lambda: ex.spin_once(timeout_sec=0.02))
    print("RESULT " + json.dumps(result() if callable(result) else result), flush=True)
    ex.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0
