"""Replay of an MCAP recording: the page shows the recorded tracks, and seeks correctly.

The recording is written with the project's own ``McapRecorder`` from the closed-form
stand-in run (``demo_state``: diver on the 20 m octagon, ROV 2 m behind), so every
expected position is known exactly: NED → ENU in the file → NED in the viewer must give
the numbers back (to float rounding).
"""

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
from uhrisim.core.errors import AssetError
from uhrisim.viz.viewer import Command
from uhrisim.viz.viewer.demo import DemoParams, demo_state, octagon, write_demo_recording
from uhrisim.viz.viewer.replay import ReplayPlayer, load_replay, serve_replay

DT = 0.1
DURATION = 20.0


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "demo.mcap"
    write_demo_recording(path, duration=DURATION, dt=DT, sonar_period=0.5)
    return path


class _Sink:
    def __init__(self) -> None:
        self.frames: list[dict] = []

    def publish(self, frame: dict) -> None:
        self.frames.append(frame)


def test_load_replay_gives_back_the_recorded_ned_tracks(recording):
    data = load_replay(recording)
    assert data.kinds == {"diver": "diver", "videoray": "rov"}
    assert (data.t_start, data.t_end) == (0.0, pytest.approx(DURATION))
    t = data.tracks["videoray"]["t"]
    assert len(t) == round(DURATION / DT) + 1
    for name in ("diver", "videoray"):
        tr = data.tracks[name]
        exp = np.array([demo_state(ti)[name] for ti in tr["t"]])
        np.testing.assert_allclose(tr["north"], exp[:, 0], atol=1e-9)
        np.testing.assert_allclose(tr["east"], exp[:, 1], atol=1e-9)
        np.testing.assert_allclose(tr["depth"], exp[:, 2], atol=1e-9)
        dh = (tr["heading_deg"] - exp[:, 3] + 180.0) % 360.0 - 180.0
        np.testing.assert_allclose(dh, 0.0, atol=1e-7)
        np.testing.assert_allclose(tr["speed"], exp[:, 4], atol=1e-9)
    # sonar: one fan per 0.5 s; its fov and range as recorded with it (never guessed)
    ts, _ = data.pings["videoray/sonar"]
    assert len(ts) == round(DURATION / 0.5) + 1
    assert data.sonar_fov_deg["videoray/sonar"] == DemoParams().sonar_fov_deg
    assert data.sonar_range["videoray/sonar"] == DemoParams().sonar_range
    # scene markers back in NED: four pilings at (±28, ±8), 0.4 m radius, 14 m tall
    pil = sorted((o["position_ned"][0], o["position_ned"][1]) for o in data.scene["objects"])
    np.testing.assert_allclose(pil, sorted([(28, -8), (28, 8), (-28, -8), (-28, 8)]), atol=1e-9)
    assert all(o["kind"] == "cylinder" and o["radius"] == pytest.approx(0.4)
               and o["height"] == pytest.approx(14.0) for o in data.scene["objects"])


def test_player_interpolates_and_obeys_commands(recording):
    data = load_replay(recording)
    sink = _Sink()
    p = ReplayPlayer(data, sink)  # type: ignore[arg-type]
    # between samples on one straight edge the path is linear: interpolation is exact
    f = p.frame_at(3.05)
    for a in f["agents"]:
        n, e, d, hd, _ = demo_state(3.05)[a["name"]]
        assert (a["north"], a["east"], a["depth"]) == pytest.approx((n, e, d), abs=1e-9)
        assert a["heading_deg"] == pytest.approx(hd, abs=1e-7)
    assert f["plots"]["range_to_diver"] == pytest.approx(
        math.dist(demo_state(3.05)["diver"][:3], demo_state(3.05)["videoray"][:3]))
    # modes: the ROV's from its helm decisions (DEPLOYING until 1 s), the diver's from MODE
    assert [a["mode"] for a in f["agents"]] == ["LOITER", "TRAIL"]
    assert [a["mode"] for a in p.frame_at(0.5)["agents"]] == ["LOITER", "DEPLOYING"]
    poly = f["overlays"]["polygons"][0]["points"]  # VIEW_POLYGON, MOOS x/y → north/east
    np.testing.assert_allclose(poly, octagon(), atol=1e-3)
    assert f["sonar"][0]["t"] == pytest.approx(3.0)  # the latest ping at or before 3.05 s
    # wall clock drives playback at the chosen speed
    p.tick(100.0)
    p.tick(101.0)
    assert p.t == pytest.approx(1.0)
    assert p.on_message(Command("speed", value=4.0))
    p.tick(101.5)
    assert p.t == pytest.approx(3.0)
    assert p.on_message(Command("pause"))
    p.tick(110.0)
    assert p.t == pytest.approx(3.0) and sink.frames[-1]["paused"] is True
    assert p.on_message(Command("step", value=1.0))
    assert p.t == pytest.approx(3.0 + DT)
    assert p.on_message({"type": "seek", "t": 1e9})
    assert p.t == pytest.approx(DURATION)
    assert p.on_message(Command("resume"))  # at the end: resume restarts from the start
    assert p.t == 0.0 and p.playing
    assert not p.on_message(Command("post", "videoray", "X", "1"))


def test_missing_recording_is_an_asset_error(tmp_path):
    with pytest.raises(AssetError, match="not found"):
        load_replay(tmp_path / "nope.mcap")


@pytest.mark.skipif(chromium_unavailable() is not None, reason=chromium_unavailable() or "")
def test_replay_page_shows_the_recorded_tracks(recording):
    server = serve_replay(recording, port=0)
    try:
        with headless_page() as bp:
            page = bp.page
            page.goto(server.url)
            page.wait_for_function("window.uhri && window.uhri.tracks && "
                                   "window.uhri.framesReceived > 0", timeout=20_000)
            assert page.locator("#conn").inner_text() == "replay"
            assert page.locator("#slider").is_visible()
            # the page holds exactly the recorded tracks (JSON floats round-trip exactly)
            tracks = page.evaluate("window.uhri.tracks")
            data = load_replay(recording)
            for name, tr in data.tracks.items():
                assert tracks[name]["t"] == tr["t"].tolist()
                assert tracks[name]["n"] == tr["north"].tolist()
                assert tracks[name]["e"] == tr["east"].tolist()
            # pause, then scrub to 12.3 s: agents sit at the recorded positions
            page.click("#btn-pause")
            page.wait_for_function("window.uhri.frame.paused === true", timeout=15_000)
            page.locator("#slider").fill("12.3")
            page.wait_for_function("Math.abs(window.uhri.frame.t - 12.3) < 1e-9", timeout=15_000)
            st = page.evaluate("""() => {
                const r = window.uhri.agents.videoray;
                return {agents: window.uhri.agents, xy: window.uhri.worldToScreen(r.north, r.east),
                        trail: window.uhri.frame && Object.fromEntries(Object.entries(
                            window.uhri.tracks).map(([k, v]) => [k, v.t.filter(x => x <= 12.3)
                            .length]))};
            }""")
            for name in ("diver", "videoray"):
                n, e, d, _, _ = demo_state(12.3)[name]
                a = st["agents"][name]
                assert (a["north"], a["east"], a["depth"]) == pytest.approx((n, e, d), abs=1e-9)
            assert st["trail"] == {"diver": 124, "videoray": 124}  # samples 0.0 … 12.3 s
            page.wait_for_timeout(300)
            img = cv2.imdecode(np.frombuffer(page.locator("#map").screenshot(), np.uint8),
                               cv2.IMREAD_COLOR)[:, :, ::-1].astype(int)
            x, y = (round(v) for v in st["xy"])
            patch = img[y - 1 : y + 2, x - 1 : x + 2].reshape(-1, 3)
            assert np.all(np.abs(patch - (245, 197, 24)) <= 12), patch.tolist()
            # the fan of the last ping before 12.3 s (12.0 s) is on screen
            page.wait_for_function("window.uhri.sonar['videoray/sonar'] && "
                                   "Math.abs(window.uhri.sonar['videoray/sonar'].t - 12.0) < 1e-9",
                                   timeout=15_000)
            assert bp.errors() == []
    finally:
        server.close()


def test_truncated_recording_replays_up_to_its_last_complete_chunk(recording, tmp_path):
    # a run killed half-way leaves no footer: replay what was written before the cut
    cut = tmp_path / "cut.mcap"
    data = recording.read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.6)])
    d = load_replay(cut)
    assert 0.0 < d.t_end < DURATION
    tr = d.tracks["diver"]
    exp = np.array([demo_state(t)["diver"][:3] for t in tr["t"]])
    np.testing.assert_allclose(np.column_stack([tr["north"], tr["east"], tr["depth"]]), exp,
                               atol=1e-9)


def test_odometry_only_recording(tmp_path):
    from uhrisim.record.mcap_recorder import McapRecorder

    path = tmp_path / "kayak.mcap"
    with McapRecorder(path) as rec:
        for k in range(11):  # 1 m/s due east for 10 s
            rec.write_odometry("kayak", float(k), (0.0, float(k), 0.0), math.pi / 2,
                               (1.0, 0.0, 0.0), 0.0)
    d = load_replay(path)
    assert d.kinds == {"kayak": "vehicle"} and d.pings == {} and d.scene["objects"] == []
    f = ReplayPlayer(d, _Sink()).frame_at(2.5)  # type: ignore[arg-type]
    (a,) = f["agents"]
    assert (a["north"], a["east"], a["heading_deg"], a["speed"]) == pytest.approx(
        (0.0, 2.5, 90.0, 1.0))
    assert f["sonar"] is None and f["plots"]["range_to_diver"] is None


def test_replay_draws_the_sonar_at_the_range_it_was_recorded_with(tmp_path):
    """A real mission recorded with a 7.5 m sonar (not the presets' 10 m or the old
    assumed 20 m) replays with a 7.5 m fan: the range comes from the recording's
    ProjectedSonarImage (issue 32)."""
    from uhrisim.app.runner import run_scenario
    from uhrisim.scenario.load import load_scenario
    from uhrisim.scenario.shipped import copy_scenario

    scenario = copy_scenario("track_and_trail", tmp_path / "scenario")[0]
    text = scenario.read_text()
    assert text.count("range_max_m: 10 ") == 1
    scenario.write_text(text.replace("range_max_m: 10 ", "range_max_m: 7.5 "))
    run_scenario(load_scenario(scenario), tmp_path / "run", duration=3.0, seed=1)
    data = load_replay(tmp_path / "run" / "recording.mcap")
    assert data.sonar_range["videoray/sonar"] == pytest.approx(7.5, abs=0.03)
    assert data.sonar_fov_deg["videoray/sonar"] == pytest.approx(45.0, abs=0.03)
    player = ReplayPlayer(data, _Sink())  # type: ignore[arg-type]
    fans = player.frame_at(2.5)["sonar"]
    assert [f["max_range"] for f in fans] == [pytest.approx(7.5, abs=0.03)] * len(fans)
    assert fans, "no sonar frame due by 2.5 s"
