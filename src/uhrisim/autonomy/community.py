"""One vehicle's autonomy stack: contact manager + helm, stepped together.

Order inside a step (as in a MOOS community where pBasicContactMgr and pHelmIvP share a
MOOSDB, with the manager's postings delivered to the helm in the same tick): node
reports -> contact manager (alerts, relays) -> helm mail (NAV_*, NODE_REPORTs, the
manager's postings, any extra mail such as viewer buttons) -> helm iteration.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

from uhrisim.autonomy.behaviors.base import OwnNav
from uhrisim.autonomy.config import HelmConfig
from uhrisim.autonomy.contacts import (
    ContactManager,
    ContactManagerConfig,
    NodeReport,
    parse_node_report,
)
from uhrisim.autonomy.helm import Helm, HelmOutput, add_mail

__all__ = ["VehicleAutonomy"]


class VehicleAutonomy:
    """Helm and contact manager of the vehicle ``name`` (MOOS frame, see helm.py)."""

    def __init__(
        self,
        name: str,
        helm_config: HelmConfig,
        contact_config: ContactManagerConfig | None = None,
    ) -> None:
        self.name = name
        self.helm = Helm(helm_config, name)
        self.contacts = ContactManager(contact_config or ContactManagerConfig(), name)
        self.last_contact_posts: list[tuple[str, str]] = []

    def step(
        self,
        t: float,
        nav: OwnNav,
        node_reports: Sequence[str | NodeReport] = (),
        extra_mail: Mapping[str, object] | Iterable[tuple[str, object]] | None = None,
    ) -> HelmOutput:
        """One helm tick at ``t`` (s): returns the helm's output; the contact manager's
        postings of this tick are in ``last_contact_posts``."""
        # parsed once, here, for both the contact manager and the helm
        reports = [parse_node_report(r) if isinstance(r, str) else r for r in node_reports]
        for r in reports:
            self.contacts.on_node_report(r, t)
        self.last_contact_posts = self.contacts.step(t, nav)
        mail: dict[str, object] = nav.mail()  # a new dict: the mail is added to it
        if reports:
            mail["NODE_REPORT"] = reports
        add_mail(mail, self.last_contact_posts)
        if extra_mail:
            add_mail(mail, extra_mail.items() if isinstance(extra_mail, Mapping) else extra_mail)
        return self.helm.step(t, mail)
