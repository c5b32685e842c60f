"""The assistant never takes the ROV inside its guards, whatever the diver does (within
a working diver's pace): random diver motions — drifts in any direction at up to
0.1 m/s, turns, the hand in and out — during a random task, in the kinematic world of
tests/support/assistant_world.py. The separation from his body and head is checked at
every 20 Hz step."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.assistant_world import DiverState, World
from uhrisim.assistant import AssistantConfig
from uhrisim.perception.signals import Command

CFG = AssistantConfig()
MAX_DRIFT = 0.1  # m/s: a diver at work (docs/hri.md: the guards' measured limits)
TASKS = [Command("come_here"), Command("bring_tool", "lift_bag"), Command("follow_me"),
         Command("light_here"), Command("stop")]


@st.composite
def diver_scripts(draw):
    start = np.array([draw(st.floats(4.0, 8.0)), draw(st.floats(-3.0, 3.0)),
                      draw(st.floats(3.0, 6.0))])
    segments = []
    for _ in range(draw(st.integers(2, 6))):
        speed = draw(st.floats(0.0, MAX_DRIFT))
        bearing = draw(st.floats(0.0, 2 * math.pi))
        climb = draw(st.floats(-0.5, 0.5))
        v = speed * np.array([math.cos(bearing), math.sin(bearing), climb])
        v *= speed / max(float(np.linalg.norm(v)), 1e-9)
        segments.append((draw(st.floats(3.0, 12.0)), v, draw(st.floats(0.0, 360.0)),
                         draw(st.booleans())))
    return start, segments


def _script(start, segments):
    """The diver's state at t: each segment's drift in turn, then still (the last one's
    heading and hand)."""
    def at(t: float) -> DiverState:
        p, left = start.copy(), t
        current, speed = segments[-1], 0.0
        for segment in segments:
            duration, v = segment[0], segment[1]
            step = min(left, duration)
            p = p + v * step
            left -= step
            if left <= 0.0:
                current, speed = segment, float(np.linalg.norm(v[:2]))
                break
        return DiverState(tuple(p), current[2], speed, hand_out=current[3])
    return at


@pytest.mark.slow
@settings(max_examples=12)
@given(diver_scripts(), st.sampled_from(TASKS), st.floats(0.5, 10.0))
def test_guards_are_never_broken(script, task, when):
    start, segments = script
    w = World(_script(start, segments), tools={"lift_bag": np.array([-2.0, 3.0, 6.0])},
              signals={when: task})
    w.run(60.0)
    body, head = w.min_separation()
    assert body >= CFG.body_guard_m, (body, w.events())
    assert head >= CFG.head_guard_m, (head, w.events())
