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

from uhrisim.core.lazy import lazy_exports

#: Each exported name -> its module (imported at first use: a scenario's declarations read
#: a few of them without the whole helm).
_HOMES = {
    "OwnNav": "behaviors", "load_bhv": "bhv", "parse_bhv": "bhv",
    "VehicleAutonomy": "community",
    "BehaviorSpec": "config", "HelmConfig": "config", "HelmSettings": "config",
    "parse_domain": "config",
    "AlertSpec": "contacts", "ContactManager": "contacts", "ContactManagerConfig": "contacts",
    "ContactRecord": "contacts", "NodeReport": "contacts", "format_node_report": "contacts",
    "parse_node_report": "contacts",
    "Domain": "domain", "DomainAxis": "domain", "Objective": "domain",
    "Decision": "helm", "Helm": "helm", "HelmOutput": "helm", "Posting": "helm",
    "as_mail": "helm",
    "load_helm_from_moos": "moos_file", "load_moos": "moos_file",
}

__all__ = sorted(_HOMES)
__getattr__ = lazy_exports(__name__, _HOMES)
