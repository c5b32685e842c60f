"""The shipped team missions end to end (docs/teamwork.md): a diver on weighted boots and a
scuba diver carry out their salvage orders with the VideoRay; metrics, the recording read
back with an independent reader (rosbags), the team timeline drawn from it, the same
seed giving the same run, and ``uhrisim validate`` refusing orders that cannot be done."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tests.support.cli import one_line_error
from uhrisim.app.runner import run_scenario
from uhrisim.cli import app
from uhrisim.record import read_odometry
from uhrisim.viz.team_figures import make_team_timeline, read_order_steps

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
BOOTS = SCENARIOS / "salvage_team_boots.yaml"
SCUBA = SCENARIOS / "salvage_team.yaml"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def boots(tmp_path_factory):
    # the orders take 237 s of the 420 the scenario allows
    return run_scenario(BOOTS, tmp_path_factory.mktemp("boots"), duration=238.0,
                        raycast_sensors=False)


def test_the_boots_diver_finishes_every_order_with_the_rov(boots):
    m = boots.metrics
    team = m["team"]
    diver = team["divers"]["diver1"]
    assert m["collisions"] == 0
    assert diver["orders"] == diver["orders_done"] == 18 and not diver["failed"]
    assert 150.0 < diver["completed_s"] < 238.0
    assert all(s["outcome"] == "done" for s in diver["steps"])
    starts = [s["start_s"] for s in diver["steps"]]
    assert starts == sorted(starts)
    # three grasps (wrench, bag, light), the light handed over by the VideoRay's gripper,
    # which held it from the start until then
    assert team["grasps"] == {"attempts": 3, "successes": 3}
    assert team["handovers"]["successes"] == 1 and team["drops"] == 0
    handed = next(s for s in diver["steps"] if s["order"] == "pick up light1")["end_s"]
    assert team["hold_s"]["rov1/gripper"] == pytest.approx(handed, abs=1.0)
    assert team["min_separation_m"] > 0.85  # the two collision spheres never touched
    silt = team["silt"]
    # 21 g per footfall (docs/teamwork.md)
    assert silt["footfalls"] > 10
    assert silt["released_kg"] == pytest.approx(0.0208 * silt["footfalls"], rel=1e-3)


def test_the_recording_holds_the_team_events_and_reads_back_independently(boots):
    from rosbags.highlevel import AnyReader

    events = []
    with AnyReader([boots.out_dir / "recording.mcap"]) as reader:
        connections = [c for c in reader.connections if c.topic == "/events"]
        for connection, _, raw in reader.messages(connections=connections):
            msg = reader.deserialize(raw, connection.msgtype)
            events.append((msg.kind, msg.detail))
    orders = [d for k, d in events if k == "order"]
    assert len(orders) == 18 and all(" done " in d for d in orders)
    team = [d for k, d in events if k == "teamwork"]
    for expected in ("bolt_loosened flange1", "cover_removed flange1", "bag_attached bag1",
                     "lifted_off valve1", "handover light1", "place light1"):
        assert any(expected in d for d in team), expected
    assert sum("bolt_removed flange1" in d for d in team) == 4
    # the diver walked on the floor: its hips stay at a standing height over the 12 m floor
    diver = read_odometry(boots.out_dir / "recording.mcap")["diver1"]
    assert np.all(np.abs(diver.depth - 11.07) < 0.2)


def test_the_timeline_figure_draws_the_recorded_steps(boots, tmp_path):
    steps = read_order_steps(boots.out_dir / "recording.mcap")
    metric_steps = boots.metrics["team"]["divers"]["diver1"]["steps"]
    assert [s["order"] for s in steps] == [s["order"] for s in metric_steps]
    np.testing.assert_allclose([s["start"] for s in steps],
                               [s["start_s"] for s in metric_steps], atol=1e-3)
    np.testing.assert_allclose([s["end"] for s in steps],
                               [s["end_s"] for s in metric_steps], atol=1e-3)
    (path,) = make_team_timeline(tmp_path, boots.out_dir)
    assert path.stat().st_size > 10_000


def test_the_scuba_diver_finishes_every_order_and_takes_the_light(tmp_path):
    result = run_scenario(SCUBA, tmp_path, duration=239.0, raycast_sensors=False)
    team = result.metrics["team"]
    diver = team["divers"]["diver1"]
    assert result.metrics["collisions"] == 0
    assert diver["orders"] == diver["orders_done"] == 18 and diver["completed_s"] < 239.0
    saved = json.loads((tmp_path / "metrics.json").read_text())
    assert saved["team"]["divers"]["diver1"]["orders_done"] == 18
    # the swimmer takes the light from the VideoRay's gripper, whose jaws and body it
    # reaches from a shoulder's standoff, never touching the vehicle
    assert team["handovers"]["successes"] == 1 and team["drops"] == 0
    handed = next(s for s in diver["steps"] if s["order"] == "pick up light1")["end_s"]
    assert team["hold_s"]["rov1/gripper"] == pytest.approx(handed, abs=1.0)
    assert team["min_separation_m"] > 0.85


def test_the_same_seed_gives_the_same_team_run(tmp_path):
    first = run_scenario(BOOTS, tmp_path / "a", duration=30.0, raycast_sensors=False)
    second = run_scenario(BOOTS, tmp_path / "b", duration=30.0, raycast_sensors=False)
    volatile = {"real_time_factor"}
    assert {k: v for k, v in first.metrics.items() if k not in volatile} == {
        k: v for k, v in second.metrics.items() if k not in volatile}
    a = read_odometry(tmp_path / "a" / "recording.mcap")["diver1"]
    b = read_odometry(tmp_path / "b" / "recording.mcap")["diver1"]
    np.testing.assert_array_equal(a.x_north, b.x_north)


@pytest.mark.parametrize("old,new,message", [
    ("- {pick_up: wrench1}", "- {pick_up: wrench9}",
     "agents[0].orders[0]: order 1 (pick up wrench9): no object or site 'wrench9'"),
    ("at: {north: 3.0, east: 0.0, depth: 11.0}", "at: {north: 3.0, east: 0.0, depth: 9.0}",
     "order 2 (use wrench1 on flange1 for 8 s): flange1 is 3.0 m above the floor: a "
     "walking diver reaches 2.0 m"),
    ("      - {remove: flange1, part: 3}\n", "",
     "order 9 (remove flange1 cover): the cover comes off only with every bolt out; no "
     "order before takes out bolt(s) 3"),
])
def test_validate_refuses_orders_that_cannot_be_carried_out(tmp_path, old, new, message):
    text = BOOTS.read_text()
    assert old in text
    path = tmp_path / "salvage.yaml"
    path.write_text(text.replace(old, new))
    line = one_line_error(CliRunner().invoke(app, ["validate", str(path)]), message)
    assert f"{path}:" in line  # the order's file and line
    number = int(line.split(f"{path}:")[1].split(":")[0])
    assert path.read_text().splitlines()[number - 1].lstrip().startswith("- {")


def test_the_divers_joints_are_recorded_as_joint_states(boots):
    from rosbags.highlevel import AnyReader

    with AnyReader([boots.out_dir / "recording.mcap"]) as reader:
        connections = [c for c in reader.connections if c.topic == "/diver1/joint_states"]
        assert [c.msgtype for c in connections] == ["sensor_msgs/msg/JointState"]
        messages = [reader.deserialize(raw, c.msgtype)
                    for c, _, raw in reader.messages(connections=connections)]
    assert len(messages) == round(238.0 * 10)  # at the odometry rate
    first = messages[0]
    assert first.header.frame_id == "diver1/base_link" and len(first.name) == 24
    names = list(first.name)
    knee = np.array([m.position[names.index("left_knee")] for m in messages])
    # walking bends the knee, never past its dry-suit limit (108 deg)
    assert knee.max() > np.radians(10.0) and knee.max() <= np.radians(108.0) + 1e-9
    fingers = np.array([m.position[names.index("right_fingers")] for m in messages])
    assert fingers.max() > np.radians(60.0)  # the hand closed on the wrench


def _tf_points(message, points_frd: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """ENU positions of points given in the FRD axes of /tf frames (frame -> point)."""
    out = {}
    for tr in message.transforms:
        frame = str(tr.child_frame_id)
        if frame in points_frd:
            q, p = tr.transform.rotation, tr.transform.translation
            x, y, z, w = q.x, q.y, q.z, q.w
            rotation = np.array([
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
            flu = points_frd[frame] * np.array([1.0, -1.0, -1.0])  # FRD -> FLU axes
            out[frame] = rotation @ flu + np.array([p.x, p.y, p.z])
    return out


def test_the_divers_links_are_tf_frames_that_hold_the_tools(boots):
    """Every link is a /tf frame ``diver1/<link>``: while the diver carries the wrench,
    the right hand's grip point (its rest point in the hand's frame) is the wrench's
    grasp point in the wrench's frame."""
    from rosbags.highlevel import AnyReader

    from uhrisim.dynamics.diver_body import DiverSkeleton
    from uhrisim.world.tools import make_tool

    skeleton = DiverSkeleton(kind="boots")  # no fins
    points = {"diver1/right_hand": skeleton.grip_point_rest("right"),
              "wrench1": make_tool("wrench", "wrench1").grasp_offset()}
    gaps, links = [], set()
    with AnyReader([boots.out_dir / "recording.mcap"]) as reader:
        connections = [c for c in reader.connections if c.topic == "/tf"]
        for c, _, raw in reader.messages(connections=connections):
            message = reader.deserialize(raw, c.msgtype)
            links |= {str(tr.child_frame_id) for tr in message.transforms}
            seen = _tf_points(message, points)
            if len(seen) == 2:
                gaps.append(float(np.linalg.norm(seen["diver1/right_hand"] - seen["wrench1"])))
    assert {f"diver1/{link}" for link in skeleton.links} == {
        f for f in links if f.startswith("diver1/")} - {"diver1/base_link", "diver1/odom"}
    assert len(skeleton.links) == 18
    # carried for tens of seconds (10 Hz): the grasp point at the hand's grip point
    # (6 mm apart: the grip frame of the acts, uhrisim.teamwork.acts.Hand, is not exactly
    # the figure's rest grip point)
    assert sum(g < 0.01 for g in gaps) > 100


def test_the_recording_holds_the_bags_gas_for_the_replay(boots):
    from uhrisim.viz.viewer.replay import ReplayPlayer, load_replay

    class Sink:
        def publish(self, frame) -> None: ...

    player = ReplayPlayer(load_replay(boots.out_dir / "recording.mcap"), Sink())
    gas = [(t, float(d.split()[2])) for t, k, d in player.data.team_events
           if k == "team_state" and d.startswith("bag1 gas ")]
    litres = [v for _, v in gas]
    assert len(gas) > 10 and litres == sorted(litres)  # 1 L steps while it inflates
    t, value = gas[len(gas) // 2]
    bag = next(s for s in player.frame_at(t + 0.01)["team"]["sites"] if s["name"] == "bag1")
    assert bag["litres"] == pytest.approx(value) and 0.0 < value < litres[-1]
