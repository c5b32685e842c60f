"""Arrival logic shared by Waypoint and Loiter (IvP ``WaypointEngine``).

A point is reached when the distance is within ``capture_radius``, or by "slip": the
closest distance seen so far is within ``slip_radius`` and the distance has begun to grow
(docs/reference/helm.md, Loiter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from uhrisim.autonomy.behaviors.base import BehaviorContext
from uhrisim.autonomy.coupler import coupled_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.zaic import ZaicMemo, zaic_peak_on_axis


@dataclass
class ArrivalTracker:
    """Mutable closest-approach memory for the current target point."""

    capture_radius: float
    slip_radius: float
    closest: float = math.inf

    def reset(self) -> None:
        self.closest = math.inf

    def arrived(self, dist: float) -> bool:
        """Update with the current distance (m); True when the point counts as reached."""
        if dist <= self.capture_radius:
            return True
        slipped = self.closest <= self.slip_radius and dist > self.closest + 1e-9
        self.closest = min(self.closest, dist)
        return slipped


def course_speed_objective(
    ctx: BehaviorContext,
    course_deg: float,
    speed: float,
    speed_zaic: tuple[float, float, float],
    speed_memo: ZaicMemo | None = None,
    weights: tuple[float, float] = (50.0, 50.0),
) -> Objective:
    """Loiter/StationKeep function: course ZAIC (pw 0, bw 180, wrap) coupled with a speed
    ZAIC ``speed_zaic = (peakwidth, basewidth, summitdelta)`` by ``weights`` (course,
    speed), normalised 0..100.

    ``speed_memo`` (the behavior's own) reuses the speed piece while its arguments repeat.
    """
    fc = zaic_peak_on_axis(ctx.domain.axis("course"), course_deg, 0.0, 180.0, 0.0)
    zs = speed_memo if speed_memo is not None else zaic_peak_on_axis
    fs = zs(ctx.domain.axis("speed"), speed, *speed_zaic)
    return coupled_objective(ctx.domain, fc, fs, weights)
