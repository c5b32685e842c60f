"""Scenario files, the loop's rules (whole-tick rates, events, collisions), and crashes."""

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from uhrisim.core.errors import AssetError, ConfigError
from uhrisim.record.reader import summarize
from uhrisim.scenario.load import load_scenario, validate_data
from uhrisim.sim.overlap import CLEARANCE_M, push_out, sphere_overlaps
from uhrisim.sim.simulation import BaseHook, Simulation

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))


def write(tmp_path: Path, text: str, name: str = "s.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_every_shipped_scenario_validates_and_runs_without_warnings_or_nan(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = Simulation(load_scenario(path))
        for _ in range(round(3.0 / sim.dt)):
            frame = sim.step()
    for snap in frame.agents.values():
        assert np.all(np.isfinite(snap.nav.position_ned)) and np.isfinite(snap.nav.yaw)


def test_typo_names_the_key_and_line(tmp_path):
    path = write(tmp_path, "name: x\nagents:\n  - name: rov\n    model: videoray\n"
                 "    driver: none\n    strat: {north: 1}\n")
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    message = str(info.value)
    assert f"{path}:6" in message and "'strat'" in message and "did you mean 'start'" in message


def test_out_of_range_value_names_the_field_path_and_line(tmp_path):
    path = write(tmp_path, "name: x\nagents:\n  - name: rov\n    model: videoray\n"
                 "    driver: none\n    sensors:\n      - {preset: P900-45, range_max_m: -3}\n")
    with pytest.raises(ConfigError, match=r"s\.yaml:7: agents\[0\]\.sensors\[0\]\.range_max_m"):
        load_scenario(path)


def test_nan_is_refused_at_load_with_its_field(tmp_path):
    path = write(tmp_path, "name: x\nagents:\n  - {name: rov, model: videoray, driver: none,\n"
                 "     start: {north: .nan}}\n")
    with pytest.raises(ConfigError, match=r"s\.yaml:4: agents\[0\]\.start\.north: .*finite"):
        load_scenario(path)


@pytest.mark.parametrize("content, problem", [(None, "mesh file not found"),
                                              (b"garbage\x00\x01", "no triangles")])
def test_missing_or_corrupt_mesh_names_the_scenario_line_and_the_file(tmp_path, content,
                                                                       problem):
    if content is not None:
        (tmp_path / "wreck.stl").write_bytes(content)
    path = write(tmp_path, "name: x\nworld:\n  objects:\n"
                 "    - {type: mesh, file: wreck.stl, label: wreck}\n"
                 "agents: [{name: rov, model: videoray, driver: none}]\n")
    with pytest.raises(AssetError, match=rf"s\.yaml:4: .*wreck\.stl.*{problem}"):
        Simulation(load_scenario(path))


def test_cli_reports_bad_input_in_one_line(tmp_path):
    path = write(tmp_path, "name: x\nagents:\n  - {name: rov, model: videoray, drivr: none}\n")
    result = subprocess.run([sys.executable, "-m", "uhrisim", "validate", str(path)],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "did you mean 'driver'" in lines[0], result.stderr
    assert "Traceback" not in result.stderr


def test_controller_inputs_must_be_finite_numbers_wherever_they_are_posted(tmp_path):
    sim = Simulation(load_scenario(write(tmp_path, COLLIDE)))
    with pytest.raises(ConfigError, match="rov: DESIRED_SPEED must be a finite number"):
        sim.post("rov", "DESIRED_SPEED", "fast")
    sim.post("rov", "DESIRED_SPEED", "0.5")  # a numeric string is a number
    sim.run(0.1)
    assert sim.agents["rov"].community.get("DESIRED_SPEED") == 0.5
    bad_event = COLLIDE + "events: [{at: 1, post: {agent: rov, var: DESIRED_DEPTH, value: deep}}]\n"
    with pytest.raises(ConfigError, match=r"events\[0\]\.post.*DESIRED_DEPTH must be a finite"):
        load_scenario(write(tmp_path, bad_event, "bad.yaml"))


def test_unknown_agent_reference_gets_a_did_you_mean():
    data = {"name": "x", "agents": [{"name": "videoray", "model": "videoray", "driver": "none"}],
            "buttons": [{"label": "GO", "agent": "videoray1", "var": "DEPLOY", "value": "true"}]}
    with pytest.raises(ConfigError, match="did you mean 'videoray'"):
        validate_data(data, "inline")


def test_rates_must_be_whole_numbers_of_physics_steps(tmp_path):
    path = write(tmp_path, """
name: x
physics_rate_hz: 50
agents:
  - name: diver
    model: diver
    helm:
      rate_hz: 3
      behaviors: [{type: ConstantDepth, name: d, depth: 2, duration: no-time-limit}]
""")
    with pytest.raises(ConfigError, match=r"3 Hz is not a whole number of physics steps"):
        Simulation(load_scenario(path))


SCRIPTED = """
name: scripted
physics_rate_hz: 60
world: {seafloor: {type: flat, depth: 10}}
agents:
  - name: diver
    model: diver
    driver: script
    start: {north: 0, east: 0, depth: 2, heading_deg: 0}
    script:
      - {t: 0, heading_deg: 90, speed: 0.5, depth: 2}
      - {t: 20, goto: {north: 0, east: 0, depth: 3}, speed: 0.6}
  - name: rov
    model: videoray
    driver: none
    start: {north: -5, east: 0, depth: 1, heading_deg: 0}
events:
  - {at: 5, post: {agent: rov, var: DEPLOY, value: "true"}}
  - {when: "DEPLOY = true", agent: rov, post: {agent: rov, var: SEEN_DEPLOY, value: 1}}
  - {at: 60, agent: diver, script: [{t: 60, heading_deg: 180, speed: 0.4}]}
"""


def test_scripted_diver_and_events(tmp_path):
    sim = Simulation(load_scenario(write(tmp_path, SCRIPTED)))
    sim.run(19.0)
    nav = sim.agents["diver"].nav()
    assert np.degrees(nav.yaw) % 360 == pytest.approx(90.0, abs=1.0)  # first leg: east
    assert nav.position_ned[1] > 7.0
    assert sim.agents["rov"].community.get("DEPLOY") == "true"
    assert sim.agents["rov"].community.get("SEEN_DEPLOY") == 1.0  # the 'when' event fired
    sim.run(40.0)  # second leg: back to the origin at 3 m
    nav = sim.agents["diver"].nav()
    assert np.hypot(*nav.position_ned[:2]) < 1.0
    assert nav.position_ned[2] == pytest.approx(3.0, abs=0.05)
    sim.run(10.0)  # the event at 60 s changed the plan: heading south
    assert np.degrees(sim.agents["diver"].nav().yaw) % 360 == pytest.approx(180.0, abs=2.0)
    kinds = [e.kind for e in sim.events_log]
    assert kinds.count("event") == 3


COLLIDE = """
name: collide
physics_rate_hz: 60
world:
  seafloor: {type: flat, depth: 10}
  objects:
    - {type: cylinder, label: piling, radius: 0.3, height: 12,
       position: {north: 8, east: 0, depth: 5}}
agents:
  - name: rov
    model: videoray
    driver: external
    start: {north: 0, east: 0, depth: 3, heading_deg: 0}
"""


def test_vehicles_never_pass_through_the_scene(tmp_path):
    sim = Simulation(load_scenario(write(tmp_path, COLLIDE)))
    for _ in range(round(30.0 / sim.dt)):  # full ahead into the piling for 30 s
        sim.set_actuators("rov", [150.0, 150.0, 0.0])
        sim.step()
    north = sim.agents["rov"].nav().position_ned[0]
    # Piling surface at 8 - 0.3 m; the ROV's collision sphere has radius 0.25 m.
    assert north < 8.0 - 0.3 - 0.25 + 0.05
    assert north > 6.5  # it did get there
    # Pushing against the piling for many seconds is one contact, counted and logged once.
    assert sim.collisions == 1
    assert [e.kind for e in sim.events_log].count("collision") == 1


def test_events_add_and_move_objects_that_vehicles_then_meet(tmp_path):
    gate = ("    - {type: box, label: gate, movable: true, size: [0.5, 4, 4],\n"
            "       position: {north: 30, east: 0, depth: 3}}\n")
    text = COLLIDE.replace("  objects:\n", "  objects:\n" + gate) + """
events:
  - {at: 1, move_object: {label: gate, position: {north: 4, east: 0, depth: 3}}}
  - {at: 2, add_object: {type: sphere, label: buoy, radius: 0.5,
                         position: {north: 0, east: 5, depth: 3}}}
"""
    sim = Simulation(load_scenario(write(tmp_path, text)))
    for _ in range(round(20.0 / sim.dt)):
        sim.set_actuators("rov", [150.0, 150.0, 0.0])
        sim.step()
    north = sim.agents["rov"].nav().position_ned[0]
    assert north < 4.0 - 0.25 - 0.25 + 0.05  # stopped by the moved gate (half-width 0.25 m)
    assert "buoy" in sim.scene.labels
    assert [e.detail for e in sim.events_log if e.kind == "event"] == [
        "moved 'gate' to [4.0, 0.0, 3.0]", "added object 'buoy'"]


def test_an_object_an_event_drops_onto_a_still_vehicle_is_a_collision(tmp_path):
    """The vehicle does not move into the object, so only the event can see it: counted
    once, logged with the object and the place; an object put beside it is not."""
    gate = ("    - {type: box, label: gate, movable: true, size: [0.5, 4, 4],\n"
            "       position: {north: 30, east: 0, depth: 3}}\n")
    text = COLLIDE.replace("  objects:\n", "  objects:\n" + gate) + """
events:
  - {at: 1, add_object: {type: box, label: crate, size: [1, 1, 1],
                         position: {north: 0, east: 3, depth: 3}}}
  - {at: 2, add_object: {type: box, label: skip, size: [1, 1, 1],
                         position: {north: 0.3, east: 0, depth: 2.9}}}
  - {at: 3, move_object: {label: gate, position: {north: 0, east: 0, depth: 3}}}
"""
    sim = Simulation(load_scenario(write(tmp_path, text)))
    sim.run(1.5)
    assert sim.collisions == 0  # the crate landed 3 m away
    sim.run(1.0)
    assert sim.collisions == 1
    sim.run(1.0)
    assert sim.collisions == 2
    hits = [e.detail for e in sim.events_log if e.kind == "collision"]
    assert hits[0].startswith("rov touched 'skip', which an event added onto it at NED [0.0")
    assert hits[1].startswith("rov touched 'gate', which an event moved onto it at NED")


def test_a_vehicle_an_event_buries_is_pushed_out_the_shortest_way(tmp_path):
    """A crate dropped 0.3 m ahead of the ROV's centre shoves it back, out of the crate by
    its radius (the crate's near face is at north -0.2 m), at rest; nothing else moves it
    and it is not counted again."""
    text = COLLIDE + """
events:
  - {at: 1, add_object: {type: box, label: skip, size: [1, 1, 1],
                         position: {north: 0.3, east: 0, depth: 3}}}
"""
    sim = Simulation(load_scenario(write(tmp_path, text)))
    rov = sim.agents["rov"]
    sim.run(0.9)
    before = rov.state[:3].copy()
    sim.run(0.2)
    after = rov.state[:3]
    assert after[0] == pytest.approx(-0.2 - rov.radius - CLEARANCE_M, abs=1e-3)
    assert after[1:] == pytest.approx(before[1:], abs=1e-2)
    skip = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    skip.apply_translation([0.3, 0.0, 3.0])
    assert not sphere_overlaps(skip, after, rov.radius)
    sim.run(2.0)
    assert sim.collisions == 1


def test_push_out_takes_the_shortest_way_from_inside_and_from_outside():
    box = trimesh.creation.box(extents=[2.0, 2.0, 2.0])  # faces at ±1 m
    inside = push_out(box, np.array([0.7, 0.1, 0.0]), 0.5)
    assert inside == pytest.approx([1.0 + 0.5 + CLEARANCE_M, 0.1, 0.0])
    grazing = push_out(box, np.array([0.0, -1.2, 0.3]), 0.5)  # centre outside, sphere in
    assert grazing == pytest.approx([0.0, -1.0 - 0.5 - CLEARANCE_M, 0.3])
    for centre in (inside, grazing):
        assert not sphere_overlaps(box, centre, 0.5)


def test_stale_external_thrusters_fall_back_to_the_controller(tmp_path):
    sim = Simulation(load_scenario(write(tmp_path, COLLIDE)))
    sim.set_actuators("rov", [100.0, 100.0, 0.0], hold_s=1.0)
    sim.run(0.5)
    assert sim.agents["rov"].inputs[0] == 100.0
    sim.run(1.0)
    assert sim.agents["rov"].inputs[0] != 100.0
    assert any("stale" in e.detail for e in sim.events_log)


def test_a_hook_only_observes_its_commands_wait_for_the_next_tick(tmp_path):
    """Outside inputs — a variable posted, thruster commands — given by a hook during a
    tick go into the one inbox and take effect at the start of the next tick, in order;
    the tick the hook observes is left as the loop made it."""

    class Commander(BaseHook):
        def __init__(self) -> None:
            self.seen: list[tuple[int, float, object]] = []

        def on_start(self, sim) -> None:
            self.sim = sim

        def on_tick(self, frame) -> None:
            rov = self.sim.agents["rov"]
            self.seen.append((frame.tick, float(rov.inputs[0]),
                              rov.community.get("DEPLOY", None)))
            if frame.tick == 3:
                self.sim.set_actuators("rov", [120.0, 120.0, 0.0], hold_s=1.0)
                self.sim.post("rov", "DEPLOY", "true", source="test")
                assert float(rov.inputs[0]) != 120.0  # nothing changed within the tick
                assert rov.community.get("DEPLOY", None) is None

    hook = Commander()
    sim = Simulation(load_scenario(write(tmp_path, COLLIDE)), hooks=[hook])
    for _ in range(5):
        sim.step()
    by_tick = {tick: (thrust, deploy) for tick, thrust, deploy in hook.seen}
    assert by_tick[3][0] != 120.0 and by_tick[3][1] is None
    assert by_tick[4] == (120.0, "true")  # applied at the start of tick 4


def test_contacts_from_truth_with_noise_latency_and_dropout_are_deterministic(tmp_path):
    text = (ROOT / "scenarios" / "track_and_trail.yaml").read_text().replace(
        "      rate_hz: 4\n      alerts:",
        "      rate_hz: 4\n      position_noise_std: 0.5\n      latency: 1.0\n"
        "      dropout: 0.2\n      alerts:")
    path = write(tmp_path, text)
    (tmp_path / "videoray_trail.bhv").write_text(
        (ROOT / "scenarios" / "videoray_trail.bhv").read_text())
    reports = []
    for _ in range(2):
        sim = Simulation(load_scenario(path), raycast_sensors=False)
        box = sim.agents["videoray"].community.mailbox()
        got = []
        for _ in range(round(20.0 / sim.dt)):
            sim.step()
            got += box.drain().get("NODE_REPORT", [])
        reports.append(got)
    assert reports[0] == reports[1]
    # 4 Hz for ~19 s with 20 % dropout: clearly fewer than 80, clearly more than 40.
    assert 45 < len(reports[0]) < 75
    times = np.array([float(r.split("TIME=")[1].split(",")[0]) for r in reports[0]])
    np.testing.assert_allclose(times % 0.25, 0.0, atol=1e-9)  # measured on the 4 Hz ticks
    assert times.max() <= 19.0 + 1e-9  # 1 s latency: nothing measured later reached it


def test_run_killed_with_sigkill_leaves_a_readable_recording(tmp_path):
    out = tmp_path / "killed"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "uhrisim", "run", str(ROOT / "scenarios" /
         "track_and_trail.yaml"), "--out", str(out), "--no-raycast-sensors", "-q"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=ROOT)
    recording = out / "recording.mcap"

    def odometry_chunks_on_disk() -> int:
        if not recording.exists():
            return 0
        return summarize(recording).topics.get("/videoray/odom", ("", 0))[1]

    deadline = time.monotonic() + 600  # only against a run that hangs (not a guess of
    while odometry_chunks_on_disk() <= 50:  # how soon a busy machine records 50)
        assert proc.poll() is None, "the run ended before it could be killed"
        assert time.monotonic() < deadline, "run hung: 50 odometry messages not in 600 s"
        time.sleep(0.3)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    summary = summarize(recording)
    assert summary.truncated
    odom = summary.topics["/videoray/odom"][1]
    assert odom > 50
    assert not (out / "metrics.json").exists()


def test_metrics_json_of_a_failed_run_says_so(tmp_path):
    from uhrisim.app.runner import run_scenario

    calls = []

    def stop_after_two_seconds() -> bool:
        calls.append(1)
        if len(calls) > 120:
            raise KeyboardInterrupt
        return False

    with pytest.raises(KeyboardInterrupt):
        run_scenario(ROOT / "scenarios" / "track_and_trail.yaml", tmp_path, raycast_sensors=False,
                     should_stop=stop_after_two_seconds)
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["completed"] is False
    assert metrics["simulated_s"] == pytest.approx(2.0)
    assert summarize(tmp_path / "recording.mcap").topics["/videoray/odom"][1] == 20
