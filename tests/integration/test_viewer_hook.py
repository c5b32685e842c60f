"""ViewerHook: pacing, pause / step / resume, buttons — with a fake clock, then with the
real simulation and a websocket client playing the page.

Pacing is checked on a fake clock (no wall-clock asserts): with instantaneous ticks the
hook must sleep exactly (t_last − t_first) / speed in total; a run slower than the
requested speed must not sleep at all and reports its real-time factor.
"""

from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from uhrisim.viz.viewer import Command, ViewerHook

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"


@dataclass
class _Tick:
    t: float
    agents: dict = field(default_factory=dict)
    pings: dict = field(default_factory=dict)
    posts: tuple = ()


class _FakeServer:
    max_fps = 20.0
    url = "http://127.0.0.1:1/"

    def __init__(self, script: dict[int, list[Command]] | None = None) -> None:
        self.script = script or {}
        self.calls = 0
        self.frames: list[dict] = []

    def drain_commands(self) -> list[Command]:
        self.calls += 1
        return self.script.get(self.calls, [])

    def publish(self, frame: dict) -> None:
        self.frames.append(frame)


class _Clock:
    def __init__(self) -> None:
        self.now = 1000.0
        self.sleeps: list[float] = []

    def __call__(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.sleeps.append(s)
        self.now += s


class _FakeSim:
    def __init__(self) -> None:
        self.posts: list[tuple] = []

    def post(self, agent, var, value, source="external"):
        self.posts.append((agent, var, value, source))


@pytest.mark.parametrize("speed", [0.5, 1.0, 4.0])
def test_pacing_sleeps_sim_time_over_speed(speed):
    clock = _Clock()
    hook = ViewerHook(_FakeServer(), speed=speed, clock=clock, sleep=clock.sleep)
    hook.on_start(_FakeSim())
    dt = 1.0 / 60.0
    for k in range(600):
        hook.on_tick(_Tick(k * dt))
    assert sum(clock.sleeps) == pytest.approx(599 * dt / speed, abs=1e-9)
    assert hook.rtf == pytest.approx(speed, rel=1e-6)


def test_max_speed_never_sleeps_and_slow_runs_do_not_catch_up():
    clock = _Clock()
    hook = ViewerHook(_FakeServer(), speed=math.inf, clock=clock, sleep=clock.sleep)
    for k in range(100):
        hook.on_tick(_Tick(k * 0.1))
    assert clock.sleeps == []
    # a run that needs 1 s of wall time per 0.1 s tick, asked for ×1: no sleeping, RTF 0.1
    clock, hook = _Clock(), None
    hook = ViewerHook(_FakeServer(), speed=1.0, clock=clock, sleep=clock.sleep)
    for k in range(20):
        hook.on_tick(_Tick(k * 0.1))
        clock.now += 1.0
    assert clock.sleeps == []
    assert hook.rtf == pytest.approx(0.1)


def test_frames_are_published_at_most_max_fps():
    clock = _Clock()
    server = _FakeServer()
    hook = ViewerHook(server, speed=1.0, clock=clock, sleep=clock.sleep)
    for k in range(601):  # 10 s at 60 Hz, paced to real time on the fake clock
        hook.on_tick(_Tick(k / 60.0))
    # 20 frames per wall second (+1 at the start)
    assert len(server.frames) == pytest.approx(201, abs=1)


def test_pause_step_resume_and_buttons():
    P, R = Command("pause"), Command("resume")
    server = _FakeServer({
        2: [P],                                               # tick 1: pause → hold
        4: [Command("step", value=2.0)],                      # (holding) let 2 ticks through
        7: [Command("post", "videoray", "DEPLOY", "true")],   # (holding after tick 3)
        8: [R],
    })
    clock = _Clock()
    sim = _FakeSim()
    hook = ViewerHook(server, speed=math.inf, clock=clock, sleep=clock.sleep, idle_hz=20)
    hook.on_start(sim)
    calls_after: list[int] = []
    for k in range(5):
        hook.on_tick(_Tick(0.1 * k))
        calls_after.append(server.calls)
    # tick 0 → call 1; tick 1 holds through calls 2-4; ticks 2, 3 step; tick 3 holds 6-8
    assert calls_after == [1, 4, 5, 8, 9]
    assert sim.posts == [("videoray", "DEPLOY", "true", "viewer")]
    held = [f for f in server.frames if f["paused"]]
    assert {f["t"] for f in held} == {0.1, 0.30000000000000004}
    assert clock.sleeps == [0.05] * 4  # the idle re-publish period only, no pacing
    assert not hook.paused


def test_released_hook_does_not_hold_a_paused_run():
    server = _FakeServer({1: [Command("pause")]})
    clock = _Clock()
    hook = ViewerHook(server, clock=clock, sleep=clock.sleep, speed=math.inf)
    hook.release()
    hook.on_tick(_Tick(0.0))  # would block forever if release() were ignored
    assert hook.paused and clock.sleeps == []


def test_real_simulation_pauses_steps_and_takes_buttons():
    pytest.importorskip("websockets")
    from websockets.sync.client import connect

    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim import simulation as sim_mod
    from uhrisim.viz.viewer import attach_viewer

    source = load_scenario(SCENARIO)
    sim = sim_mod.Simulation(source, raycast_sensors=False)
    server, hook = attach_viewer(sim, port=0, speed=math.inf)
    assert sim.hooks[-1] is hook
    stop = threading.Event()
    th = threading.Thread(target=lambda: sim.run(600.0, should_stop=stop.is_set), daemon=True)
    try:
        with connect(server.url.replace("http://", "ws://") + "ws") as ws:
            hello = json.loads(ws.recv(timeout=5))
            # the scenario's four buttons and its sea floor come with the page
            assert [b["label"] for b in hello["buttons"]] == ["DEPLOY", "RETURN", "TRAIL",
                                                              "LOITER"]
            assert len(hello["scene"]["seafloor"]["faces"]) > 1000
            th.start()

            def send(**kw):
                ws.send(json.dumps({"type": "command", **kw}))

            def frame_where(pred, timeout=20.0):
                deadline = time.monotonic() + timeout
                while time.monotonic() < deadline:
                    m = json.loads(ws.recv(timeout=timeout))
                    if m["type"] == "frame" and pred(m):
                        return m
                raise AssertionError("no such frame")

            first = frame_where(lambda m: m["t"] > 0.5)
            # both contact-manager alerts of the scenario (60 m) as circles on the ROV
            assert first["overlays"]["circles"] == [
                {"agent": "videoray", "label": "TRAIL_INFO 60 m", "radius": 60.0},
            ]
            assert {a["name"]: a["kind"] for a in first["agents"]} == {
                "diver": "diver", "videoray": "rov"}
            send(kind="pause")
            paused = frame_where(lambda m: m["paused"])
            tick = sim.tick
            assert paused["t"] == pytest.approx(tick * sim.dt)
            time.sleep(0.3)
            assert sim.tick == tick, "simulation advanced while paused"
            send(kind="step", value=1)
            frame_where(lambda m: m["paused"] and m["t"] > paused["t"] + 1e-9)
            assert sim.tick == tick + 1  # exactly one physics step
            send(kind="post", agent="videoray", name="VIEWER_NOTE", value="hello")
            send(kind="resume")
            frame_where(lambda m: not m["paused"] and m["t"] > paused["t"] + 0.5)
            assert sim.agents["videoray"].community.get("VIEWER_NOTE") == "hello"
    finally:
        stop.set()
        hook.release()
        th.join(20)
        server.close()
    assert not th.is_alive()
