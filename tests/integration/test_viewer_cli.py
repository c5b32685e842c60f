"""`uhrisim run --view` end to end (issue 7): the real command, the real simulation in its
own process, a real headless Chromium. The page loads without errors, the vehicles move
on screen, a scenario button posts its variable into the simulation and the ROV's helm
changes mode; the run still writes its recording. (Replay of recorded tracks:
test_viewer_replay.py.)
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("websockets")

from tests.support.browser import chromium_unavailable, headless_page
from uhrisim.record.reader import read_odometry

_why = chromium_unavailable()
pytestmark = pytest.mark.skipif(_why is not None, reason=_why or "")

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "track_and_trail.yaml"


def read_url(stream, pattern: str, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = stream.readline()
        match = re.search(pattern, line)
        if match:
            return match.group(0)
    raise AssertionError(f"no line matching {pattern!r} within {timeout} s")


def map_png(page) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(page.locator("#map").screenshot(), np.uint8),
                        cv2.IMREAD_COLOR)


def test_run_view_shows_moving_vehicles_and_buttons_change_the_helm_mode(tmp_path: Path):
    out = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--view", "--port", "0",
         "--rtf", "3", "--duration", "90", "--no-raycast-sensors", "--out", str(out), "-q"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        url = read_url(proc.stderr, r"http://127\.0\.0\.1:\d+/", timeout=60)
        with headless_page() as browser:
            page = browser.page
            page.goto(url)
            page.wait_for_function("window.uhri && window.uhri.framesReceived > 3",
                                   timeout=30_000)
            page.keyboard.press("f")  # fit the map to the agents and the loiter polygon
            first, t_first = map_png(page), page.evaluate("window.uhri.frame.t")
            # simulated time goes on (about 3x wall, slower on a busy machine): a second
            # of it, however long that takes
            page.wait_for_function(f"window.uhri.frame.t > {t_first} + 1.0", timeout=120_000)
            second = map_png(page)
            assert np.count_nonzero(np.any(first != second, axis=2)) > 20  # vehicles moved
            mode_before = page.evaluate("window.uhri.agents.videoray.mode")
            assert "TRAILING" in mode_before
            page.click("#buttons button[data-var='RETURN']")
            page.wait_for_function(
                "window.uhri.agents.videoray.mode.includes('RETURNING')", timeout=20_000)
            # the rest of the run at the speed menu's "max": no wall-clock pacing left
            page.select_option("#speed", "max")
            page.wait_for_function("window.uhri.frame.speed_factor === null",
                                   timeout=20_000)
            assert browser.errors() == []
        _, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, stderr[-2000:]
    tracks = read_odometry(out / "recording.mcap")
    assert set(tracks) == {"diver", "videoray"}
