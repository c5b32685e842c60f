"""Pace a simulation loop to the wall clock, or let it run free.

The physics never reads the wall clock (docs/conventions.md, "Time"); only this
helper does, to keep a loop that talks to live ROS 2 nodes at ``real_time_factor``
times real time. With ``real_time_factor=None`` (or ``inf``) the loop runs free: as
fast as it can, in lockstep with nothing.

Typical use in a loop::

    pacer = Pacer(real_time_factor=1.0)
    pacer.reset(t_sim=0.0)
    for k in range(n_ticks):
        step(); t_sim = (k + 1) * dt
        pacer.wait(t_sim)        # sleeps until wall time catches up with t_sim / factor

When the loop falls more than ``max_lag_s`` (wall seconds) behind schedule, the pacer
re-anchors instead of running flat out to catch up, and counts a slip; a loop that is
merely slower than real time therefore runs at its own best speed.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from uhrisim.core.errors import ConfigError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PacerStats:
    """What a :class:`Pacer` has seen so far.

    ``lag_s``: how far behind schedule the last :meth:`Pacer.wait` found the loop (wall s,
    0 when on time); ``slept_s``: total wall time spent sleeping; ``slips``: how many
    times the pacer re-anchored after falling more than ``max_lag_s`` behind;
    ``waits``: number of :meth:`Pacer.wait` calls.
    """

    lag_s: float
    slept_s: float
    slips: int
    waits: int


class Pacer:
    """Keeps ``t_sim`` (simulation seconds) in step with ``real_time_factor`` × wall time.

    ``clock`` (monotonic seconds) and ``sleep`` are injectable so tests can drive the
    pacer with a fake clock.
    """

    def __init__(
        self,
        real_time_factor: float | None = 1.0,
        *,
        max_lag_s: float = 0.5,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if real_time_factor is not None and not (real_time_factor > 0.0):
            raise ConfigError(
                f"must be positive (or None to run free), got {real_time_factor!r}",
                where="Pacer.real_time_factor",
            )
        if not (max_lag_s > 0.0):
            raise ConfigError(f"must be positive, got {max_lag_s!r}", where="Pacer.max_lag_s")
        free = real_time_factor is None or math.isinf(real_time_factor)
        self._factor: float | None = None if free else float(real_time_factor)
        self._max_lag = float(max_lag_s)
        self._clock = clock
        self._sleep = sleep
        self._anchor_wall: float | None = None
        self._anchor_sim = 0.0
        self._lag = 0.0
        self._slept = 0.0
        self._slips = 0
        self._waits = 0

    @property
    def real_time_factor(self) -> float | None:
        """Simulation seconds per wall second, or None when running free."""
        return self._factor

    def clock(self) -> float:
        """The pacer's wall clock now (monotonic s, or the injected clock's)."""
        return self._clock()

    @property
    def free_running(self) -> bool:
        """True when the pacer never sleeps."""
        return self._factor is None

    def reset(self, t_sim: float = 0.0) -> None:
        """Anchor: simulation time ``t_sim`` corresponds to the wall clock now."""
        self._anchor_wall = self._clock()
        self._anchor_sim = float(t_sim)

    def wall_deadline(self, t_sim: float) -> float:
        """Wall-clock time (the ``clock``'s units) at which ``t_sim`` is due."""
        if self._anchor_wall is None or self._factor is None:
            return self._clock()
        return self._anchor_wall + (float(t_sim) - self._anchor_sim) / self._factor

    def wait(self, t_sim: float) -> float:
        """Sleep until ``t_sim`` is due; return how far behind schedule it was (wall s).

        Free-running pacers return 0 at once. The first call on a pacer that was never
        :meth:`reset` anchors at ``t_sim`` and returns 0.
        """
        self._waits += 1
        if self._factor is None:
            self._lag = 0.0
            return 0.0
        if self._anchor_wall is None:
            self.reset(t_sim)
            self._lag = 0.0
            return 0.0
        now = self._clock()
        ahead = self.wall_deadline(t_sim) - now
        if ahead > 0.0:
            self._sleep(ahead)
            self._slept += ahead
            self._lag = 0.0
            return 0.0
        self._lag = -ahead
        if self._lag > self._max_lag:
            self._slips += 1
            self._anchor_wall = now
            self._anchor_sim = float(t_sim)
        return self._lag

    def stats(self) -> PacerStats:
        """A snapshot of the pacing statistics."""
        return PacerStats(self._lag, self._slept, self._slips, self._waits)


#: Simulated seconds over which a paced run's achieved speed is judged.
PACE_WINDOW_S = 10.0
#: A window below this fraction of the asked real-time factor is "behind".
BEHIND_FRACTION = 0.9


class PacingHook:
    """Paces a simulation to ``real_time_factor`` x wall time (for live bridges), and
    warns once (log) when a window of :data:`PACE_WINDOW_S` simulated seconds ran below
    :data:`BEHIND_FRACTION` of it: the machine cannot keep up, and nodes on wall time see
    a slow world. ``pacer``: the pacer to use (tests: one with a fake clock)."""

    def __init__(self, real_time_factor: float | None, pacer: Pacer | None = None) -> None:
        self.pacer = pacer or Pacer(real_time_factor)
        self._window: tuple[float, float] | None = None  # (t_sim, wall) at its start
        #: windows that ran below the asked factor so far
        self.behind = 0

    def on_start(self, sim) -> None:
        self.pacer.reset(sim.t)
        self._window = (float(sim.t), self.pacer.clock())

    def on_tick(self, frame) -> None:
        self.pacer.wait(frame.t)
        factor, window = self.pacer.real_time_factor, self._window
        if factor is None or window is None or frame.t - window[0] < PACE_WINDOW_S:
            return
        now = self.pacer.clock()
        achieved = (frame.t - window[0]) / max(now - window[1], 1e-9)
        self._window = (float(frame.t), now)
        if achieved < BEHIND_FRACTION * factor:
            self.behind += 1
            if self.behind == 1:
                log.warning("the paced run falls behind: %.2fx real time over the last "
                            "%g simulated s, %gx asked (the machine cannot keep up; ROS "
                            "nodes on use_sim_time follow /clock, nodes on wall time see a "
                            "slow world)", achieved, PACE_WINDOW_S, factor)

    def on_end(self, sim, error) -> None:
        del sim, error
