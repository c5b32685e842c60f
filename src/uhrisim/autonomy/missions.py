"""The paper's mission helms in the scenario mapping form (docs/reference/helm.md, "The paper's
mission"), ready for :meth:`HelmConfig.from_mapping` and
:meth:`ContactManagerConfig.from_mapping`.

Diver: ConstantDepth + Loiter around a radius-20 m octagon (vertices at bearings
22.5 + 45 k) centred at ``loiter_center``. ROV (videoray): ConstantDepth whose depth follows
the diver's (contact-manager relay ``DEPTH_UPDATES = depth=$[DEP]``), Trail (180 deg, 2 m,
the paper's text) and AvoidCollision, both spawned per contact from the contact manager's
alerts TRAIL_INFO / CONTACT_INFO, under the authors' mode tree
``MODE = ACTIVE{DEPLOY=true} INACTIVE`` with children STATION-KEEPING, RETURNING, TRAILING
(else LOITERING). Viewer buttons post DEPLOY, RETURN, TRAIL, STATION_KEEP.

Scenario knobs (our choices, stated): AvoidCollision distances are the authors' values
scaled for a 2 m trail (outer 3, inner 1, min 0.8, max 1.5, completed 40 m); Trail radius
0.2 m and nm_radius 5 m; the ROV's speed grid is 0 .. 2 m/s by 0.02 because with the
paper's 0.2 m/s grid Trail's along-track dead band, (dv/2) nm_radius / (0.5 v_c), is
~2.5 m for a 0.4 m/s diver (see tests/integration/test_helm_paper_mission.py).
"""

from __future__ import annotations

import copy
from typing import Any

__all__ = ["paper_diver_helm", "paper_rov_contacts", "paper_rov_helm"]


def paper_diver_helm(
    loiter_center: tuple[float, float] = (10.0, -20.0), depth: float = 3.0, speed: float = 0.5
) -> dict[str, Any]:
    """Diver helm mapping: ConstantDepth + octagon Loiter (x east, y north, metres)."""
    cx, cy = loiter_center
    return {
        "initialize": {"DEPLOY": "true"},
        "behaviors": [
            {"type": "ConstantDepth", "name": "depth", "depth": depth,
             "duration": "no-time-limit", "condition": "DEPLOY = true"},
            {"type": "Loiter", "name": "loiter", "speed": speed, "condition": "DEPLOY = true",
             "polygon": f"format=radial, x={cx:g}, y={cy:g}, radius=20, pts=8",
             "slip_radius": 4},
        ],
    }  # fmt: skip


_ROV: dict[str, Any] = {
    "domain": {"course": [0, 359, 360], "speed": [0, 2, 101], "depth": [0, 100, 101, "optional"]},
    "initialize": {"DEPLOY": "true", "RETURN": "false", "STATION_KEEP": "false", "TRAIL": "true"},
    "modes": [
        "MODE = ACTIVE { DEPLOY = true } INACTIVE",
        "MODE = STATION-KEEPING { MODE = ACTIVE ; STATION_KEEP = true }",
        "MODE = RETURNING { MODE = ACTIVE ; RETURN = true }",
        "MODE = TRAILING { MODE = ACTIVE ; TRAIL = true } LOITERING",
    ],
    "behaviors": [
        {"type": "ConstantDepth", "name": "depth", "depth": 0, "condition": "MODE == ACTIVE",
         "duration": "no-time-limit", "updates": "DEPTH_UPDATES"},
        {"type": "Trail", "name": "trail_", "pwt": 300, "condition": "MODE == TRAILING",
         "templating": "spawn", "updates": "TRAIL_INFO", "trail_range": 2, "trail_angle": 180,
         "radius": 0.2, "nm_radius": 5},
        {"type": "AvoidCollision", "name": "avd_", "pwt": 200, "condition": "MODE == ACTIVE",
         "templating": "spawn", "updates": "CONTACT_INFO", "pwt_outer_dist": 3,
         "pwt_inner_dist": 1, "completed_dist": 40, "min_util_cpa_dist": 0.8,
         "max_util_cpa_dist": 1.5},
        {"type": "Loiter", "name": "loiter", "condition": "MODE == LOITERING", "speed": 0.5,
         "polygon": "format=radial, x=0, y=-10, radius=10, pts=8"},
        {"type": "Waypoint", "name": "return", "condition": "MODE == RETURNING",
         "points": "0,0", "speed": 1.0, "capture_radius": 1, "slip_radius": 3,
         "perpetual": True, "endflag": ["RETURN = false", "STATION_KEEP = true"]},
        {"type": "StationKeep", "name": "station", "condition": "MODE == STATION-KEEPING",
         "center_activate": True, "inner_radius": 1, "outer_radius": 5, "outer_speed": 0.5,
         "transit_speed": 1.0},
    ],
}  # fmt: skip

_ROV_CONTACTS: dict[str, Any] = {
    "alerts": [
        {"id": "trail", "var": "TRAIL_INFO", "alert_range": 100},
        {"id": "avd", "var": "CONTACT_INFO", "alert_range": 20},
    ],
    "relays": [{"var": "DEPTH_UPDATES", "pattern": "depth=$[DEP]", "contact": "diver"}],
}


def paper_rov_helm() -> dict[str, Any]:
    """ROV (videoray) helm mapping (a fresh copy)."""
    return copy.deepcopy(_ROV)


def paper_rov_contacts() -> dict[str, Any]:
    """ROV contact-manager mapping: trail/avoid alerts and the diver-depth relay."""
    return copy.deepcopy(_ROV_CONTACTS)
