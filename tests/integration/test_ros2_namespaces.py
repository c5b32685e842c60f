"""Two simulators on one ROS domain, in different namespaces, do not collide (issue 16).

Both run scenarios/ros2_external_helm.yaml here, paced at real time; one gets its
namespace by remapping (``--ros-args -r __ns:=/sim_a``), the other from the hook's
``namespace`` with parameters (``-p``). A separate plain-rclpy process commands only
``/sim_a/videoray``: that ROV moves, the other stays where it starts. Each node, each
``clock``, ``tf`` and agent topic exists once per namespace, and the parameters took
effect (rates, reliable sensor and clock QoS).
"""

from __future__ import annotations

import importlib.util
import json
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from rclpy.qos import ReliabilityPolicy

from tests.support.children import Child
from uhrisim.bridges.ros2.hook import Ros2BridgeHook
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.pacing import Pacer
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "ros2_external_helm.yaml"


def test_two_simulators_in_two_namespaces_on_one_domain(ros_env: int, tmp_path: Path) -> None:
    hook_a = Ros2BridgeHook(domain_id=ros_env, ros_args=["-r", "__ns:=/sim_a",
                                                         "-p", "odom_rate_hz:=20.0"])
    hook_b = Ros2BridgeHook(domain_id=ros_env, namespace="/sim_b",
                            ros_args=["-p", "sensor_qos:=reliable", "-p", "clock_qos:=reliable"])
    sims = [Simulation(load_scenario(SCENARIO), raycast_sensors=sonar, hooks=[hook])
            for hook, sonar in ((hook_a, False), (hook_b, True))]
    plan = [[3.0, {"desired_heading": [90.0], "desired_speed": [0.6], "desired_depth": [2.0]}]]
    commander = Child("ros2_command_plan.py", ["--agent", "sim_a/videoray", "--plan",
                                               json.dumps(plan), "--clock", "/sim_a/clock"],
                      tmp_path)
    try:
        for sim in sims:
            sim.start()
        pacer = Pacer(real_time_factor=1.0)
        pacer.reset(0.0)
        done_at = None
        deadline = time.monotonic() + 600.0  # the commander's start and discovery: a busy
        while done_at is None or sims[0].t < done_at + 0.5:  # machine takes its time
            assert time.monotonic() < deadline and commander.proc.poll() in (None, 0), \
                f"the commander never finished: {commander.stderr_path.read_text()[-2000:]}"
            for sim in sims:
                sim.step()
            pacer.wait(sims[0].t)
            if done_at is None and commander.poll_line("DONE") is not None:
                done_at = sims[0].t
        node = hook_a.bridge._node  # the graph as one participant sees it
        topics = dict(node.get_topic_names_and_types())
        nodes = set(node.get_node_names_and_namespaces())
        clock_b = node.get_publishers_info_by_topic("/sim_b/clock")
        image_b = node.get_publishers_info_by_topic("/sim_b/videoray/sonar/polar")
        clock_a = node.get_publishers_info_by_topic("/sim_a/clock")
        params = (hook_a.bridge.parameters, hook_b.bridge.parameters)
        assert commander.finish(timeout=15.0) == 0
    finally:
        for sim in sims:
            sim.close()
        if commander.proc.poll() is None:
            commander.proc.kill()

    assert {("uhrisim", "/sim_a"), ("uhrisim", "/sim_b")} <= nodes
    for ns in ("/sim_a", "/sim_b"):
        for topic in ("clock", "videoray/odom", "videoray/cmd/desired_speed", "scene/markers",
                      *(("tf", "tf_static") if importlib.util.find_spec("tf2_msgs") else ())):
            assert f"{ns}/{topic}" in topics, f"{ns}/{topic}"
    assert not {"/clock", "/tf", "/videoray/odom"} & set(topics)  # nothing at the root

    # only sim_a's ROV obeyed: it moved east at the commanded speed; sim_b's stayed put
    start = np.array([3.0, 4.0, 2.0])
    moved_a = np.linalg.norm(sims[0].agents["videoray"].nav().position_ned - start)
    moved_b = np.linalg.norm(sims[1].agents["videoray"].nav().position_ned - start)
    assert moved_a > 0.8 and moved_b < 0.01
    assert hook_a.n_posted > 0 and hook_b.n_posted == 0

    # the parameters took effect
    assert params[0].odom_rate_hz == 20.0 and params[1].odom_rate_hz == 0.0
    assert params[1].sensor_qos == params[1].clock_qos == "reliable"
    assert clock_b[0].qos_profile.reliability == ReliabilityPolicy.RELIABLE
    assert image_b[0].qos_profile.reliability == ReliabilityPolicy.RELIABLE
    assert clock_a[0].qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT


def test_a_bad_parameter_is_one_line_naming_it(ros_env: int, tmp_path: Path) -> None:
    """A parameter of the wrong value or type stops the start with a ConfigError naming
    it; on the command line, one ``error:`` line and exit status 2."""
    from uhrisim.bridges.ros2 import AgentBridgeSpec, Ros2Bridge
    from uhrisim.core.errors import ConfigError

    for args, name in ((["-p", "sensor_qos:=fast"], "sensor_qos"),
                       (["-p", "odom_rate_hz:=20"], "odom_rate_hz"),  # an int, not a double
                       (["-p", "clock_rate_hz:=-1.0"], "clock_rate_hz")):
        bridge = Ros2Bridge([AgentBridgeSpec("rov")], domain_id=ros_env, ros_args=args)
        with pytest.raises(ConfigError, match=f"ROS parameter {name}"):
            bridge.start()
        bridge.close()
    proc = subprocess.run(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out", str(tmp_path / "o"),
         "--duration", "1", "--no-raycast-sensors", "-q", "--ros-args=-p sensor_qos:=fast"],
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "sensor_qos" in lines[0]


def test_ros_syntax_after_ros_args_goes_to_ros(ros_env: int, tmp_path: Path) -> None:
    """As ``ros2 run`` takes them: every argument after a bare ``--ros-args`` up to ``--``
    goes to ROS (the remapping and the parameter reach the node: the bad parameter stops
    the start, named), and what follows ``--`` is uhrisim's again (``--duration``). A run
    in a namespace records its topics under their live names (issue 30)."""
    del ros_env
    proc = subprocess.run(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out", str(tmp_path / "o"),
         "--no-raycast-sensors", "-q", "--ros-args", "-r", "__ns:=/sim_a", "-p",
         "sensor_qos:=fast", "--", "--duration", "1"],
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "sensor_qos" in lines[0] and "fast" in lines[0], lines
    ok = subprocess.run(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out", str(tmp_path / "ns"),
         "--no-raycast-sensors", "-q", "--no-figures", "--ros-args", "-r", "__ns:=/sim_a",
         "--", "--duration", "1"], capture_output=True, text=True, timeout=300)
    assert ok.returncode == 0, ok.stderr
    # the bag's topics are the live names: under the namespace, /clock and /tf included
    import yaml

    meta = yaml.safe_load((tmp_path / "ns" / "metadata.yaml").read_text())
    topics = {t["topic_metadata"]["name"]
              for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]}
    assert {"/sim_a/clock", "/sim_a/tf", "/sim_a/videoray/odom"} <= topics
    assert all(t.startswith("/sim_a/") for t in topics), topics

    from uhrisim.cli import _gather_ros_args

    gathered = _gather_ros_args(["run", "x.yaml", "--ros-args", "-r", "__ns:=/sim_a", "-p",
                                 "note:=a b", "--", "-q"])
    assert gathered[:3] == ["run", "x.yaml", "-q"] and gathered[3].startswith("--ros-args=")
    assert shlex.split(gathered[3].partition("=")[2]) == ["-r", "__ns:=/sim_a", "-p",
                                                           "note:=a b"]


def test_a_second_simulator_of_the_same_name_is_told_and_leaves_clock_alone(
        ros_env: int, tmp_path: Path) -> None:
    """Two simulators, both ``/uhrisim`` in the root namespace on one domain (the other a
    ``uhrisim run --ros2`` process): each sees the other in the ROS graph, says so (a
    bridge event; on the other's console, a warning) and publishes no more ``/clock``,
    so nodes on ``use_sim_time`` never see two clocks interleaved."""
    console = tmp_path / "other.err"
    with console.open("w") as err:
        other = subprocess.Popen([sys.executable, "-m", "uhrisim", "run", str(SCENARIO),
                                  "--out", str(tmp_path / "other"), "--no-raycast-sensors",
                                  "-q", "--ros2"], stdout=subprocess.DEVNULL, stderr=err)
    hook = Ros2BridgeHook(domain_id=ros_env)
    sim = Simulation(load_scenario(SCENARIO), raycast_sensors=False, hooks=[hook])

    def told() -> tuple[bool, bool]:  # (this one, the other one)
        return (any("another node named 'uhrisim'" in e.detail for e in sim.events_log),
                "another node named 'uhrisim'" in console.read_text())

    try:
        sim.start()
        pacer = Pacer(real_time_factor=1.0)
        pacer.reset(sim.t)
        deadline = time.monotonic() + 300.0  # the other's start and discovery
        while not all(told()):
            assert time.monotonic() < deadline and other.poll() is None, told()
            pacer.wait(sim.step().t)
        assert hook.bridge is not None and not hook.bridge.publishes_clock
    finally:
        sim.close()
        other.send_signal(2)  # SIGINT
        try:
            other.wait(timeout=120.0)
        finally:
            if other.poll() is None:
                other.kill()
    assert other.returncode == 130
    assert "publishes no /clock" in console.read_text()
