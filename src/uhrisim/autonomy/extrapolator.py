"""Contact dead reckoning: linear extrapolator with speed decay (IvP ``LinearExtrapolator``).

docs/reference/helm.md: with dt = now - report time,

* dt <= d_s:          the contact travels v * dt along its heading;
* d_s < dt <= d_e:    its speed decays linearly from v to 0 at d_e, so the distance is
                      v*d_s + v*(dt - d_s) - v*(dt - d_s)^2 / (2 (d_e - d_s));
* dt > d_e:           the position is frozen at v*d_s + v*(d_e - d_s)/2, "decay maxed".

Frame: x east, y north (m); heading compass degrees; speed m/s. A negative dt (report
from the future) counts as 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from uhrisim.core.errors import ConfigError

__all__ = ["Extrapolated", "LinearExtrapolator"]


class Extrapolated(NamedTuple):
    """Dead-reckoned position and how far it was carried (a named tuple: the contact
    manager makes one per contact every tick)."""

    x: float
    y: float
    distance: float
    decay_maxed: bool


@dataclass(frozen=True)
class LinearExtrapolator:
    """Decay window (s). IvP contact behaviors default to ``decay = 5, 10`` (as recalled
    from IvPContactBehavior; docs/reference/helm.md gives no values)."""

    decay_start: float = 5.0
    decay_end: float = 10.0

    def __post_init__(self) -> None:
        if self.decay_start < 0.0 or self.decay_end < self.decay_start:
            raise ConfigError(
                f"decay needs 0 <= start <= end, got {self.decay_start}, {self.decay_end}",
                "extrapolator",
            )

    def travelled(self, speed: float, dt: float) -> tuple[float, bool]:
        """Distance (m) travelled after ``dt`` seconds and whether the decay is maxed."""
        dt = max(dt, 0.0)
        ds, de = self.decay_start, self.decay_end
        if dt <= ds:
            return speed * dt, False
        if dt <= de:
            tau = dt - ds
            return speed * ds + speed * tau - speed * tau * tau / (2.0 * (de - ds)), False
        return speed * ds + speed * (de - ds) / 2.0, True

    def extrapolate(
        self, x: float, y: float, heading_deg: float, speed: float, t_report: float, t_now: float
    ) -> Extrapolated:
        """Position at ``t_now`` of a contact reported at (x, y) at ``t_report``."""
        dist, maxed = self.travelled(speed, t_now - t_report)
        h = math.radians(heading_deg)
        return Extrapolated(x + dist * math.sin(h), y + dist * math.cos(h), dist, maxed)
