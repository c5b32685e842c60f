"""Lockstep with ROS 2 (issue 6: "or in lockstep for reproducible runs").

``uhrisim run --lockstep`` against a plain-rclpy controller in its own process that
answers each odometry message with desired heading/speed/depth (the docs' example node
with ``--reactive``): every odometry period waits for the answer, so two runs write the
same trajectory to the last bit, and the ROV heads for the controller's goal. Without
a controller the run refuses to start, naming what is missing; a controller that dies
mid-run leaves a run that goes on (not waiting for it, then the safe stop) and says so.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from tests.support.children import Child
from tests.support.ros2_domains import spare_domain_id
from uhrisim.core.errors import BridgeError
from uhrisim.record.reader import OdometryTrack, iter_messages, read_odometry

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "ros2_external_helm.yaml"
SIM_SECONDS = 30.0
GOAL_ENU = (10.0, 8.0)  # m east, m north; the ROV starts at (4, 3)


def _lockstep_run(tmp_path: Path, name: str) -> tuple[OdometryTrack, dict]:
    out = tmp_path / name
    controller = Child("ros2_goto_point.py", [
        "--agent", "videoray", "--x", str(GOAL_ENU[0]), "--y", str(GOAL_ENU[1]),
        "--depth", "3", "--max-speed", "0.8", "--reactive", "--timeout", "300"], tmp_path)
    try:
        sim = subprocess.run(
            [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out", str(out),
             "--lockstep", "--rtf", "0", "--duration", str(SIM_SECONDS), "-q", "--no-figures"],
            capture_output=True, text=True, cwd=ROOT, timeout=240)
    finally:
        controller.proc.kill()
        controller.finish()
    assert sim.returncode == 0, sim.stderr[-2000:]
    metrics = json.loads((out / "metrics.json").read_text())
    return read_odometry(out / "recording.mcap")["videoray"], metrics


def test_lockstep_runs_with_an_outside_controller_repeat_exactly(ros_env: int,
                                                               tmp_path: Path) -> None:
    del ros_env  # loopback discovery, a private domain
    first, metrics = _lockstep_run(tmp_path, "first")
    second, _ = _lockstep_run(tmp_path, "second")

    # every odometry period (10 Hz) was a round the controller answered
    assert metrics["completed"] and metrics["simulated_s"] == pytest.approx(SIM_SECONDS)
    assert metrics["ros2"]["lockstep_rounds"] == round(SIM_SECONDS * 10)
    assert metrics["ros2"]["posted"] == 3 * metrics["ros2"]["lockstep_rounds"]
    assert metrics["ros2"]["failed"] == {}
    # the same trajectory, to the bit, at the recorder's 10 Hz
    for field in ("t", "x_north", "y_east", "depth", "yaw", "u", "v", "w", "r"):
        np.testing.assert_array_equal(first[field], second[field], err_msg=field)
    # under the outside controller's commands: from 7.8 m off the goal to close to it
    distance = np.hypot(first.y_east - GOAL_ENU[0], first.x_north - GOAL_ENU[1])
    assert distance[0] == pytest.approx(np.hypot(6.0, 5.0), abs=0.05)
    assert distance[-1] < 1.0
    assert abs(first.depth[-1] - 3.0) < 0.3


def test_lockstep_without_a_controller_says_what_is_missing(ros_env: int) -> None:
    from uhrisim.bridges.ros2 import Ros2BridgeHook
    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim.simulation import Simulation

    hook = Ros2BridgeHook(domain_id=spare_domain_id(ros_env), lockstep=True,
                          lockstep_start_timeout_s=0.5, publish_scene=False)
    with (pytest.raises(BridgeError, match=r"no controller for 'videoray' within 0\.5 s"),
          Simulation(load_scenario(SCENARIO), hooks=[hook]) as sim):
        sim.run(0.5)
    assert not hook.bridge.started  # closed, nothing left running


def test_a_controller_dying_mid_run_lapses_lockstep_and_the_run_goes_on(
    ros_env: int, tmp_path: Path
) -> None:
    del ros_env
    scenario = tmp_path / "lockstep.yaml"  # lockstep from the scenario file, 1 s rounds
    # (the start still waits up to 30 s for the controller: discovery on a busy machine)
    text = SCENARIO.read_text()
    section = "ros2: {enabled: true, odom_rate_hz: 10, command_timeout_s: 1.0"
    assert section in text
    scenario.write_text(text.replace(
        section, section + ", lockstep: true, lockstep_timeout_s: 1.0"))
    out = tmp_path / "run"
    controller = Child("ros2_goto_point.py", [
        "--agent", "videoray", "--x", str(GOAL_ENU[0]), "--y", str(GOAL_ENU[1]),
        "--depth", "3", "--max-speed", "0.8", "--reactive", "--timeout", "300"], tmp_path)
    sim = subprocess.Popen(
        [sys.executable, "-m", "uhrisim", "run", str(scenario), "--out", str(out),
         "--rtf", "4", "--duration", "40", "-q", "--no-figures"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        controller.expect("ARRIVED", timeout=60.0)  # ~15 simulated s in: SIGKILL it
        controller.proc.send_signal(signal.SIGKILL)
        controller.finish()
        _stdout, stderr = sim.communicate(timeout=120.0)
    finally:
        if sim.poll() is None:
            sim.kill()
    assert sim.returncode == 0, stderr[-2000:]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["completed"] and metrics["simulated_s"] == pytest.approx(40.0)
    events = [(m.message.header.stamp.sec, m.message.detail)
              for m in iter_messages(out / "recording.mcap", ["/events"])
              if m.message.kind == "bridge"]
    lapsed = [t for t, detail in events if "lockstep lapsed" in detail]
    stopped = [t for t, detail in events if "safe stop" in detail]
    assert len(lapsed) == 1 and len(stopped) == 1 and lapsed[0] <= stopped[0] < 40, events
    assert 10 * lapsed[0] <= metrics["ros2"]["lockstep_rounds"] < 400
