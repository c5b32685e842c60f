"""The viewer's map labels, plots and sonar fan read well, in a REAL headless Chromium.

Frames of the stand-in trailing mission (``uhrisim.viz.viewer.demo``: the ROV 2 m behind
the diver, the trail point on top of it) are published one by one; the page reports
what it drew (``window.uhri.labelBoxes``, ``plotLayout``, ``sonarView``). Checks:

* no two label boxes intersect, none covers a vehicle or leaves the map, although the
  diver, the ROV and the trail point are within a few pixels of one another at the
  fitted scale;
* every plot has value ticks at nice numbers (1, 2 or 5 × 10^k apart), strictly
  monotonic on screen, with distinct labels; the time axis has ticks in seconds;
* a replay-style jump in time (``frame["jump"]``) leaves a gap: the range series is
  drawn as two polylines, neither spanning the skipped time;
* the sonar fan has bearing labels across its field of view, and the wheel zooms it:
  twice the pixels per metre shows half the range, with finer range arcs.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("websockets")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from support.browser import chromium_unavailable, headless_page
from uhrisim.viz.viewer import ViewerServer
from uhrisim.viz.viewer.demo import DEMO_BUTTONS, demo_fan, demo_frame, demo_scene

_why = chromium_unavailable()
pytestmark = pytest.mark.skipif(_why is not None, reason=_why or "")


def _show(page, server: ViewerServer, frame: dict) -> None:
    server.publish(frame)
    page.wait_for_function(f"window.uhri.frame && window.uhri.frame.t === {frame['t']}",
                           timeout=20_000)


def _echo_distance(png: bytes, apex: list[float]) -> float:
    """Distance (px) from the fan's apex to the centroid of its brightest echo (the diver):
    the grey fan's brightest pixels (the overlay's blue-tinted lines and labels left out)."""
    img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR).astype(float)
    grey = np.where(np.ptp(img, axis=2) < 12, img.mean(axis=2), 0.0)
    ys, xs = np.nonzero(grey >= 0.8 * grey.max())
    return float(np.hypot(xs.mean() - apex[0], ys.mean() - apex[1]))


def _boxes_intersect(a: dict, b: dict) -> bool:
    return (a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"]
            and a["y"] < b["y"] + b["h"] and b["y"] < a["y"] + a["h"])


def _is_nice_step(step: float) -> bool:
    mantissa = step / 10 ** np.floor(np.log10(step) + 1e-9)
    return any(abs(mantissa - m) < 1e-6 for m in (1.0, 2.0, 5.0, 10.0))


def test_labels_ticks_gaps_and_sonar_zoom():
    server = ViewerServer(demo_scene(), DEMO_BUTTONS, port=0, max_fps=50)
    url = server.start()
    rng = np.random.default_rng(0)
    try:
        with headless_page() as bp:
            page = bp.page
            server.publish(demo_frame(0.0))
            page.goto(url)
            page.wait_for_function("window.uhri.framesReceived > 0", timeout=20_000)
            # 30 s of trailing at 1 Hz, then a jump to 45 s (a replay seek) and 5 s more
            times = [float(k) for k in range(1, 31)] + [45.0 + k for k in range(6)]
            for t in times:
                frame = demo_frame(t, sonar=demo_fan(t, rng=rng) if t == times[-1] else None)
                frame["jump"] = t == 45.0
                _show(page, server, frame)
            page.wait_for_function("window.uhri.sonarsReceived > 0", timeout=20_000)
            page.evaluate("window.uhri.redraw()")
            page.wait_for_timeout(300)
            st = page.evaluate("""() => ({boxes: window.uhri.labelBoxes,
                plots: window.uhri.plotLayout, sonar: window.uhri.sonarView,
                size: [document.getElementById("map").clientWidth,
                       document.getElementById("map").clientHeight],
                agents: Object.values(window.uhri.agents).map(
                    (a) => window.uhri.worldToScreen(a.north, a.east))})""")

            # --- labels: the diver, the ROV and the trail point are crowded, labels are not
            texts = [b["text"] for b in st["boxes"]]
            assert any(t.startswith("diver") for t in texts)
            assert any(t.startswith("videoray") for t in texts) and "trail point" in texts
            (x1, y1), (x2, y2) = st["agents"]
            assert np.hypot(x1 - x2, y1 - y2) < 40, "the test wants the vehicles crowded"
            boxes = st["boxes"]
            width, height = st["size"]
            for i, a in enumerate(boxes):
                assert a["x"] >= 0 and a["x"] + a["w"] <= width, a  # on the map
                assert a["y"] >= 0 and a["y"] + a["h"] <= height, a
                for b in boxes[i + 1:]:
                    assert not _boxes_intersect(a, b), (a, b)
                for x, y in st["agents"]:  # no label on a vehicle's centre
                    assert not (a["x"] <= x <= a["x"] + a["w"] and a["y"] <= y <= a["y"] + a["h"])

            # --- plots: nice, distinct, monotonic ticks; a time axis
            rows = st["plots"]["rows"]
            assert [r["title"] for r in rows] == ["range to diver (m)", "depth (m)",
                                                  "speed (m/s)"]
            for r in rows:
                ticks = r["ticks"]
                assert len(ticks) >= 2, r["title"]
                values = [k["value"] for k in ticks]
                labels = [k["text"] for k in ticks]
                assert len(set(labels)) == len(labels), labels
                steps = np.diff(values)
                assert np.all(steps > 0) and np.allclose(steps, steps[0]), values
                assert _is_nice_step(float(steps[0])), values
                ys = np.array([k["y"] for k in ticks])
                assert np.all(np.diff(ys) < 0) or np.all(np.diff(ys) > 0), ys
                assert [float(t) for t in labels] == pytest.approx(values)
            time_ticks = st["plots"]["time"]
            tvals = [k["value"] for k in time_ticks]
            assert len(tvals) >= 3 and _is_nice_step(float(np.diff(tvals)[0]))
            assert tvals[-1] <= times[-1] and tvals[0] >= times[-1] - 60
            assert np.all(np.diff([k["x"] for k in time_ticks]) > 0)

            # --- the jump from 30 s to 45 s is a gap: two polylines, none across it
            segments = rows[0]["segments"]["range"]
            assert len(segments) == 2, [len(s) for s in segments]
            assert [len(s) for s in segments] == [len(times) - 6 + 1, 6]  # t = 0..30, 45..50
            assert segments[0][-1][0] < segments[1][0][0]
            px_per_s = (time_ticks[-1]["x"] - time_ticks[0]["x"]) / (tvals[-1] - tvals[0])
            gap_px = segments[1][0][0] - segments[0][-1][0]
            assert gap_px == pytest.approx(15 * px_per_s, rel=0.02)

            # --- the sonar fan: bearings across the 45° field, zoom by the wheel
            (key, fan), = st["sonar"].items()
            assert key == "videoray/sonar"
            assert fan["bearings"] == [-20, -10, 0, 10, 20]
            assert fan["shown_range"] == pytest.approx(10.0) and fan["arcs"] == [2, 4, 6, 8, 10]
            echo_before = _echo_distance(page.locator("#sonar").screenshot(), fan["apex"])
            box = page.locator("#sonar").bounding_box()
            page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            page.mouse.wheel(0, -500)  # × exp(500 · 0.0015) = 2.12
            page.wait_for_function("window.uhri.sonarZoom > 2", timeout=10_000)
            page.wait_for_timeout(200)
            zoom = page.evaluate("window.uhri.sonarZoom")
            zoomed = page.evaluate("window.uhri.sonarView['videoray/sonar']")
            assert zoom == pytest.approx(np.exp(0.75), rel=1e-6)
            assert zoomed["px_per_m"] == pytest.approx(zoom * fan["px_per_m"], rel=0.01)
            assert zoomed["shown_range"] == pytest.approx(10.0 / zoom, rel=1e-6)
            assert zoomed["arcs"] == [1, 2, 3, 4]
            assert "×2.1" in page.locator("#sonar-caption").inner_text()
            # the picture is magnified too: the diver's echo, 2 m out, is twice as far up
            assert echo_before == pytest.approx(2.0 * fan["px_per_m"], rel=0.15)
            echo_after = _echo_distance(page.locator("#sonar").screenshot(), fan["apex"])
            assert echo_after == pytest.approx(zoom * echo_before, rel=0.1)
            page.dblclick("#sonar")
            page.wait_for_function("window.uhri.sonarZoom === 1", timeout=10_000)
            assert bp.errors() == []
    finally:
        server.close()
