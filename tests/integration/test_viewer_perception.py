"""The viewer draws the sonar perception of a real sonar-trail run (headless Chromium):
the diver track as a green circle on the map where the track is, and the tracks on the
sonar fan; a replay of the recording shows the recorded tracks."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("websockets")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from support.browser import chromium_unavailable, headless_page

_why = chromium_unavailable()
pytestmark = pytest.mark.skipif(_why is not None, reason=_why or "")

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail_sonar.yaml"
DIVER_GREEN = (51, 255, 51)  # TRACK_COLORS.diver in viewer.js


def _green(pixels: np.ndarray) -> np.ndarray:
    return np.all(np.abs(pixels.astype(int) - DIVER_GREEN) <= 40, axis=-1)


def test_tracks_are_drawn_on_the_map_and_the_fan():
    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim.simulation import Simulation
    from uhrisim.viz.viewer import FrameBuilder, ViewerServer
    from uhrisim.viz.viewer.adapt import scene_from_world

    sim = Simulation(load_scenario(SCENARIO))
    builder = FrameBuilder()
    tick = sim.step()
    while sim.t < 30.0 or not tick.pings:
        builder.observe(tick)
        tick = sim.step()
    frame = builder.build(tick, paused=True)
    (diver_track,) = [tr for tr in frame["overlays"]["tracks"] if tr["kind"] == "diver"]
    truth = sim.agents["diver"].nav().position_ned
    assert math.hypot(diver_track["north"] - truth[0], diver_track["east"] - truth[1]) < 1.0
    (mark,) = [m for m in frame["sonar"][0]["marks"] if m["kind"] == "diver"]
    assert 0.5 < mark["range"] < 4.0 and abs(mark["bearing_deg"]) < 22.5

    server = ViewerServer(scene_from_world(sim.scene), [], port=0, max_fps=20)
    url = server.start()
    try:
        server.publish(frame)
        with headless_page() as bp:
            page = bp.page
            page.goto(url)
            page.wait_for_function("window.uhri && window.uhri.framesReceived > 0"
                                   " && window.uhri.sonarsReceived > 0", timeout=60_000)
            page.keyboard.press("f")
            page.wait_for_timeout(400)
            xy = page.evaluate(f"() => window.uhri.worldToScreen({diver_track['north']},"
                               f" {diver_track['east']})")
            img = cv2.imdecode(np.frombuffer(page.locator("#map").screenshot(), np.uint8),
                               cv2.IMREAD_COLOR)[:, :, ::-1]
            x, y = (round(v) for v in xy)
            ring = img[y - 8: y + 9, x - 8: x + 9]  # the 6 px circle around the track
            assert _green(ring).sum() >= 8
            sonar = cv2.imdecode(np.frombuffer(page.locator("#sonar").screenshot(), np.uint8),
                                 cv2.IMREAD_COLOR)[:, :, ::-1]
            assert _green(sonar).sum() >= 8
            assert bp.errors() == []
    finally:
        server.close()


class _Sink:
    def publish(self, frame: dict) -> None:
        del frame


def test_replay_shows_the_recorded_tracks(tmp_path):
    # A recorded sonar-trail run, replayed: the map overlay at time t holds the tracks
    # recorded at the last ping before t, the diver track next to the recorded diver.
    from uhrisim.app.runner import run_scenario
    from uhrisim.record.reader import read_odometry
    from uhrisim.viz.viewer.replay import ReplayPlayer, load_replay

    run_scenario(SCENARIO, tmp_path, duration=30.0, figures=False)  # the recording only
    data = load_replay(tmp_path / "recording.mcap")
    times, seen = data.perception["videoray"]
    assert len(times) == 30 * 15  # every ping
    diver = read_odometry(tmp_path / "recording.mcap")["diver"]
    player = ReplayPlayer(data, _Sink())  # type: ignore[arg-type]
    t = 25.0
    (track,) = [tr for tr in player.frame_at(t)["overlays"]["tracks"] if tr["kind"] == "diver"]
    i = int(np.argmin(abs(diver.t - t)))
    assert math.hypot(track["north"] - diver.x_north[i], track["east"] - diver.y_east[i]) < 1.0
    last_ping = seen[int(np.searchsorted(times, t, "right")) - 1]
    assert track == {"agent": "videoray", **next(s for s in last_ping if s["kind"] == "diver")}
