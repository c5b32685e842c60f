"""Shared machinery of contact behaviors (IvP ``IvPContactBehavior``).

Parameters: ``contact`` (name as in its NODE_REPORT), ``extrapolate`` (default true),
``decay = start,end`` (s, default 5,10), ``on_no_contact_ok`` (default true: a missing
contact is silent; false posts ``BHV_ERROR``). A contact whose dead reckoning has decayed
fully ("decay maxed") gets no function (reference/helm.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext, ContactInfo
from uhrisim.autonomy.cpa import CpaGrid
from uhrisim.autonomy.domain import Domain
from uhrisim.autonomy.extrapolator import Extrapolated, LinearExtrapolator
from uhrisim.autonomy.params import setter, to_bool, to_decay, to_str

CONTACT_HANDLERS = {
    "contact": setter("contact", to_str),
    "extrapolate": setter("extrapolate", to_bool),
    "decay": setter("decay", to_decay),
    "on_no_contact_ok": setter("on_no_contact_ok", to_bool),
}


@dataclass(frozen=True)
class ContactTrack:
    """Contact as reported and its dead-reckoned position now."""

    info: ContactInfo
    now: Extrapolated

    @property
    def x(self) -> float:
        return self.now.x

    @property
    def y(self) -> float:
        return self.now.y


class ContactBehavior(Behavior):
    CONTACT_BASED = True

    def cpa_grid(self, domain: Domain) -> CpaGrid:
        """Own-ship velocities over the domain's course x speed grid (built once per domain)."""
        memo = getattr(self, "_cpa_grid", None)
        if memo is None or (memo[0] is not domain and memo[0] != domain):
            grid = CpaGrid.over(domain.axis("course").values, domain.axis("speed").values)
            memo = self._cpa_grid = (domain, grid)
        return memo[1]

    def track(self, ctx: BehaviorContext) -> ContactTrack | None:
        p = self.params
        if not p.contact:
            ctx.post("BHV_ERROR", f"{self.name}: no contact given")
            return None
        info = ctx.contact(p.contact)
        if info is None:
            if not p.on_no_contact_ok:
                ctx.post("BHV_ERROR", f"{self.name}: no information on contact {p.contact}")
            return None
        ex = LinearExtrapolator(*p.decay) if p.extrapolate else None
        now = info.extrapolate(ex, ctx.t)
        if now.decay_maxed:
            ctx.post("BHV_WARNING", f"{self.name}: contact {p.contact} report too old")
            return None
        return ContactTrack(info, now)
