"""The diver's side of a signal: what his body shows while his script says one.

A script's ``signal`` (a command on a channel) becomes, from its start time: for a
``gesture`` (or the ``sonar`` wave), his ``signal_ready`` pose for
:data:`GESTURE_READY_S` (he turns to the ROV and rises upright from his work: whoever
moves his body does that while he performs), then the gesture's joint angles over its
timeline (:func:`~uhrisim.perception.gestures.pose_at`, the signalling arm ``side``) and
then his ``signal_ready`` pose again; for a ``marker``, the slate with the command's id held up
for ``slate_hold_s``. Whoever renders the diver (the simulation loop, a test world, the
figure) asks :meth:`SignalPerformer.joints` and :meth:`SignalPerformer.slate_id` each
frame; :attr:`SignalPerformer.issued` is the truth the metrics count against
(:mod:`uhrisim.assistant.metrics`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.perception.gestures import GestureSet, Keyframe, Side, pose_at
from uhrisim.perception.markers import MarkerCommands
from uhrisim.perception.signals import Channel, Command


@dataclass(frozen=True)
class Performance:
    """One signal being made: start (s), command, channel, duration (s), and the gesture's
    keyframes (s from the start: its ready lead included) or the slate's marker id."""

    t: float
    command: Command
    channel: Channel
    duration_s: float
    frames: tuple[Keyframe, ...] = ()
    marker_id: int | None = None


#: how long the diver holds the slate up (s) ...
SLATE_HOLD_S = 3.0
#: ... after at most this long (s) to turn to the ROV and rise from his work upright
#: (a marker signal's order lasts both; uhrisim.sim.assistance)
SLATE_READY_S = 2.0
#: a gesture starts after this long (s) in his ready pose, turned to the ROV and upright:
#: made straight from his work or his swim, its first seconds were lost to turning and
#: rising (the assisted salvage: 89° off the ROV at a "follow me"; docs/hri.md)
GESTURE_READY_S = SLATE_READY_S
#: where he holds it: ahead of his body centre and above it (m), its face to the front
SLATE_AHEAD_M, SLATE_ABOVE_M = 0.45, 0.35


def slate_position(body_ned: NDArray[np.float64], yaw: float) -> NDArray[np.float64]:
    """Where the slate is held up (NED, m), for a diver whose body centre is at
    ``body_ned`` facing ``yaw`` (rad); the slate's frame is turned by ``yaw`` too."""
    ahead = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    return np.asarray(body_ned, dtype=float) + SLATE_AHEAD_M * ahead - (0.0, 0.0, SLATE_ABOVE_M)


def signal_duration(command: Command, channel: Channel,
                    gestures: GestureSet | None = None) -> float:
    """How long making ``command`` on ``channel`` takes (s): the gesture's timeline, or
    getting ready and holding the slate up; ConfigError when the language has no
    gesture for it."""
    if channel == "marker":
        return SLATE_READY_S + SLATE_HOLD_S
    gesture, count = (gestures or GestureSet.load()).for_command(command, channel)
    return GESTURE_READY_S + gesture.timeline("right", count)[-1].t


@dataclass
class SignalPerformer:
    """Turns the script's signals into the diver's poses and slate (module docstring)."""

    gestures: GestureSet = field(default_factory=GestureSet.load)
    markers: MarkerCommands = field(default_factory=MarkerCommands.load)
    side: Side = "right"
    slate_hold_s: float = SLATE_HOLD_S
    issued: list[Performance] = field(default_factory=list)

    def signal(self, t: float, command: Command, channel: Channel) -> Performance:
        """Start making ``command`` on ``channel`` at ``t`` (s); ConfigError when the
        language has no gesture, or the slate no marker, for it."""
        if channel == "marker":
            done = Performance(t, command, channel, self.slate_hold_s,
                               marker_id=self.marker_id(command))
        else:
            gesture, count = self.gestures.for_command(command, channel)
            frames = tuple(replace(k, t=k.t + GESTURE_READY_S)
                           for k in gesture.timeline(self.side, count))
            done = Performance(t, command, channel, frames[-1].t, frames)
        self.issued.append(done)
        return done

    def marker_id(self, command: Command) -> int:
        """The slate's marker for ``command`` (the lowest id that says it)."""
        ids = [i for i, c in self.markers.commands.items() if c == command]
        if not ids:
            raise ConfigError(f"no marker on the slate says {command}", "signal")
        return min(ids)

    def _current(self, t: float) -> Performance | None:
        now = [p for p in self.issued if p.t <= t < p.t + p.duration_s]
        return now[-1] if now else None

    def joints(self, t: float) -> dict[str, float]:
        """The arm and trunk joint angles (rad, by name) at ``t``: a gesture's, or the
        ``signal_ready`` pose between gestures."""
        p = self._current(t)
        if p is None or not p.frames:
            plain = next(g for g in self.gestures.gestures.values() if g.count_period_s is None)
            return dict(plain.timeline(self.side)[0].joints)  # every gesture starts there
        return pose_at(p.frames, t - p.t)

    def performing(self, t: float) -> dict[str, float] | None:
        """The joint angles (rad, by name) while a signal is being made at ``t`` (the
        ready pose holding the slate), else None: the body is his own."""
        return None if self._current(t) is None else self.joints(t)

    def slate_id(self, t: float) -> int | None:
        """The marker id held up at ``t``, or None."""
        p = self._current(t)
        return None if p is None else p.marker_id
