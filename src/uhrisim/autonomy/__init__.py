"""Autonomy: a MOOS-IvP style behavior-fusion helm, contact manager and ``.bhv`` loader.

Vocabulary and frames are MOOS's (x east, y north, compass degrees, depth down); see
reference/helm.md and docs/conventions.md. Typical use::

    cfg = HelmConfig.from_bhv_file("meta_vehicle.bhv", known_vars=cm_cfg.alert_vars)
    helm = Helm(cfg, "videoray")
    out = helm.step(t, {"NAV_X": 0.0, "NAV_Y": 0.0, "NAV_HEADING": 180.0, ...})
"""

from __future__ import annotations

from uhrisim.autonomy.behaviors import OwnNav
from uhrisim.autonomy.bhv import load_bhv, parse_bhv
from uhrisim.autonomy.config import BehaviorSpec, HelmConfig
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
from uhrisim.autonomy.helm import Decision, Helm, HelmOutput

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
    "NodeReport",
    "Objective",
    "OwnNav",
    "format_node_report",
    "load_bhv",
    "parse_bhv",
    "parse_node_report",
]
