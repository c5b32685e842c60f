"""The viewer against the REAL simulation (scenarios/track_and_trail.yaml) in headless
Chromium: the page shows the simulated agents where the simulation has them, the helm's
loiter polygon and trail point, the sonar fan; a scenario button reaches the simulated
community through drain_commands() → Simulation.post.

The loop here is a minimal stand-in for the lead's run loop: step, observe every tick,
publish every 3rd tick (20 Hz at the scenario's 60 Hz physics), apply commands.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("websockets")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from support.browser import chromium_unavailable, headless_page

_why = chromium_unavailable()
pytestmark = pytest.mark.skipif(_why is not None, reason=_why or "")

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"


class _Loop:
    def __init__(self, sim, server, builder) -> None:
        self.sim, self.server, self.builder = sim, server, builder
        self.paused = False
        self.last = None
        self.posts = []
        self.applied: list[tuple] = []  # postings the simulation applied from the viewer
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                for c in self.server.drain_commands():
                    if c.kind == "post":
                        self.sim.post(c.agent, c.name, c.value, source="viewer")
                        self.posts.append(c)
                    elif c.kind == "pause":
                        self.paused = True
                if self.paused:
                    self.server.publish(self.builder.build(self.last, paused=True))
                    time.sleep(0.02)
                    continue
                tick = self.sim.step()
                self.last = tick
                self.applied += [(p.community, p.var, p.value) for p in tick.posts
                                 if p.source == "viewer"]
                if self.sim.tick % 3 == 0:
                    self.server.publish(self.builder.build(tick))
                else:
                    self.builder.observe(tick)
        except BaseException as e:  # surfaced by the test
            self.error = e

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join(10)


def test_page_shows_the_real_simulation():
    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim import simulation as sim_mod
    from uhrisim.viz.viewer import FrameBuilder, ViewerServer
    from uhrisim.viz.viewer.adapt import scene_from_world

    source = load_scenario(SCENARIO)
    sim = sim_mod.Simulation(source)
    buttons = [{"label": b.label, "agent": b.agent, "var": b.var, "value": b.value}
               for b in source.scenario.buttons]
    server = ViewerServer(scene_from_world(sim.scene), buttons, port=0, max_fps=20)
    url = server.start()
    try:
        with _Loop(sim, server, FrameBuilder()) as loop, headless_page() as bp:
            page = bp.page
            page.goto(url)
            page.wait_for_function(
                "window.uhri && window.uhri.framesReceived > 5 && window.uhri.sonarsReceived > 0"
                " && window.uhri.frame.overlays.polygons.length > 0", timeout=60_000)
            # a scenario button → Command → Simulation.post → the community variable
            page.click("#buttons button[data-var='RETURN']")
            deadline = time.monotonic() + 20
            while ("videoray", "RETURN", "true") not in loop.applied:
                assert time.monotonic() < deadline, "RETURN never reached the community"
                time.sleep(0.02)
            # freeze the run, then the page must show exactly the last simulated state
            page.click("#btn-pause")
            page.wait_for_function("window.uhri.frame.paused === true", timeout=20_000)
            page.keyboard.press("f")  # fit the map to the agents and the loiter polygon
            page.wait_for_timeout(300)
            last = loop.last
            st = page.evaluate("""() => ({agents: window.uhri.agents, t: window.uhri.frame.t,
                overlays: window.uhri.frame.overlays,
                xy: window.uhri.worldToScreen(window.uhri.agents.videoray.north,
                                              window.uhri.agents.videoray.east)})""")
            assert st["t"] == pytest.approx(last.t, abs=1e-9)
            for name, snap in last.agents.items():
                a = st["agents"][name]
                np.testing.assert_allclose([a["north"], a["east"], a["depth"]],
                                           snap.nav.position_ned, atol=1e-9)
                assert a["heading_deg"] == pytest.approx(np.degrees(snap.nav.yaw) % 360, abs=1e-9)
            # the helm's loiter octagon (radius 20 m about north -20, east 10; MOOS x=10,
            # y=-20 in the scenario), converted from MOOS x/y to north/east
            (poly,) = [p for p in st["overlays"]["polygons"] if p["label"] == "loiter"]
            pts = np.array(poly["points"])
            assert len(pts) == 8
            np.testing.assert_allclose(np.hypot(pts[:, 0] + 20, pts[:, 1] - 10), 20.0, atol=0.05)
            img = cv2.imdecode(np.frombuffer(page.locator("#map").screenshot(), np.uint8),
                               cv2.IMREAD_COLOR)[:, :, ::-1].astype(int)
            x, y = (round(v) for v in st["xy"])
            patch = img[y - 1 : y + 2, x - 1 : x + 2].reshape(-1, 3)
            assert np.all(np.abs(patch - (245, 197, 24)) <= 12), patch.tolist()
            assert loop.error is None
            assert bp.errors() == []
    finally:
        server.close()
