"""BHV_AvoidCollision: keep the closest point of approach to a contact large.

As pHelmIvP does it (MOOS-IvP ivp/src/lib_behaviors-marine/BHV_AvoidCollision.cpp,
AOF_AvoidCollision.cpp; docs/reference/helm.md):

* relevance r = pct, pct^2 or pct^1.5 (``pwt_grade`` linear, quadratic, quasi) with
  pct = (outer - range)/(outer - inner): 0 at and beyond ``pwt_outer_dist``, 1 at
  ``pwt_inner_dist`` and MORE than 1 inside it (not clamped, getRelevance l.484-497); the
  helm weight this tick is ``priority * r`` (no function at r <= 0);
* utility from the CPA over ``time_on_leg`` (120 s) for each candidate course x speed: 0
  for cpa < min_util_cpa_dist, 100 for cpa > max_util_cpa_dist, 25 -> 100 linearly
  between; with the range already at or inside min_util_cpa_dist, range/2 is the min
  (l.311-313); a min above max_util_cpa_dist is no function and a BHV_ERROR (the AOF
  refuses to initialise);
* the utility is built into 3 x 3-index linear pieces and normalised 0..100 (so the
  peak is 100 even when no candidate clears max_util_cpa_dist), as
  :func:`~uhrisim.autonomy.ivp_build.reflect` computes (l.292-293, 330-384);
* with a ``depth`` axis in the helm's domain an instance's first build yields nothing (its
  first reflector runs over course, speed AND depth, which the build pieces do not name;
  l.51-54, 315-331): one tick without a function, as in pHelmIvP;
* completed (endflags; a spawned instance is removed) once the range reaches 1.1 x
  ``completed_dist``, whether running or idle (l.211, 226, 275).

Defaults (IvP): outer 200, inner 50, completed 500, min 10, max 75, grade quasi.
Authors' mission: outer 50, inner 20, completed 75, min 8, max 25, priority 200.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from uhrisim.autonomy.behaviors.base import BehaviorContext, ContactInfo
from uhrisim.autonomy.behaviors.contact_base import CONTACT_HANDLERS, ContactBehavior
from uhrisim.autonomy.cpa import AvoidUtility, cpa_distance
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import distance
from uhrisim.autonomy.ivp_build import (
    fit_pieces_reference,
    normalize,
    reflect_cpa,
)
from uhrisim.autonomy.params import one_of, setter, to_float


def relevance(range_m: float, outer: float, inner: float, grade: str) -> float:
    """0 at/after ``outer``, 1 at ``inner``, graded between and beyond (module docstring)."""
    if range_m >= outer:
        return 0.0
    if outer <= inner:  # pHelmIvP divides by zero here; full relevance is the sane reading
        return 1.0
    pct = (outer - range_m) / (outer - inner)  # > 1 inside ``inner``: not clamped
    return pct * pct if grade == "quadratic" else pct**1.5 if grade == "quasi" else pct


PIECE = (3, 3)
"""Build pieces, grid indices (course, speed): ``uniform_piece = discrete @ course:3,speed:3``
(BHV_AvoidCollision.cpp:48)."""


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
    no_alert_request: bool = False  # IvP default (BHV_AvoidCollision.cpp:69)
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

    def reset(self) -> None:
        self.built_once = False

    def _range(self, ctx: BehaviorContext) -> tuple[float, ContactInfo] | None:
        """Range (m) to the contact and its track, or None with nothing to go on."""
        tr = self.track(ctx)
        if ctx.own is None or tr is None:
            return None
        return distance(ctx.own.x, ctx.own.y, tr.x, tr.y), tr

    def _cpa_bounds(self, rng: float, ctx: BehaviorContext) -> tuple[float, float] | None:
        """(collision, all-clear) CPA distances, m, or None (BHV_ERROR) when they cross."""
        p: AvoidCollisionParams = self.params
        collision = p.min_util_cpa_dist if rng > p.min_util_cpa_dist else rng / 2.0
        if collision > p.max_util_cpa_dist:
            ctx.post("BHV_ERROR", f"{self.name}: Unable to init AOF_AvoidCollision.")
            return None
        return collision, p.max_util_cpa_dist

    def on_idle(self, ctx: BehaviorContext) -> None:
        seen = self._range(ctx)
        if seen is not None and seen[0] >= 1.1 * self.params.completed_dist:
            self.complete()

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: AvoidCollisionParams = self.params
        seen = self._range(ctx)
        if seen is None:
            return None
        rng, tr = seen
        if rng >= 1.1 * p.completed_dist:
            self.complete()
            return None
        self.priority_scale = relevance(rng, p.pwt_outer_dist, p.pwt_inner_dist, p.pwt_grade)
        if self.priority_scale <= 0.0:
            return None
        bounds = self._cpa_bounds(rng, ctx)
        first_build, self.built_once = not self.built_once, True
        if bounds is None or (first_build and ctx.domain.has("depth")):
            return None
        own, grid = ctx.own, self.cpa_grid(ctx.domain)
        table, lo, hi = reflect_cpa(grid, own.x, own.y, tr.x, tr.y, tr.heading, tr.speed,
                                    p.time_on_leg, AvoidUtility(*bounds), PIECE)
        return Objective.over(ctx.domain, ("course", "speed"), table, (lo, hi))

    def objective_reference(self, ctx: BehaviorContext) -> Objective | None:
        """:meth:`on_run`'s function from the plain :func:`cpa_distance` and the reference
        fit (tests only; ignores the first-build rule)."""
        p: AvoidCollisionParams = self.params
        seen = self._range(ctx)
        bounds = None if seen is None else self._cpa_bounds(seen[0], ctx)
        if seen is None or bounds is None:
            return None
        own, tr = ctx.own, seen[1]
        crs, spd = ctx.domain.axis("course").values, ctx.domain.axis("speed").values
        cpa = cpa_distance(
            own.x, own.y, crs[:, None], spd[None, :],
            tr.x, tr.y, tr.heading, tr.speed, p.time_on_leg,
        )  # fmt: skip
        u = normalize(normalize(fit_pieces_reference(cpa_utility(cpa, *bounds), PIECE)))
        return Objective.over(ctx.domain, ("course", "speed"), u.table())
