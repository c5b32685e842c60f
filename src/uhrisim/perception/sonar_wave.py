"""Reading the diver's two-arm wave on the imaging sonar's polar images.

The ``wave_both_arms`` gesture (``perception/data/gestures.json``) swings both straight
arms between 60° and 140° of abduction, a 2.6 s cycle, twice. A horizontal fan sees the
arms as echoes beside the body; raised overhead they leave the fan's vertical aperture
close by (a P900's ±10° covers ±0.5 m at 3 m), and lowered they come back: the echo
beside the diver brightens and fades once per cycle, where the camera may see nothing.

**Per ping** (:func:`side_echo`): in the diver's gate — ``range ± GATE_RANGE_M`` at his
bearing (from the perception chain's diver track, or any tracker) — the summed excess
over the gate's median level (less :data:`ECHO_FLOOR`) of the cells whose cross-range
from his centre is between :data:`SIDE_M` (beside the body) and its end.

**Per window** (:func:`wave_score`, the last ``window_s`` at the ping rate): the side
echo less its moving average over one cycle (which removes the arms' coming out and
going back, and keeps the swing), then its **periodicity** — the normalised
autocorrelation at a lag of one cycle (±0.2 s), ~0 for speckle — and its **strength** —
its standard deviation over the window's mean side echo. :class:`SonarWaveReader` says
``come_here`` on the ``sonar`` channel when both reach :data:`MIN_PERIODICITY` and
:data:`MIN_STRENGTH`; its confidence is the periodicity. The thresholds were set from
renders of every gesture of the language at 3, 6 and 10 m (docs/hri.md); the fan's
aperture limits the reading to a few metres, turbidity does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from uhrisim.perception.signals import Command, RecognizedSignal
from uhrisim.sensors.sonar.ping import SonarPing

GATE_RANGE_M = 0.8
SIDE_M = (0.4, 1.3)
ECHO_FLOOR = 0.1
CYCLE_S = 2.6
MIN_PERIODICITY, MIN_STRENGTH = 0.3, 0.2


def side_echo(ping: SonarPing, range_m: float, bearing_rad: float) -> float:
    """The echo beside the diver at ``range_m`` and ``bearing_rad`` (sonar frame, > 0
    starboard): summed display level over the gate's median + ECHO_FLOOR (module
    docstring)."""
    lo, hi = np.searchsorted(ping.bin_ranges_m, [range_m - GATE_RANGE_M, range_m + GATE_RANGE_M])
    cross = np.abs(range_m * np.tan(ping.beam_angles_rad - bearing_rad))
    side = (cross > SIDE_M[0]) & (cross < SIDE_M[1])
    gate = ping.polar[lo:hi]
    if gate.size == 0 or not side.any():
        return 0.0
    return float(np.clip(gate[:, side] - np.median(gate) - ECHO_FLOOR, 0.0, None).sum())


def wave_score(echo: NDArray[np.float64], rate_hz: float) -> tuple[float, float]:
    """(periodicity, strength) of a window of side echoes at ``rate_hz`` (module
    docstring); (0, 0) when the window is shorter than two cycles."""
    x = np.asarray(echo, float)
    m = max(2, round(CYCLE_S * rate_hz))
    if len(x) < 2 * m or x.mean() <= 0.0:
        return 0.0, 0.0
    trend = np.convolve(x, np.ones(m) / m, mode="valid")
    swing = x[m // 2:m // 2 + len(trend)] - trend
    swing = swing - swing.mean()
    power = float(swing @ swing)
    if power <= 0.0:
        return 0.0, 0.0
    lags = range(max(1, round((CYCLE_S - 0.2) * rate_hz)), round((CYCLE_S + 0.2) * rate_hz) + 1)
    periodicity = max(float(swing[:-lag] @ swing[lag:]) / power for lag in lags
                      if lag < len(swing))
    return periodicity, float(swing.std() / x.mean())


@dataclass
class SonarWaveReader:
    """Streams pings and the diver's position in them into ``come_here`` signals."""

    window_s: float = 8.0
    hop_s: float = 1.0
    rate_hz: float = 5.0  # pings used per second (the thresholds' rate); others skipped
    _echo: list[tuple[float, float]] = field(default_factory=list, init=False)
    _next_t: float = field(default=-math.inf, init=False)
    _quiet_until: float = field(default=-math.inf, init=False)

    def feed(self, ping: SonarPing, range_m: float | None, bearing_rad: float | None
             ) -> list[RecognizedSignal]:
        """Take one ping and the diver's range (m) and bearing (rad) in it (None: not
        tracked, the window restarts); the signals recognized now."""
        if range_m is None or bearing_rad is None:
            self._echo.clear()
            return []
        t = ping.t
        if self._echo and t < self._echo[-1][0] + 1.0 / self.rate_hz - 1e-6:
            return []
        self._echo.append((t, side_echo(ping, range_m, bearing_rad)))
        self._echo = [e for e in self._echo if e[0] > t - self.window_s]
        span = self._echo[-1][0] - self._echo[0][0]
        if t < self._next_t or span < 0.9 * self.window_s:
            return []
        self._next_t = t + self.hop_s
        rate = (len(self._echo) - 1) / span
        periodicity, strength = wave_score(np.array([e[1] for e in self._echo]), rate)
        if periodicity < MIN_PERIODICITY or strength < MIN_STRENGTH or t < self._quiet_until:
            return []
        self._quiet_until = t + self.window_s
        return [RecognizedSignal(Command("come_here"), "sonar", min(1.0, periodicity), t)]
