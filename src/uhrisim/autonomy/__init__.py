"""Autonomy: a MOOS-IvP style behavior-fusion helm, contact manager and ``.bhv`` loader.

Vocabulary and frames are MOOS's (x east, y north, compass degrees, depth down); see
docs/reference/helm.md and docs/conventions.md. One community per vehicle, each helm tick::

    cm_cfg = ContactManagerConfig.from_mapping({"alerts": [...], "relays": [...]})
    cfg = load_bhv("meta_vehicle.bhv", known_vars=cm_cfg.alert_vars, domain=parse_domain(
        ["course:0:359:360", "speed:0:5:26", "depth:0:100:101:optional"]))
    #  or load_helm_from_moos("mission.moos")    (a MOOS mission's pHelmIvP block)
    #  or HelmConfig.from_mapping(scenario["helm"], "scenario.yaml:helm", cm_cfg.alert_vars)
    helm, cm = Helm(cfg, "videoray"), ContactManager(cm_cfg, "videoray")

    alerts = cm.step(t, own_nav, node_reports_of_others)        # [(var, value), ...]
    nav = {"NAV_X": x_east, "NAV_Y": y_north, "NAV_HEADING": hdg_deg, "NAV_SPEED": v,
           "NAV_DEPTH": z, "NODE_REPORT": node_reports_of_others}
    mail = as_mail(alerts, base=nav)   # repeated variables become lists, applied in order
    out = helm.step(t, mail)   # out.decision (heading_deg, speed, depth|None) or None
    #  or helm.step(t, [(var, value, moos_time), ...])   (mail as MOOS delivers it)
                               # out.posts, out.contributions, out.total, out.mode, ...

:class:`VehicleAutonomy` does exactly this in one call: ``out = auto.step(t,
OwnNav.from_ned(north, east, down, yaw, speed), reports)``; ``out.decision.yaw_rad``.
:mod:`uhrisim.autonomy.missions` holds the paper's diver and ROV helms in mapping form.
"""

from __future__ import annotations

from uhrisim.autonomy.behaviors import OwnNav
from uhrisim.autonomy.bhv import load_bhv, parse_bhv
from uhrisim.autonomy.community import VehicleAutonomy
from uhrisim.autonomy.config import BehaviorSpec, HelmConfig, HelmSettings, parse_domain
from uhrisim.autonomy.contacts import (
    AlertSpec,
    ContactManager,
    ContactManagerConfig,
    ContactRecord,
    NodeReport,
    format_node_report,
    parse_node_report,
)
from uhrisim.autonomy.domain import Domain, DomainAxis, Objective
from uhrisim.autonomy.helm import Decision, Helm, HelmOutput, Posting, as_mail
from uhrisim.autonomy.moos_file import load_helm_from_moos, load_moos

__all__ = [
    "AlertSpec",
    "BehaviorSpec",
    "ContactManager",
    "ContactManagerConfig",
    "ContactRecord",
    "Decision",
    "Domain",
    "DomainAxis",
    "Helm",
    "HelmConfig",
    "HelmOutput",
    "HelmSettings",
    "NodeReport",
    "Objective",
    "OwnNav",
    "Posting",
    "VehicleAutonomy",
    "as_mail",
    "format_node_report",
    "load_bhv",
    "load_helm_from_moos",
    "load_moos",
    "parse_bhv",
    "parse_domain",
    "parse_node_report",
]
