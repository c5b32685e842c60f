"""The diver's side of a gesture (perception/signalling.py): he gets ready first — turned
to the ROV and upright, in his ready pose — and only then makes the gesture; made
straight from his work or his swim, the assisted salvage's gestures began while he
was prone or 89° off the ROV and were never read (docs/hri.md)."""

from __future__ import annotations

import pytest

from uhrisim.perception.gestures import pose_at
from uhrisim.perception.signalling import GESTURE_READY_S, SignalPerformer, signal_duration
from uhrisim.perception.signals import Command
from uhrisim.sim.assistance import SignallingDiver


@pytest.mark.parametrize("command", ["follow_me", "bring_tool lift_bag"])
def test_a_gesture_starts_once_the_diver_is_ready(command):
    performer = SignalPerformer()
    diver = SignallingDiver(agent=None, performer=performer)  # type: ignore[arg-type]
    said = Command.parse(command)
    gesture, count = performer.gestures.for_command(said)
    motion = gesture.timeline("right", count)
    start = 10.0
    p = performer.signal(start, said, "gesture")
    assert p.duration_s == pytest.approx(GESTURE_READY_S + motion[-1].t)
    assert signal_duration(said, "gesture") == pytest.approx(p.duration_s)
    ready = performer.joints(start - 1.0)  # his ready pose, between signals
    # getting ready: performing (so the loop turns him to the ROV) upright, arms at ready
    for t in (start, start + 0.5 * GESTURE_READY_S, start + GESTURE_READY_S):
        assert diver.signalling_pose(t) == {"posture": 0.0, "waist": 0.0, **ready}
    # then the gesture's own timeline, from its start
    for after in (0.4 * motion[-1].t, 0.8 * motion[-1].t):
        assert performer.joints(start + GESTURE_READY_S + after) == pytest.approx(
            pose_at(motion, after))
    assert diver.signalling_pose(start + p.duration_s + 0.1) is None
