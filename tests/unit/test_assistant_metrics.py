"""Signals issued against signals read, latency and assists (assistant/metrics.py), and the
readers' once-per-signal rule (perception/signal_readers.py)."""

from __future__ import annotations

from uhrisim.assistant.io import AssistantOutputs
from uhrisim.assistant.metrics import IssuedSignal, signal_metrics
from uhrisim.perception.signal_readers import SignalReaders
from uhrisim.perception.signals import Command, RecognizedSignal

BRING = Command("bring_tool", "lift_bag")
FOLLOW = Command("follow_me")


def _tick(t, task="idle", active="assistant/decide/task/idle", events=()):
    return AssistantOutputs(t, (), None, task, active, tuple(events))


def test_counts_latency_and_assists_by_hand():
    issued = [IssuedSignal(1.0, BRING, "gesture", 9.4),   # read at 11.0: recognized
              IssuedSignal(40.0, FOLLOW, "marker", 3.0),  # read at 40.5: recognized
              IssuedSignal(60.0, FOLLOW, "gesture", 3.2)]  # never read: missed
    said = [RecognizedSignal(BRING, "gesture", 0.95, 11.0),
            RecognizedSignal(FOLLOW, "marker", 0.9, 40.5),
            RecognizedSignal(Command("stop"), "gesture", 0.92, 50.0)]  # false
    creep = "assistant/decide/task/bring tool/hand over/creep to his hand"
    trace = [_tick(0.0), _tick(11.25, str(BRING)), _tick(30.0, str(BRING), creep),
             _tick(30.25, str(BRING), creep), _tick(31.0, str(BRING)), _tick(32.0, str(BRING),
             creep), _tick(35.0, str(BRING), events=("handed over lift_bag",
                                                      "task bring_tool lift_bag done")),
             _tick(40.75, str(FOLLOW))]
    m = signal_metrics(issued, said, trace)
    assert m["signals"]["gesture"] == {"issued": 2, "recognized": 1, "missed": 1, "false": 1}
    assert m["signals"]["marker"] == {"issued": 1, "recognized": 1, "missed": 0, "false": 0}
    assert m["signals"]["sonar"] == {"issued": 0, "recognized": 0, "missed": 0, "false": 0}
    assert m["latency_s"]["each"] == [10.25, 0.75]
    assert m["handovers"] == {"attempted": 2, "succeeded": 1}
    assert m["tasks"] == {"completed": 1, "aborted": 0}


def test_a_recognition_too_late_or_on_another_channel_does_not_match():
    issued = [IssuedSignal(0.0, FOLLOW, "gesture", 3.2)]
    said = [RecognizedSignal(FOLLOW, "gesture", 0.9, 3.2 + 3.0 + 0.1),
            RecognizedSignal(FOLLOW, "marker", 0.9, 1.0)]
    m = signal_metrics(issued, said, [])
    assert m["signals"]["gesture"] == {"issued": 1, "recognized": 0, "missed": 1, "false": 1}
    assert m["signals"]["marker"]["false"] == 1
    assert m["latency_s"] == {"each": [], "mean": None, "max": None}


def test_a_slate_held_up_is_said_once_until_put_away_for_a_while():
    readers = SignalReaders(markers=None, gestures=None, sonar=None, repeat_s=5.0)
    said = []
    for k in range(40):  # held up 0..3.9 s, read every 0.1 s
        said += readers.once([RecognizedSignal(FOLLOW, "marker", 0.9, 0.1 * k)])
    said += readers.once([RecognizedSignal(FOLLOW, "marker", 0.9, 9.0)])  # shown again
    said += readers.once([RecognizedSignal(Command("stop"), "marker", 0.9, 9.5)])
    assert [(str(s.command), s.t) for s in said] == [("follow_me", 0.0), ("follow_me", 9.0),
                                                       ("stop", 9.5)]
    assert readers.said == said
