"""McapRecordingHook: TickFrame-shaped input → the recorded topics and values.

The frames here are stand-ins with the documented fields of ``uhrisim.sim.hooks``
(TickFrame, AgentSnapshot, HelmRecord, SimEvent, community Post, sonar SonarPing), so
this test does not depend on the simulation loop; expected values are set by hand.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace as Ns

import numpy as np
import pytest
import trimesh

from uhrisim.core.errors import ConfigError
from uhrisim.record import McapRecordingHook, iter_messages, read_odometry, summarize
from uhrisim.ros.topics import ros_name


def nav(north: float, east: float, depth: float, yaw: float) -> Ns:
    return Ns(position_ned=np.array([north, east, depth]), yaw=yaw,
              velocity_body=np.array([0.5, 0.0, 0.0]), yaw_rate=0.0)


def fake_sim() -> Ns:
    box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))  # 12 triangles, centred at 0
    box.apply_translation((10.0, 0.0, 5.0))
    objects = (Ns(mesh=box, label="piling_1", label_id=3, material=Ns(name="concrete")),)
    return Ns(seed=42, dt=0.05, t=0.0, scene=Ns(static_objects=objects),
              scenario=Ns(name="trail"))


def cloud() -> Ns:
    x = np.array([[5.0, np.nan], [6.0, 7.0]], dtype=np.float32)
    return Ns(x=x, y=np.zeros_like(x), z=np.ones_like(x),
              intensity=np.array([[0.5, 0.0], [0.25, 1.0]], dtype=np.float32))


def frame(tick: int, dt: float = 0.05, ping: bool = False) -> Ns:
    t = tick * dt
    agents = {"rov": Ns(nav=nav(0.1 * tick, 0.0, 2.0, 0.0)),
              "diver-1": Ns(nav=nav(5.0, 0.02 * tick, 3.0, math.pi / 2))}
    pings = {}
    if ping:
        pings["rov/sonar"] = Ns(t=t, polar_u8=np.zeros((16, 8), np.uint8),
                                fan_u8=np.full((10, 12), 9, np.uint8), cloud=cloud(),
                                hit_points_sonar=np.zeros((0, 3)),
                                position_ned=np.array([0.1 * tick, 0.0, 2.0]),
                                rotation_ned_from_sonar=np.eye(3),
                                beam_angles_rad=np.linspace(-0.4, 0.4, 8),
                                bin_ranges_m=np.linspace(0.1, 1.6, 16),
                                info=Ns(frequency_hz=9e5, sound_speed_m_s=1500.0))
    helm = {"rov": Ns(heading_deg=90.0, speed=0.5, depth=None,
                      contributions={"trail": 70.0}, total=70.0, mode="TRAIL",
                      active=("trail",), all_stop_reason=None)}
    posts = (Ns(community="rov", var="DEPLOY", value="true", t=t, source="script"),)
    events = (Ns(t=t, kind="collision", detail="rov/piling_1"),) if tick == 3 else ()
    return Ns(tick=tick, t=t, agents=agents, pings=pings, helm=helm, posts=posts,
              events=events)


def test_hook_records_a_run(tmp_path: Path) -> None:
    path = tmp_path / "hook.mcap"
    hook = McapRecordingHook(path, odom_every=2)
    sim = fake_sim()
    hook.on_start(sim)
    for k in range(10):
        hook.on_tick(frame(k, ping=(k % 5 == 0)))
    hook.on_end(sim, None)
    s = summarize(path)
    assert not s.truncated
    counts = {k: v[1] for k, v in s.topics.items()}
    assert counts["/rov/odom"] == counts["/diver_1/odom"] == 5  # ticks 0, 2, 4, 6, 8
    assert counts["/rov/sonar/fan"] == counts["/rov/sonar/points"] == 2
    assert counts["/rov/sonar/image"] == 2  # frequency and sound speed from the ping
    assert counts["/rov/helm/decision"] == counts["/rov/vars"] == 10
    assert counts["/events"] == 1 and counts["/scene/markers"] == 1
    tracks = read_odometry(path)
    np.testing.assert_allclose(tracks["rov"].x_north, [0.0, 0.2, 0.4, 0.6, 0.8])
    np.testing.assert_allclose(tracks["diver_1"].yaw, math.pi / 2)
    msgs = {m.topic: m.message for m in iter_messages(path)}
    pts = np.frombuffer(msgs["/rov/sonar/points"].data, "<f4").reshape(-1, 4)
    # the NaN ray is dropped; FRD (x, 0, 1) → FLU (x, 0, -1)
    np.testing.assert_allclose(pts, [[5, 0, -1, 0.5], [6, 0, -1, 0.25], [7, 0, -1, 1.0]])
    (marker,) = msgs["/scene/markers"].markers
    assert (marker.type, marker.id, marker.text, len(marker.points)) == (11, 3, "piling_1", 36)
    assert hook.summary()["messages"] == sum(counts.values())


def test_hook_marks_a_failed_run(tmp_path: Path) -> None:
    path = tmp_path / "fail.mcap"
    hook = McapRecordingHook(path, record_scene=False)
    sim = fake_sim()
    hook.on_start(sim)
    hook.on_tick(frame(0))
    sim.t = 0.05
    hook.on_end(sim, RuntimeError("diverged"))
    ev = [m.message for m in iter_messages(path, ["/events"])]
    assert [(e.kind, e.detail) for e in ev] == [("error", "RuntimeError: diverged")]


def test_ros_name_and_bad_options(tmp_path: Path) -> None:
    assert ros_name("rov") == "rov"
    assert ros_name("diver-1") == "diver_1"
    assert ros_name("2rov") == "a_2rov"
    with pytest.raises(ConfigError, match="odom_every"):
        McapRecordingHook(tmp_path / "x.mcap", odom_every=0)
