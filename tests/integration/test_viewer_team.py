"""The team mission in the viewer (issue 25), live and in replay, in a REAL headless Chromium.

``scenarios/salvage_team_boots.yaml`` runs for 10 simulated seconds without ray-cast
sensors (the diver on weighted boots picks up the wrench and starts on the first bolt),
recorded like any run; a hook builds viewer frames with the team entry as the live
viewer does. Checks, each against what the simulation or the recording holds:

* live: the task panel says ``<done>/<total> orders done`` and the current order as the
  executor has them; the map draws every tool and load and the diver's posed figure
  (its white bones where the skeleton's points project); the 3-D view has a mesh per
  tool, load and site and the figure in place of the primitive diver;
* replay of the same run: at its end the panel shows the orders done as metrics.json
  counts them, out of the total, and the figure from the recorded joint states; the map
  draws every tool and load where its last ``/tf`` frame (read with the independent
  ``mcap_ros2`` reader) puts it, the wrench the diver grasped held (ringed, "held by" in
  the panel), and the flange's state as the events tell it.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages

pytest.importorskip("websockets")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from support.browser import chromium_unavailable, headless_page
from uhrisim.app.runner import run_scenario
from uhrisim.sim.simulation import BaseHook
from uhrisim.viz.viewer import FrameBuilder, ViewerServer
from uhrisim.viz.viewer.replay import serve_replay
from uhrisim.viz.viewer.team import TeamView

_why = chromium_unavailable()
pytestmark = pytest.mark.skipif(_why is not None, reason=_why or "")

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "salvage_team_boots.yaml"


class _Frames(BaseHook):
    """Builds a viewer frame every simulated second, as the live viewer's hook does."""

    def __init__(self) -> None:
        self.builder = FrameBuilder()
        self.last: dict | None = None

    def on_start(self, sim) -> None:
        self.builder.team = TeamView(sim.team)

    def on_tick(self, frame) -> None:
        if frame.tick % 60 == 0:
            self.last = self.builder.build(frame)
        else:
            self.builder.observe(frame)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("salvage")
    frames = _Frames()
    run_scenario(SCENARIO, out, duration=10.0, raycast_sensors=False, extra_hooks=[frames])
    return out, frames.last


@pytest.fixture(scope="module")
def browser():
    """One headless page for both tests (starting Chromium costs seconds)."""
    with headless_page() as bp:
        yield bp


def _png(buf: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(buf, np.uint8), cv2.IMREAD_COLOR)[:, :, ::-1].astype(int)


def test_live_team_panel_map_and_3d(run, browser):
    _, frame = run
    team = frame["team"]
    progress = team["progress"]["diver1"]
    assert progress["total"] == 18 and progress["done"] >= 1 and progress["current"]
    server = ViewerServer({}, [], port=0, max_fps=20)
    url = server.start()
    try:
        bp, page = browser, browser.page
        server.publish(frame)
        page.goto(url)
        page.wait_for_function("window.uhri.team && window.uhri.teamDrawn && "
                               "window.uhri.gl", timeout=20_000)
        text = page.locator("#team").inner_text()
        assert f"diver1: {progress['done']}/18 orders done" in text
        assert f"now: {progress['current']}" in text
        assert "flange1: 0/4 bolts out" in text
        drawn = page.evaluate("window.uhri.teamDrawn")
        assert sorted(o["name"] for o in drawn["objects"]) == sorted(
            o["name"] for o in team["objects"])
        fig = team["figures"]["diver1"]
        assert drawn["figures"] == {"diver1": len(fig["bones"])} and len(fig["bones"]) >= 27

        # zoomed on the diver, its bones are white on the map where the points project
        n, e = np.mean(np.array(fig["points"])[:, :2], axis=0)
        page.evaluate(f"""() => {{ const v = window.uhri.view;
            v.cn = {n}; v.ce = {e}; v.scale = 150; v.userMoved = true;
            window.uhri.redraw(); }}""")
        page.wait_for_timeout(300)
        img = _png(page.locator("#map").screenshot())
        white = np.all(img > 235, axis=2)
        hits = 0
        for i, j in fig["bones"]:
            a, b = np.array(fig["points"][i]), np.array(fig["points"][j])
            mid = page.evaluate(f"window.uhri.worldToScreen({(a[0] + b[0]) / 2}, "
                                f"{(a[1] + b[1]) / 2})")
            x, y = (round(v) for v in mid)
            hits += bool(white[y - 1:y + 2, x - 1:x + 2].any())
        assert hits >= 0.8 * len(fig["bones"]), f"{hits} of {len(fig['bones'])} bones seen"

        # 3-D: a mesh per tool and load (the bag as its site), flange and bag sites,
        # the figure instead of the primitive diver
        v3 = page.evaluate("""() => { const v = window.uhri.view3d;
            return {keys: Object.keys(v.teamObjs).sort(),
                    figures: Object.keys(v.figureObjs),
                    body: v.agentObjs.diver1.body.map((m) => m.visible)}; }""")
        want = sorted([f"o:{o['name']}" for o in team["objects"] if o["kind"] != "lift_bag"]
                      + [f"s:{s['name']}" for s in team["sites"]
                         if s["kind"] in ("flange", "hatch", "lift_bag")])
        assert v3["keys"] == want
        assert v3["figures"] == ["diver1"] and not any(v3["body"])
        page.goto("about:blank")  # leave before the server goes (no reconnect attempts)
        assert bp.errors() == []
    finally:
        server.close()


def test_replay_shows_the_recorded_progress_and_pose(run, browser):
    out, _ = run
    metrics = json.loads((out / "metrics.json").read_text())["team"]["divers"]["diver1"]
    server = serve_replay(out / "recording.mcap", port=0)
    try:
        bp, page = browser, browser.page
        page.goto(server.url)
        page.wait_for_function("window.uhri.replay && window.uhri.framesReceived > 0",
                               timeout=20_000)
        t_end = page.evaluate("window.uhri.replay.t_end")
        page.evaluate(f"""() => {{ const s = document.getElementById('slider');
            s.value = {t_end}; s.dispatchEvent(new Event('input')); }}""")
        page.wait_for_function(f"window.uhri.frame.t >= {t_end} - 1e-6 && window.uhri.team",
                               timeout=20_000)
        page.wait_for_timeout(200)
        text = page.locator("#team").inner_text()
        assert f"diver1: {metrics['orders_done']}/{metrics['orders']} orders done" in text
        assert "last: pick up wrench1 (done)" in text
        drawn = page.evaluate("window.uhri.teamDrawn")
        assert drawn["figures"]["diver1"] >= 27

        # tools and loads where the recording's last /tf frames put them, the held wrench
        # ringed; the flange's state from the events
        last = {tr.child_frame_id: tr.transform.translation
                for m in read_ros2_messages(out / "recording.mcap", topics=["/tf"])
                for tr in m.ros_msg.transforms if tr.header.frame_id == "map"}
        team = page.evaluate("window.uhri.team")
        names = {o["name"] for o in team["objects"]}
        assert names == {"basket1", "wrench1", "bag1", "light1", "valve1"} <= set(last)
        for o in drawn["objects"]:
            p = last[o["name"]]  # ENU: x east, y north
            x, y = page.evaluate(f"window.uhri.worldToScreen({p.y}, {p.x})")
            assert abs(o["x"] - x) < 1.0 and abs(o["y"] - y) < 1.0, o
        held = {o["name"]: o["held_by"] for o in team["objects"] if o["held_by"]}
        assert held["wrench1"] == ["diver1/right_hand"]
        assert "wrench1 held by diver1/right_hand" in text
        assert "flange1: 0/4 bolts out" in text and "valve1: raised 0.00 m" in text
        wrench = next(o for o in drawn["objects"] if o["name"] == "wrench1")
        ring = _png(page.locator("#map").screenshot())[round(wrench["y"]),
                                                       round(wrench["x"]) + 6:
                                                       round(wrench["x"]) + 11]
        assert np.all(ring > 200, axis=1).any(), "no white ring round the held wrench"
        page.goto("about:blank")
        assert bp.errors() == []
    finally:
        server.close()
