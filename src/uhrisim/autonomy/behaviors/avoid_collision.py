"""BHV_AvoidCollision: keep the closest point of approach to a contact large.

reference/helm.md. Relevance r grades from 0 at ``pwt_outer_dist`` to 1 at
``pwt_inner_dist`` (pct = (outer - range)/(outer - inner); linear: pct, quadratic: pct^2,
quasi: pct^1.5); the helm weight this tick is ``priority * r`` (dropped at 0). Utility from
the CPA over ``time_on_leg`` (120 s) for each candidate course x speed: 0 for
cpa < min_util_cpa_dist, 100 for cpa >= max_util_cpa_dist, 25 -> 100 linearly between;
if the current range is already inside min_util_cpa_dist, range/2 is used as the min.
Completed (endflags; a spawned instance is removed) beyond ``completed_dist``.

Defaults (IvP): outer 200, inner 50, completed 500, min 10, max 75, grade quasi.
Authors' mission: outer 50, inner 20, completed 75, min 8, max 25, priority 200.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from uhrisim.autonomy.behaviors.base import BehaviorContext
from uhrisim.autonomy.behaviors.contact_base import CONTACT_HANDLERS, ContactBehavior
from uhrisim.autonomy.cpa import cpa_distance
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import distance
from uhrisim.autonomy.params import one_of, setter, to_float


def relevance(range_m: float, outer: float, inner: float, grade: str) -> float:
    """0 at/after ``outer``, 1 at/inside ``inner``, graded between (see module docstring)."""
    if range_m >= outer:
        return 0.0
    if range_m <= inner or outer <= inner:
        return 1.0
    pct = (outer - range_m) / (outer - inner)
    return pct * pct if grade == "quadratic" else pct**1.5 if grade == "quasi" else pct


def cpa_utility(cpa: np.ndarray, min_util: float, max_util: float) -> np.ndarray:
    """0 below ``min_util``, 100 above ``max_util``, 25 -> 100 linearly from min to max
    (IvP ``AOF_AvoidCollision::metric``: exactly at min the value is 25)."""
    span = max(max_util - min_util, 1e-9)
    u = cpa - min_util
    u *= 75.0 / span
    u += 25.0
    np.clip(u, 25.0, 100.0, out=u)
    u[cpa < min_util] = 0.0
    return u


def cpa_utility_inplace(cpa: np.ndarray, min_util: float, max_util: float) -> np.ndarray:
    """:func:`cpa_utility` computed in ``cpa``'s own storage (same operations; returns it)."""
    span = max(max_util - min_util, 1e-9)
    keep = cpa >= min_util  # cpa is never NaN: the complement of cpa < min_util
    u = cpa
    u -= min_util
    u *= 75.0 / span
    u += 25.0
    np.maximum(u, 25.0, out=u)
    np.minimum(u, 100.0, out=u)
    u *= keep  # x 1.0 keeps u exactly, x 0.0 zeroes it (u in [25, 100])
    return u


@dataclass(frozen=True)
class AvoidCollisionParams:
    """BHV_AvoidCollision parameters (IvP names and defaults; module docstring).

    ``contact`` the NODE_REPORT name; ``decay`` the dead-reckoning decay (start, end), s;
    distances m; ``pwt_grade`` "linear" | "quadratic" | "quasi"; ``time_on_leg`` s.
    """

    contact: str = ""
    extrapolate: bool = True
    decay: tuple[float, float] = (5.0, 10.0)
    on_no_contact_ok: bool = True
    pwt_outer_dist: float = 200.0
    pwt_inner_dist: float = 50.0
    completed_dist: float = 500.0
    min_util_cpa_dist: float = 10.0
    max_util_cpa_dist: float = 75.0
    pwt_grade: str = "quasi"
    time_on_leg: float = 120.0


class AvoidCollision(ContactBehavior):
    KIND = "BHV_AvoidCollision"
    Params = AvoidCollisionParams
    HANDLERS: ClassVar[dict] = {
        **CONTACT_HANDLERS,
        **{
            k: setter(k, to_float)
            for k in (
                "pwt_outer_dist",
                "pwt_inner_dist",
                "completed_dist",
                "min_util_cpa_dist",
                "max_util_cpa_dist",
                "time_on_leg",
            )
        },
        "pwt_grade": setter("pwt_grade", one_of("linear", "quadratic", "quasi")),
    }

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: AvoidCollisionParams = self.params
        own = ctx.own
        tr = self.track(ctx)
        if own is None or tr is None:
            return None
        rng = distance(own.x, own.y, tr.x, tr.y)
        if rng > p.completed_dist:
            self.complete()
            return None
        self.priority_scale = relevance(rng, p.pwt_outer_dist, p.pwt_inner_dist, p.pwt_grade)
        if self.priority_scale <= 0.0:
            return None
        min_u = p.min_util_cpa_dist if rng > p.min_util_cpa_dist else rng / 2.0
        max_u = max(p.max_util_cpa_dist, min_u)
        cpa = self.cpa_grid(ctx.domain).distance(
            own.x, own.y, tr.x, tr.y, tr.info.heading, tr.info.speed, p.time_on_leg
        )
        u = cpa_utility_inplace(cpa, min_u, max_u)
        return Objective.over(ctx.domain, ("course", "speed"), u)

    def objective_reference(self, ctx: BehaviorContext) -> Objective | None:
        """:meth:`on_run`'s function from the plain :func:`cpa_distance` (tests only)."""
        p: AvoidCollisionParams = self.params
        own, tr = ctx.own, self.track(ctx)
        if own is None or tr is None:
            return None
        rng = distance(own.x, own.y, tr.x, tr.y)
        min_u = p.min_util_cpa_dist if rng > p.min_util_cpa_dist else rng / 2.0
        max_u = max(p.max_util_cpa_dist, min_u)
        crs, spd = ctx.domain.axis("course").values, ctx.domain.axis("speed").values
        cpa = cpa_distance(
            own.x, own.y, crs[:, None], spd[None, :],
            tr.x, tr.y, tr.info.heading, tr.info.speed, p.time_on_leg,
        )  # fmt: skip
        return Objective.over(ctx.domain, ("course", "speed"), cpa_utility(cpa, min_u, max_u))
