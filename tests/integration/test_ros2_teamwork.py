"""The teamwork world live on ROS 2 (issue 25), received by a separate plain-rclpy process
(tests/support/ros2_team_listener.py) from the bridge on scenarios/salvage_team.yaml's
first 8.5 simulated seconds (the diver grasps the wrench at 7.5 s; the VideoRay carries the
light in its gripper from the start):

* every tool and load is a frame on /tf, ``map -> <object>``, at the simulation's pose of
  that tick (ENU): the light moves with the VideoRay that carries it, the wrench leaves
  the basket in the diver's hand;
* the articulated diver's joints arrive on ``/diver1/joint_states`` with the simulation's
  names and angles;
* the grasp and the finished order arrive on /events as they happen;
* the bridge advertises no helm topics for agents without a helm of their own (here: an
  order-driven diver and a scripted VideoRay), and takes no commands for a diver that is
  not driven from outside (ground truth only), but does for the VideoRay (issue 30).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")
pytest.importorskip("tf2_msgs", reason="uhrisim ros2-interfaces")
pytest.importorskip("uhrisim_msgs", reason="uhrisim ros2-interfaces")

from tests.support.children import Child, run_paced_for
from uhrisim.bridges.ros2.hook import Ros2BridgeHook
from uhrisim.ros.convert import pose_enu_from_ned
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "salvage_team.yaml"
NODE = "uhrisim_team_test"


def _key(t: float) -> str:
    sec, ns = divmod(round(t * 1e9), 1_000_000_000)
    return f"{sec}.{ns:09d}"


def test_objects_joints_and_team_events_live(ros_env: int, tmp_path: Path) -> None:
    hook = Ros2BridgeHook(domain_id=ros_env, node_name=NODE, publish_scene=False)
    sim = Simulation(load_scenario(SCENARIO), hooks=[hook], seed=1)
    listener = Child("ros2_team_listener.py", ["--diver", "diver1", "--node", NODE], tmp_path)
    poses: dict[str, dict[str, tuple]] = {}  # stamp -> object -> (xyz, q) in ENU
    joints: dict[str, tuple] = {}

    def keep(frame) -> None:
        poses[_key(frame.t)] = {name: pose_enu_from_ned(th.pose[:3, 3], th.pose[:3, :3])
                                for name, th in sim.team.workspace.things.items()}
        joints[_key(frame.t)] = frame.joints["diver1"]

    result = run_paced_for(sim, listener, ["/tf", "/diver1/joint_states", "/events"],
                           8.5, 6.0, keep)

    # every object a frame on /tf at the simulation's pose of that tick
    objects = set(poses[next(iter(poses))])
    assert objects == {"bag1", "basket1", "light1", "valve1", "wrench1"}
    seen: dict[str, list] = {name: [] for name in objects}
    for stamp, rows in result["tf"].items():
        for parent, child, xyz, q in rows:
            if child in objects:
                assert parent == "map"
                want_xyz, want_q = poses[stamp][child]
                np.testing.assert_allclose(xyz, want_xyz, atol=1e-12)
                np.testing.assert_allclose(q, want_q, atol=1e-12)
                seen[child].append((float(stamp), np.asarray(xyz)))
    assert all(len(track) >= 60 for track in seen.values()), {k: len(v) for k, v in seen.items()}
    light = np.array([xyz for _, xyz in seen["light1"]])
    assert light[-1][1] - light[0][1] > 0.5  # north (ENU y): carried by the VideoRay
    team_events = [e for e in sim.events_log if e.kind in ("teamwork", "order")]
    grasped = next(e.t for e in team_events if "grasp wrench1" in e.detail)
    picked = next(e.t for e in team_events if e.kind == "order" and "pick up wrench1" in e.detail)
    wrench = {t: xyz for t, xyz in seen["wrench1"]}
    before = [xyz for t, xyz in wrench.items() if t < grasped]
    after = [xyz for t, xyz in wrench.items() if t > picked]
    assert before and after, (grasped, picked)
    assert np.ptp(np.array(before), axis=0).max() < 1e-9  # resting in the basket
    assert np.linalg.norm(after[-1] - before[-1]) > 0.05  # in the diver's hand

    # the diver's joints, as the simulation has them
    assert len(result["joints"]) >= 60
    for stamp, (names, position) in result["joints"].items():
        assert names == list(joints[stamp].names)
        np.testing.assert_allclose(position, joints[stamp].position, atol=0)

    # teamwork and order events as they happen
    live = {tuple(e) for e in result["events"]}
    said = {(e.kind, e.detail) for e in team_events if e.t <= picked}  # as the sim said
    assert said <= live, live
    assert any(kind == "order" and "done" in detail and "pick up wrench1" in detail
               for kind, detail in live), live

    # no helm topics for agents without a helm; the diver takes no commands
    published, subscribed = result["published"], result["subscribed"]
    assert "/diver1/joint_states" in published and "/rov1/joint_states" not in published
    assert not [t for t in published if "/helm/" in t], published
    assert not [t for t in subscribed if t.startswith("/diver1/")], subscribed
    assert {"/rov1/cmd/desired_speed", "/rov1/cmd/thrusters"} <= set(subscribed)
