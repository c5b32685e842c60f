"""Shared machinery of contact behaviors (IvP ``IvPContactBehavior``).

Parameters: ``contact`` (name as in its NODE_REPORT), ``extrapolate`` (default true),
``decay = start,end`` (s), ``on_no_contact_ok`` (default true: a missing contact is a
``BHV_WARNING``; false a ``BHV_ERROR``), ``no_alert_request`` (whether a template asks
pContactMgrV20 for its alert with ``BCM_ALERT_REQUEST``: accepted, not modelled - in a
uhrisim scenario the contact manager's alerts are the scenario's ``contacts.alerts``).

The contact is where its last report put it: pHelmIvP dead-reckons no contact (its
extrapolation is compiled out, IvPContactBehavior.cpp:568-591, and the helm's contact
ledger never switches its own on, ContactLedger.cpp:43), so ``extrapolate`` and ``decay``
are accepted as pHelmIvP accepts them; ``extrapolate = false`` only stops Trail matching
the contact's speed. A contact too old for the helm's ledger is gone (:mod:`helm`).
"""

from __future__ import annotations

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext, ContactInfo
from uhrisim.autonomy.cpa import CpaGrid
from uhrisim.autonomy.domain import Domain
from uhrisim.autonomy.params import setter, to_bool, to_decay, to_str

CONTACT_HANDLERS = {
    "contact": setter("contact", to_str),
    "extrapolate": setter("extrapolate", to_bool),
    "decay": setter("decay", to_decay),
    "on_no_contact_ok": setter("on_no_contact_ok", to_bool),
    "no_alert_request": setter("no_alert_request", to_bool),
}


class ContactBehavior(Behavior):
    CONTACT_BASED = True

    def cpa_grid(self, domain: Domain) -> CpaGrid:
        """Own-ship velocities over the domain's course x speed grid (built once per domain)."""
        memo = getattr(self, "_cpa_grid", None)
        if memo is None or (memo[0] is not domain and memo[0] != domain):
            grid = CpaGrid.over(domain.axis("course").values, domain.axis("speed").values)
            memo = self._cpa_grid = (domain, grid)
        return memo[1]

    def track(self, ctx: BehaviorContext) -> ContactInfo | None:
        """The contact as last reported, or None: with no contact named, silently while
        ``on_no_contact_ok``; with a named contact the ledger lacks, a BHV_WARNING - or a
        BHV_ERROR, which halts the helm's iteration, when not ``on_no_contact_ok``
        (IvPContactBehavior.cpp:514-541)."""
        p = self.params
        if not p.contact:
            if not p.on_no_contact_ok:
                ctx.post("BHV_ERROR", f"{self.name}: contact IDX not set.")
            return None
        info = ctx.contact(p.contact)
        if info is None:
            msg = f"{self.name}: {p.contact} x/y/heading/speed info not found"
            ctx.post("BHV_WARNING" if p.on_no_contact_ok else "BHV_ERROR", msg)
        return info
