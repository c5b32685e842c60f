"""BHV_ConstantHeading: hold a heading (subdomain: course).

As pHelmIvP's (MOOS-IvP lib_behaviors-marine/BHV_ConstantHeading.cpp): the ``heading``
(compass deg, taken mod 360 and snapped to the nearest course grid value) is the summit
of a wrapping ZAIC peak with peakwidth 10, basewidth 170 and summitdelta 25 by default;
``complete_thresh`` (deg, -1 = off) completes the behavior once the own heading is within
it of the desired one; ``heading_mismatch_var`` posts that difference (deg) every tick.
Like ConstantDepth its ``duration`` defaults to 0: give ``duration = no-time-limit``.
An assistant points the vehicle at a diver through ``updates`` such as ``heading=231``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.params import (
    setter,
    to_clipped_non_negative,
    to_float,
    to_str,
    to_summitdelta,
)
from uhrisim.autonomy.zaic import zaic_peak_on_axis
from uhrisim.core.frames import wrap_180


@dataclass(frozen=True)
class ConstantHeadingParams:
    """BHV_ConstantHeading parameters (IvP names and defaults; module docstring)."""

    heading: float = 0.0
    peakwidth: float = 10.0
    basewidth: float = 170.0
    summitdelta: float = 25.0
    complete_thresh: float = -1.0
    heading_mismatch_var: str = ""


class ConstantHeading(Behavior):
    KIND = "BHV_ConstantHeading"
    Params = ConstantHeadingParams
    DEFAULT_DURATION = 0.0
    HANDLERS: ClassVar[dict] = {
        "heading": setter("heading", lambda v, k, w: to_float(v, k, w) % 360.0),
        "peakwidth": setter("peakwidth", to_clipped_non_negative),
        "basewidth": setter("basewidth", to_clipped_non_negative),
        "summitdelta": setter("summitdelta", to_summitdelta),
        "complete_thresh": setter("complete_thresh", to_float),
        "heading_mismatch_var": setter("heading_mismatch_var", to_str),
    }

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: ConstantHeadingParams = self.params
        axis = ctx.domain.axis("course")
        summit = float(axis.values[axis.index_of(p.heading)])
        if ctx.own is not None:
            mismatch = abs(float(wrap_180(ctx.own.heading - summit)))
            if p.heading_mismatch_var:
                ctx.post(p.heading_mismatch_var, mismatch)
            if mismatch < p.complete_thresh:
                self.complete()
                return None
        u = zaic_peak_on_axis(axis, summit, p.peakwidth, p.basewidth, p.summitdelta)
        return Objective.over(ctx.domain, ("course",), u)
