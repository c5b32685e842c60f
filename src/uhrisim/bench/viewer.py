"""Benchmark: cost of the live web viewer to the simulation (``uhrisim bench viewer``).

Measures, with the stand-in track-and-trail frames of ``uhrisim.viz.viewer.demo`` (two
agents, overlays, plots; a 512 × 400 fan image — the recorder's fan size — every 10th
tick, i.e. a 100 Hz "sonar" on a 1 kHz loop, far above any real ping rate; the server
PNG-encodes at most ``max_sonar_fps`` = 10 of them per second):

* ``publish()`` cost per call (µs) while a client is connected and the server thread
  is busy encoding, averaged over the mix above (each sonar tick copies the 200 kB fan)
  and for frames without sonar;
* frames/s delivered to a headless client: a Python websocket client in its own
  process, and, when a system Chromium and Playwright are present (not in quick mode),
  the real page in headless Chromium (``window.uhri.framesReceived``);
* overhead on a dummy 1 kHz loop: a fixed amount of numpy work per tick (≈ 0.3 ms) run
  flat out, in alternating 1 s blocks without and with publishing (server and a client
  connected throughout; frames + sonar published every tick in the "with" blocks), so
  that load from other processes hits both alike: overhead = 1 − median rate_with /
  median rate_without; and the same loop paced at 1 kHz with the viewer, reporting the
  tick rate it achieves. ``no_server`` is the flat-out rate with no viewer at all;
* (full mode, source checkout) the real simulation, scenarios/track_and_trail.yaml run
  flat out (sonar on) without and with ``attach_viewer`` and a connected client.

Targets (issue 7): overhead ≤ 20 %; ≥ 10 frames/s delivered during a live run;
publish() ≤ 5 µs (so a 1 kHz loop spends < 0.5 % of its time in it).
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from typing import Any

import numpy as np

from uhrisim.viz.viewer.demo import demo_fan, demo_frame, demo_scene
from uhrisim.viz.viewer.server import ViewerServer

OVERHEAD_TARGET = 0.20
FPS_TARGET = 10.0
PUBLISH_TARGET_US = 5.0
FAN_SHAPE = (512, 400)


_CLIENT = r"""
import json, sys, time
from websockets.sync.client import connect
frames, sonars = [], []
with connect(sys.argv[1], max_size=None) as ws:
    print("ready", flush=True)
    try:
        while True:
            raw = ws.recv()
            now = time.monotonic()
            if raw.startswith('{"type":"frame"'):
                frames.append(now)
            elif raw.startswith('{"type":"sonar"'):
                sonars.append(now)
    except Exception:
        pass
print(json.dumps({"frames": frames, "sonars": sonars}), flush=True)
"""


class _Client:
    """A websocket client in its own process (like a browser) that timestamps messages."""

    def __init__(self, url: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _CLIENT, url.replace("http://", "ws://") + "ws"],
            stdout=subprocess.PIPE, text=True,
        )
        assert self.proc.stdout is not None
        if self.proc.stdout.readline().strip() != "ready":
            raise RuntimeError("benchmark client failed to connect")
        self.frames: list[float] = []
        self.sonars: list[float] = []

    def finish(self) -> None:
        """Call after the server closed: collect the timestamps."""
        out, _ = self.proc.communicate(timeout=10)
        data = json.loads(out.strip().splitlines()[-1])
        self.frames, self.sonars = data["frames"], data["sonars"]

    def rate(self, which: str, t0: float, t1: float) -> float:
        ts = self.frames if which == "frames" else self.sonars
        return sum(1 for t in ts if t0 <= t < t1) / (t1 - t0)


def _work(x: np.ndarray) -> np.ndarray:
    """Fixed per-tick work standing in for dynamics + sensors (a few hundred µs)."""
    for _ in range(4):
        x = np.sin(x) * 0.999 + 0.001
    return x


def _frames(n: int, fan: np.ndarray) -> list[dict[str, Any]]:
    """Pre-built frames (the simulation builds its own; we time the viewer, not demo_frame)."""
    return [demo_frame(k * 1e-3, sonar=fan if k % 10 == 0 else None) for k in range(n)]


def _interleaved(pairs: int, block_s: float, server: ViewerServer,
                 frames: list[dict[str, Any]]) -> tuple[float, float]:
    """Median tick rates (Hz) of the flat-out loop without / with publishing, in
    alternating blocks of ``block_s`` wall seconds so that load from other processes hits
    both alike. No pause between blocks: the server's work left over from a "with" block
    (one producer cycle, a few ms) lands in the next "without" block — under 1 % of it."""
    x = np.linspace(0.0, 1.0, 6_000)
    nf = len(frames)
    rates: dict[bool, list[float]] = {False: [], True: []}
    k = 0
    for i in range(2 * pairs):
        publish = i % 2 == 1
        n = 0
        t0 = time.perf_counter()
        while True:
            for _ in range(50):
                x = _work(x)
                if publish:
                    server.publish(frames[k % nf])
                    k += 1
            n += 50
            dt = time.perf_counter() - t0
            if dt >= block_s:
                break
        rates[publish].append(n / dt)
    return float(np.median(rates[False])), float(np.median(rates[True]))


def _flat_out(ticks: int) -> float:
    x = np.linspace(0.0, 1.0, 6_000)
    t0 = time.perf_counter()
    for _ in range(ticks):
        x = _work(x)
    return ticks / (time.perf_counter() - t0)


def _paced(seconds: float, server: ViewerServer, frames: list[dict[str, Any]]) -> float:
    x = np.linspace(0.0, 1.0, 6_000)
    period = 1e-3
    t0 = time.perf_counter()
    nxt = t0
    k = 0
    while time.perf_counter() - t0 < seconds:
        x = _work(x)
        server.publish(frames[k % len(frames)])
        k += 1
        nxt += period
        delay = nxt - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
    return k / (time.perf_counter() - t0)


def _chromium_fps(url: str, seconds: float) -> float | None:
    try:
        import sys
        from pathlib import Path

        root = Path(__file__).resolve().parents[3] / "tests"
        if str(root) not in sys.path and root.is_dir():
            sys.path.insert(0, str(root))
        from support.browser import chromium_unavailable, headless_page
    except ImportError:
        return None
    if chromium_unavailable() is not None:
        return None
    with headless_page() as bp:
        bp.page.goto(url)
        bp.page.wait_for_function("window.uhri && window.uhri.framesReceived > 0",
                                  timeout=15_000)
        bp.page.wait_for_timeout(1500)  # let the page finish loading (three.js, scene)
        n0 = bp.page.evaluate("window.uhri.framesReceived")
        t0 = time.perf_counter()
        bp.page.wait_for_timeout(seconds * 1000)
        n1 = bp.page.evaluate("window.uhri.framesReceived")
        return (n1 - n0) / (time.perf_counter() - t0)


def _real_simulation(pairs: int = 3, ticks: int = 900) -> dict[str, Any] | None:
    """Flat-out tick rate of scenarios/track_and_trail.yaml without / with attach_viewer
    (a client connected), alternating runs; None without the viewer's extra."""

    from uhrisim.scenario.shipped import shipped_scenario

    scenario = shipped_scenario()
    try:
        from uhrisim.scenario.load import load_scenario
        from uhrisim.sim.simulation import Simulation
        from uhrisim.viz.viewer.hook import attach_viewer
    except ImportError:
        return None
    source = load_scenario(scenario)
    rates: dict[bool, list[float]] = {False: [], True: []}
    frames = 0
    for i in range(2 * pairs):
        view = i % 2 == 1
        sim = Simulation(source)
        server = client = None
        if view:
            server, _ = attach_viewer(sim, port=0, speed=float("inf"))
            client = _Client(server.url)
        sim.step()
        t0 = time.perf_counter()
        for _ in range(ticks):
            sim.step()
        rates[view].append(ticks / (time.perf_counter() - t0))
        if server is not None and client is not None:
            server.close()
            client.finish()
            frames += len(client.frames)
        sim.close()
    without, with_ = float(np.median(rates[False])), float(np.median(rates[True]))
    return {
        "scenario": "track_and_trail.yaml",
        "ticks_per_run": ticks,
        "tick_rate_hz": {"without_viewer": without, "with_viewer": with_},
        "overhead_fraction": 1.0 - with_ / without,
        "frames_received_per_run": frames / pairs,
    }


def run(quick: bool = False) -> dict[str, Any]:
    """Measure; returns a JSON-serialisable dict (see module docstring)."""
    rng = np.random.default_rng(0)
    fan = demo_fan(0.0, size=FAN_SHAPE, rng=rng)
    frames = _frames(200, fan)
    pairs, block_s = (2, 0.3) if quick else (8, 1.0)
    max_fps = 20.0

    # --- baseline: no viewer at all (for reference)
    _flat_out(200)  # warm-up
    no_server = _flat_out(2000 if quick else 8000)

    server = ViewerServer(demo_scene(), [], port=0, max_fps=max_fps)
    url = server.start()
    client = _Client(url)
    fps_chromium = None
    try:
        time.sleep(0.2)
        # --- publish() cost alone (server busy in its thread, a client connected)
        n_pub = 20_000 if quick else 200_000
        t0 = time.perf_counter()
        for k in range(n_pub):
            server.publish(frames[k % 200])
        publish_us = (time.perf_counter() - t0) / n_pub * 1e6
        plain = [f for f in frames if f["sonar"] is None]
        t0 = time.perf_counter()
        for k in range(n_pub):
            server.publish(plain[k % len(plain)])
        publish_plain_us = (time.perf_counter() - t0) / n_pub * 1e6

        # --- overhead on the flat-out loop (interleaved blocks, medians)
        e0 = server.frames_encoded
        w0 = time.monotonic()
        base, with_viewer = _interleaved(pairs, block_s, server, frames)
        w1 = time.monotonic()
        encoded = server.frames_encoded - e0

        # --- paced 1 kHz loop with the viewer
        p0 = time.monotonic()
        paced_rate = _paced(0.4 if quick else 3.0, server, frames)
        p1 = time.monotonic()

        # --- the real page, if a browser is here
        if not quick:
            stop = threading.Event()

            def feed() -> None:
                k = 0
                while not stop.is_set():
                    server.publish(frames[k % 200])
                    k += 1
                    time.sleep(1e-3)

            th = threading.Thread(target=feed, daemon=True)
            th.start()
            try:
                fps_chromium = _chromium_fps(url, 3.0)
            finally:
                stop.set()
                th.join(2)
    finally:
        server.close()
        client.finish()
    fps_python = client.rate("frames", w0, w1)
    fps_paced = client.rate("frames", p0, p1)
    sonar_paced = client.rate("sonars", p0, p1)

    real = None if quick else _real_simulation()
    overhead = 1.0 - with_viewer / base
    fps_delivered = fps_chromium if fps_chromium is not None else fps_paced
    return {
        "config": {
            "quick": quick,
            "max_fps": max_fps,
            "fan_shape": list(FAN_SHAPE),
            "sonar_every_ticks": 10,
            "agents": 2,
            "interleaved_pairs": pairs,
            "seconds_per_block": block_s,
        },
        "publish_us_per_call": publish_us,
        "publish_us_per_call_without_sonar": publish_plain_us,
        "loop_rate_hz": {"no_server": no_server, "without_publish": base,
                         "with_viewer": with_viewer},
        "overhead_fraction": overhead,
        "frames_encoded_during_flat_out": encoded,
        "frames_per_s": {
            "python_client_flat_out_half_blocks": fps_python,
            "python_client_paced_1khz": fps_paced,
            "chromium_page": fps_chromium,
        },
        "sonar_per_s_paced_1khz": sonar_paced,
        "real_simulation": real,
        "paced_1khz_loop_achieved_hz": paced_rate,
        "targets": {
            "overhead_max": OVERHEAD_TARGET,
            "frames_per_s_min": FPS_TARGET,
            "publish_us_max": PUBLISH_TARGET_US,
        },
        "meets_target": bool(
            overhead <= OVERHEAD_TARGET
            and fps_delivered >= FPS_TARGET
            and publish_us <= PUBLISH_TARGET_US
        ),
    }


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps(run(quick=False), indent=2))
