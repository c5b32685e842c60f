"""Progress as one line at a time, for logs and pipes (where a progress bar cannot draw):
how far, how fast, how long still to go.

``track_and_trail: 120/600 s simulated (20 %), 4.1x real time, about 1 min 57 s left``
``sweep: 3/12 runs (25 %), 0.52 runs/s, about 17 s left``

A line is written at the first update, then at most every ``every_s`` wall seconds, and
always at the end (:meth:`ProgressLines.finish`). Rates are measured from the first
update on, so that the setup before it (building a scene) does not count.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass
class ProgressLines:
    """Periodic progress lines of ``what`` (``total`` of ``unit``; ``total=None`` while
    unknown). ``simulated``: the unit is simulated seconds, so the rate is a real-time
    factor. ``clock``: wall seconds (monotonic)."""

    what: str
    total: float | None
    unit: str
    write: Callable[[str], None]
    every_s: float = 10.0
    simulated: bool = False
    clock: Callable[[], float] = time.monotonic
    _first: tuple[float, float] | None = field(init=False, default=None)  # (wall s, done)
    _last: float | None = field(init=False, default=None)
    _done: float = field(init=False, default=0.0)
    _written: float | None = field(init=False, default=None)  # ``done`` of the last line

    def update(self, done: float, total: float | None = None) -> None:
        """``done`` units so far (and the total, once known); a line when one is due."""
        self._done = done
        if total is not None:
            self.total = total
        now = self.clock()
        if self._first is None:
            self._first = (now, done)
        if self._last is None or now - self._last >= self.every_s:
            self._emit(now)

    def finish(self) -> None:
        """The last line (unless the last update already wrote it)."""
        if self._written != self._done:
            self._emit(self.clock())

    def _emit(self, now: float) -> None:
        self._last, self._written = now, self._done
        start, done_then = self._first or (now, self._done)
        self.write(self.line(self._done, self._done - done_then, now - start))

    def line(self, done: float, recent: float, elapsed_s: float) -> str:
        """The line for ``done`` units, ``recent`` of them done in the last ``elapsed_s``
        wall seconds (the rate)."""
        amount = f"{done:.0f}" if self.total is None else f"{done:.0f}/{self.total:.0f}"
        parts = [f"{self.what}: {amount} {self.unit}"]
        if self.total:
            parts[0] += f" ({100.0 * done / self.total:.0f} %)"
        rate = recent / elapsed_s if elapsed_s > 0 else math.nan
        if math.isfinite(rate) and rate > 0:
            unit = self.unit.split()[0]
            parts.append(f"{rate:.1f}x real time" if self.simulated
                         else f"{rate:.2g} {unit}/s")
            if self.total is not None and done < self.total:
                parts.append(f"about {duration_text((self.total - done) / rate)} left")
        return ", ".join(parts)


def duration_text(seconds: float) -> str:
    """``"45 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"
