"""SIGTERM ends a ROS 2 run as Ctrl-C does (issue 30): what ``ros2 launch`` and service
managers send. The run (scenarios/ros2_external_helm.yaml with ``--ros2``, its own
process) is stopped once a plain-rclpy listener in another process sees its topics; it
exits with 128 + 15 and one line, leaving a complete bag (metadata.yaml, read back with
rosbags), metrics.json saying why it stopped, and no Fast DDS shared-memory file whose
owner is gone. How long the stop takes is measured, not asserted (docs/bridges-ros2.md).
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rclpy")
pytest.importorskip("rosbags")

from rosbags.highlevel import AnyReader

from tests.support import ros2_shm
from tests.support.children import Child

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "ros2_external_helm.yaml"


def test_sigterm_leaves_a_complete_bag_and_no_shared_memory(ros_env: int,
                                                           tmp_path: Path) -> None:
    del ros_env  # (the environment: ROS_DOMAIN_ID, loopback discovery)
    before = ros2_shm.shm_snapshot()
    out = tmp_path / "run"
    listener = Child("ros2_listener.py", ["--agent", "videoray"], tmp_path)
    run = subprocess.Popen([sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out",
                            str(out), "-q", "--ros2"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        listener.expect("READY", timeout=300.0)  # the bridge's topics are up: mid-run
        run.send_signal(signal.SIGTERM)
        _, stderr = run.communicate(timeout=120.0)
        listener.result(timeout=60.0)
    finally:
        for proc in (run, listener.proc):
            if proc.poll() is None:
                proc.kill()
    assert run.returncode == 128 + signal.SIGTERM, stderr
    assert stderr.strip().splitlines() == ["error: stopped by SIGTERM"]
    with AnyReader([out]) as bag:  # metadata.yaml and the MCAP file: a whole rosbag2 bag
        # (the stop may come before the first tick: then only the start's messages)
        assert sum(c.msgcount for c in bag.connections) > 0
        decoded = sum(bool(bag.deserialize(raw, c.msgtype)) for c, _, raw in bag.messages())
        assert decoded == sum(c.msgcount for c in bag.connections)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["completed"] is False and "SIGTERM" in metrics["stopped_by"]
    orphans = [n for n in ros2_shm.shm_snapshot() - before
               if n.endswith("_el") and not ros2_shm.owner_alive(ros2_shm.SHM / n)]
    assert orphans == []
