"""BHV_ConstantDepth: hold a depth (subdomain: depth).

Objective: ZAIC peak at ``depth`` with IvP defaults peakwidth 3 m, basewidth 100 m,
summitdelta 50 (docs/reference/helm.md); no normalisation (BHV_ConstantDepth.cpp:112-120). The
depth can follow another vehicle through ``updates`` postings such as ``depth=3.2``.

Its ``duration`` defaults to 0, as in pHelmIvP ("we force the user to provide a duration
value otherwise it will timeout immediately", BHV_ConstantDepth.cpp:56-60): without
``duration = no-time-limit`` (or a time) it completes at its first running iteration.
``depth`` below 0 is taken as 0 and ``summitdelta`` is clipped to [0, 100] (l.73-96).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.params import setter, to_float, to_summitdelta
from uhrisim.autonomy.zaic import zaic_peak_on_axis


@dataclass(frozen=True)
class ConstantDepthParams:
    """BHV_ConstantDepth parameters: ``depth`` m (positive down); ZAIC ``peakwidth``,
    ``basewidth`` m and ``summitdelta`` (utility) with IvP's defaults (docs/reference/helm.md).
    """

    depth: float = 0.0
    peakwidth: float = 3.0
    basewidth: float = 100.0
    summitdelta: float = 50.0


def _depth(v: object, key: str, where: str) -> float:
    return max(to_float(v, key, where), 0.0)


class ConstantDepth(Behavior):
    KIND = "BHV_ConstantDepth"
    Params = ConstantDepthParams
    DEFAULT_DURATION = 0.0
    HANDLERS: ClassVar[dict] = {
        "depth": setter("depth", _depth),
        "summitdelta": setter("summitdelta", to_summitdelta),
        **{k: setter(k, to_float) for k in ("peakwidth", "basewidth")},
    }

    def reset(self) -> None:
        self._memo: tuple[object, Objective] | None = None

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: ConstantDepthParams = self.params
        key = (ctx.domain, p)  # the function depends on nothing else: reuse it
        if self._memo is not None and self._memo[0] == key:
            return self._memo[1]
        u = zaic_peak_on_axis(
            ctx.domain.axis("depth"), p.depth, p.peakwidth, p.basewidth, p.summitdelta
        )
        u.flags.writeable = False
        obj = Objective.over(ctx.domain, ("depth",), u, (float(u.min()), float(u.max())))
        self._memo = (key, obj)
        return obj
