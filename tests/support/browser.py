"""Headless Chromium for viewer tests: Debian's ``/usr/bin/chromium`` driven by Playwright.

Never calls ``playwright install`` (no downloads here): it launches the system Chromium
with a throw-away profile and the flags the house rules ask for. ``chromium_unavailable()``
returns the reason a test should skip (None when a browser can run).
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

CHROMIUM_CANDIDATES = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome")

CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    # WebGL in software (SwiftShader) so the 3-D panel renders without a GPU.
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
)


def chromium_path() -> str | None:
    """Path of a system Chromium, honouring ``$UHRISIM_CHROMIUM``; None if none is found."""
    env = os.environ.get("UHRISIM_CHROMIUM")
    if env:
        return env if os.path.exists(env) else None
    for p in CHROMIUM_CANDIDATES:
        if os.path.exists(p):
            return p
    return shutil.which("chromium")


def chromium_unavailable() -> str | None:
    """Why a browser test cannot run here, or None if it can."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright (Python) is not installed: pip install playwright"
    if chromium_path() is None:
        return "no system Chromium: apt-get install -y chromium (never `playwright install`)"
    return None


@dataclass
class BrowserPage:
    """A Playwright page plus everything the page logged."""

    page: Any
    console: list[tuple[str, str]] = field(default_factory=list)
    page_errors: list[str] = field(default_factory=list)
    failed_requests: list[str] = field(default_factory=list)

    def errors(self) -> list[str]:
        """Console errors, uncaught exceptions and failed requests, as text."""
        out = [f"console.{kind}: {text}" for kind, text in self.console if kind == "error"]
        out += [f"pageerror: {e}" for e in self.page_errors]
        out += [f"requestfailed: {u}" for u in self.failed_requests]
        return out


@contextlib.contextmanager
def headless_page(
    width: int = 1400, height: int = 860, device_scale_factor: float = 1.0
) -> Iterator[BrowserPage]:
    """A fresh headless Chromium page (temporary profile), closed on exit."""
    from playwright.sync_api import sync_playwright

    exe = chromium_path()
    if exe is None:  # pragma: no cover - callers check chromium_unavailable() first
        raise RuntimeError("no system Chromium found")
    profile = tempfile.mkdtemp(prefix="uhrisim-chromium-")
    try:
        with sync_playwright() as pw:
            ctx = pw.chromium.launch_persistent_context(
                profile,
                executable_path=exe,
                headless=True,
                args=list(CHROMIUM_FLAGS),
                viewport={"width": width, "height": height},
                device_scale_factor=device_scale_factor,
                env={**os.environ, "HOME": profile},
            )
            try:
                page = ctx.pages[0] if ctx.pages else ctx.new_page()
                bp = BrowserPage(page)
                page.on("console", lambda m: bp.console.append((m.type, m.text)))
                page.on("pageerror", lambda e: bp.page_errors.append(str(e)))
                page.on("requestfailed", lambda r: bp.failed_requests.append(r.url))
                yield bp
            finally:
                ctx.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)


def _live_screenshot(path: str, sim: Any, sim_seconds: float, speed: float,
                     arrange: str | None = None) -> None:
    """Run ``sim`` for ``sim_seconds`` at ``speed`` × real time in the viewer, then save a
    screenshot of the page (after the JS ``arrange`` function, given the page state)."""
    import threading

    from uhrisim.viz.viewer import attach_viewer

    server, _ = attach_viewer(sim, port=0, speed=speed)
    run = threading.Thread(target=sim.run, args=(sim_seconds,), daemon=True)
    try:
        with headless_page(width=1400, height=860) as bp:
            bp.page.goto(server.url)
            bp.page.wait_for_function("window.uhri && window.uhri.scene !== null")
            run.start()
            run.join()
            bp.page.wait_for_function(f"window.uhri.frame && window.uhri.frame.t >= "
                                      f"{sim_seconds} - 0.5", timeout=60_000)
            if arrange is not None:
                bp.page.evaluate(arrange)
            bp.page.wait_for_timeout(2500)
            bp.page.screenshot(path=path)
            if bp.errors():
                raise RuntimeError(f"page reported errors: {bp.errors()}")
    finally:
        sim.close()
        server.close()


def mission_screenshot(path: str, sim_seconds: float = 150.0) -> None:
    """Save a screenshot of the page during the real track-and-trail mission.

    ``python tests/support/browser.py docs/img/viewer.png`` regenerates the README image.
    """
    from pathlib import Path

    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim.simulation import Simulation

    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"
    _live_screenshot(path, Simulation(load_scenario(scenario)), sim_seconds, 20.0)


def team_screenshot(path: str, sim_seconds: float = 150.0) -> None:
    """Save a screenshot of the page during the salvage mission (no ray-cast sensors),
    the map zoomed on the diver: tools, sites, the posed diver, the task panel."""
    from pathlib import Path

    from uhrisim.app.runner import build_run
    from uhrisim.scenario.load import load_scenario

    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "salvage_team.yaml"
    sim = build_run(load_scenario(scenario), raycast_sensors=False)
    _live_screenshot(path, sim, sim_seconds, math.inf, """() => {
        const d = Object.values(window.uhri.agents).find((a) => a.kind === "diver");
        const v = window.uhri.view;
        v.cn = d.north; v.ce = d.east - 1; v.scale = 70; v.userMoved = true;
        window.uhri.redraw(); }""")


def replay_screenshot(path: str, recording: str, t_first: float, t_then: float) -> None:
    """Save a screenshot of the replay page: played ×5 from ``t_first`` (s) for about
    20 s, then a seek to ``t_then`` (a gap in the plots), played on a little, paused,
    the sonar zoomed ×2."""
    from uhrisim.viz.viewer.replay import serve_replay

    server = serve_replay(recording, port=0)
    seek = "(t) => { const s = document.getElementById('slider'); s.value = t; " \
           "s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change')); }"
    try:
        with headless_page(width=1400, height=860) as bp:
            page = bp.page
            page.goto(server.url)
            page.wait_for_function("window.uhri.replay && window.uhri.framesReceived > 0",
                                   timeout=300_000)
            page.evaluate(seek, t_first)
            page.select_option("#speed", "5")
            page.wait_for_timeout(4000)
            page.evaluate(seek, t_then)
            page.wait_for_timeout(2000)
            page.click("#btn-pause")
            box = page.locator("#sonar").bounding_box()
            page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            page.mouse.wheel(0, -462)  # × 2
            page.keyboard.press("f")
            page.wait_for_timeout(1000)
            page.screenshot(path=path)
            if bp.errors():
                raise RuntimeError(f"page reported errors: {bp.errors()}")
    finally:
        server.close()


if __name__ == "__main__":  # pragma: no cover - manual tool
    import sys

    mission_screenshot(sys.argv[1] if len(sys.argv) > 1 else "viewer.png")
