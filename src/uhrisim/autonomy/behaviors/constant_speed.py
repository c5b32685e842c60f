"""BHV_ConstantSpeed: hold a speed (subdomain: speed).

As pHelmIvP's (MOOS-IvP lib_behaviors-marine/BHV_ConstantSpeed.cpp): a ZAIC peak at
``speed`` (m/s, clipped at 0 as IvP does) with peakwidth 0, basewidth 0.2 and summitdelta
0 by default; ``speed_mismatch_var`` posts |NAV_SPEED − speed| each tick. Its
``duration`` defaults to 0, as ConstantDepth's: give ``duration = no-time-limit``. With
``speed = 0`` it holds a vehicle still while another behavior turns it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.params import (
    setter,
    to_clipped_non_negative,
    to_str,
    to_summitdelta,
)
from uhrisim.autonomy.zaic import zaic_peak_on_axis


@dataclass(frozen=True)
class ConstantSpeedParams:
    """BHV_ConstantSpeed parameters (IvP names and defaults; module docstring)."""

    speed: float = 0.0
    peakwidth: float = 0.0
    basewidth: float = 0.2
    summitdelta: float = 0.0
    speed_mismatch_var: str = ""


class ConstantSpeed(Behavior):
    KIND = "BHV_ConstantSpeed"
    Params = ConstantSpeedParams
    DEFAULT_DURATION = 0.0
    HANDLERS: ClassVar[dict] = {
        "speed": setter("speed", to_clipped_non_negative),
        "peakwidth": setter("peakwidth", to_clipped_non_negative),
        "basewidth": setter("basewidth", to_clipped_non_negative),
        "summitdelta": setter("summitdelta", to_summitdelta),
        "speed_mismatch_var": setter("speed_mismatch_var", to_str),
    }

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: ConstantSpeedParams = self.params
        if p.speed_mismatch_var and ctx.own is not None:
            ctx.post(p.speed_mismatch_var, abs(ctx.own.speed - p.speed))
        u = zaic_peak_on_axis(ctx.domain.axis("speed"), p.speed, p.peakwidth, p.basewidth,
                              p.summitdelta)
        return Objective.over(ctx.domain, ("speed",), u)
