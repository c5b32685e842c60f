"""BHV_MaxSpeed: a ceiling on the speed (subdomain: speed).

As pHelmIvP's (MOOS-IvP lib_behaviors-marine/BHV_MaxSpeed.cpp): a ZAIC_LEQ with its summit
at ``max_speed`` (m/s, default 1) — full utility at or below it, falling to zero over
``basewidth`` (m/s, default 0.5; ``tolerance`` is another name for it) above (both
clipped at 0, as IvP does); with a high
priority the fused decision stays at or under the ceiling. ``speed_slack_var`` posts
max_speed − NAV_SPEED each tick. An assistant lowers the ceiling near a diver through
``updates`` such as ``max_speed=0.25``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.params import setter, to_clipped_non_negative, to_str
from uhrisim.autonomy.zaic import zaic_leq


@dataclass(frozen=True)
class MaxSpeedParams:
    """BHV_MaxSpeed parameters (IvP names and defaults; module docstring)."""

    max_speed: float = 1.0
    basewidth: float = 0.5
    speed_slack_var: str = ""


class MaxSpeed(Behavior):
    KIND = "BHV_MaxSpeed"
    Params = MaxSpeedParams
    HANDLERS: ClassVar[dict] = {
        "max_speed": setter("max_speed", to_clipped_non_negative),
        "basewidth": setter("basewidth", to_clipped_non_negative),
        "tolerance": setter("basewidth", to_clipped_non_negative),
        "speed_slack_var": setter("speed_slack_var", to_str),
    }

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: MaxSpeedParams = self.params
        if p.speed_slack_var and ctx.own is not None:
            ctx.post(p.speed_slack_var, p.max_speed - ctx.own.speed)
        u = zaic_leq(ctx.domain.axis("speed").values, p.max_speed, p.basewidth)
        return Objective.over(ctx.domain, ("speed",), u)
