"""What an assisted run measured: the diver's signals against what the ROV read, how
fast it acted, and what it got done (docs/hri.md, "Wiring").

**Signals.** The diver's script says what he signalled (:class:`IssuedSignal`: when it
began, the command, the channel, how long it took to make). A recognition matches an
issued signal when it says the same command on the same channel between the signal's
start and ``match_s`` after its end; each recognition matches one signal at most. Per
channel: ``issued``, ``recognized`` (issued signals matched), ``missed`` and ``false``
(recognitions that match none).

**Latency** of a signal the assistant acts on (not ``ok`` or ``done``): from the start of
the signal to the first tick whose task is its command (s), for the signals that got
one; missed signals have none.

**Assists.** From the assistant's trace: handovers ``attempted`` (entries into "creep to
his hand") and ``succeeded`` ("handed over" events), tasks ``completed`` ("task ... done"
events) and ``aborted``, and ``asked_again``: how often the idle ROV showed its "say
again?" cue ("say again?" events).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from uhrisim.assistant.io import AssistantOutputs
from uhrisim.perception.signals import CHANNELS, Channel, Command, RecognizedSignal

_NO_TASK = ("ok", "done")


@dataclass(frozen=True)
class IssuedSignal:
    """A signal the diver made: start time (s), command, channel, duration (s)."""

    t: float
    command: Command
    channel: Channel
    duration_s: float = 0.0


def signal_metrics(issued: Sequence[IssuedSignal], said: Sequence[RecognizedSignal],
                   trace: Sequence[AssistantOutputs], match_s: float = 3.0) -> dict[str, Any]:
    """The metrics of the module docstring, as a JSON-ready dict."""
    used: set[int] = set()
    matched: list[bool] = []
    for sig in issued:
        hit = next((i for i, r in enumerate(said) if i not in used
                    and r.channel == sig.channel and r.command == sig.command
                    and sig.t <= r.t <= sig.t + sig.duration_s + match_s), None)
        if hit is not None:
            used.add(hit)
        matched.append(hit is not None)
    channels = {}
    for channel in CHANNELS:
        mine = [m for s, m in zip(issued, matched, strict=True) if s.channel == channel]
        channels[channel] = {
            "issued": len(mine), "recognized": sum(mine), "missed": len(mine) - sum(mine),
            "false": sum(1 for i, r in enumerate(said) if r.channel == channel and i not in used)}
    latencies = []
    for sig, ok in zip(issued, matched, strict=True):
        if not ok or sig.command.name in _NO_TASK:
            continue
        acted = next((out.t for out in trace
                      if out.t >= sig.t and out.task == str(sig.command)), None)
        if acted is not None:
            latencies.append(round(acted - sig.t, 3))
    events = [e for out in trace for e in out.events]
    actives = [out.active for out in trace]
    attempts = sum(1 for a, b in zip(["", *actives], actives, strict=False)
                   if b.endswith("creep to his hand") and not a.endswith("creep to his hand"))
    return {
        "signals": channels,
        "latency_s": {"each": latencies,
                      "mean": round(sum(latencies) / len(latencies), 3) if latencies else None,
                      "max": max(latencies) if latencies else None},
        "handovers": {"attempted": attempts,
                      "succeeded": sum(e.startswith("handed over") for e in events)},
        "tasks": {"completed": sum(e.startswith("task ") and e.endswith(" done")
                                   for e in events),
                  "aborted": sum(e.startswith("task ") and " aborted" in e for e in events)},
        "asked_again": sum(e.startswith("say again?") for e in events),
    }
