"""A paced run that cannot keep up says so once (issue 30: the camera scenario ran at
0.72x real time without a word). A fake clock stands in for the wall: each tick of
1/60 s simulated costs ``cost`` wall seconds of work."""

from __future__ import annotations

import logging
from types import SimpleNamespace

import pytest

from uhrisim.sim.pacing import PACE_WINDOW_S, Pacer, PacingHook


def _run(cost_s: float, seconds: float) -> PacingHook:
    wall = [0.0]

    def sleep(dt: float) -> None:
        wall[0] += dt

    hook = PacingHook(1.0, Pacer(1.0, clock=lambda: wall[0], sleep=sleep))
    hook.on_start(SimpleNamespace(t=0.0))
    dt = 1.0 / 60.0
    for k in range(1, round(seconds / dt) + 1):
        wall[0] += cost_s  # the tick's work
        hook.on_tick(SimpleNamespace(t=k * dt))
    return hook


def test_a_run_at_072x_real_time_warns_once(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="uhrisim.sim.pacing"):
        hook = _run(cost_s=(1.0 / 60.0) / 0.72, seconds=3 * PACE_WINDOW_S)
    assert hook.behind == 3  # every window behind ...
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "0.72x real time" in lines[0]  # ... said once, with the rate


def test_a_run_that_keeps_up_says_nothing(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="uhrisim.sim.pacing"):
        hook = _run(cost_s=(1.0 / 60.0) * 0.5, seconds=3 * PACE_WINDOW_S)
    assert hook.behind == 0 and not caplog.records
