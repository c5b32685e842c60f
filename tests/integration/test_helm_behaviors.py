"""Closed-loop behavior tests: the helm drives a tiny kinematic vehicle.

Vehicle (written here, first principles): heading turns toward DESIRED_HEADING at most
``turn_rate`` deg/s (the short way), speed relaxes first-order (time constant ``tau``) to
DESIRED_SPEED, depth moves toward DESIRED_DEPTH at most ``dive_rate`` m/s. Integration at
0.1 s; the helm runs at 4 Hz (on the first 0.1 s tick at or after each multiple of 0.25 s).
Positions in MOOS local coordinates (x east, y north), compass headings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from uhrisim.autonomy import Helm, HelmConfig, format_node_report, NodeReport, load_bhv
from uhrisim.autonomy.geometry import parse_polygon

DATA = __import__("pathlib").Path(__file__).resolve().parents[1] / "data" / "helm"
ALERT_VARS = ("TRAIL_INFO", "CONTACT_INFO", "DEPTH_UPDATES", "LOITER_UPDATES")


@dataclass
class Kinematic:
    x: float
    y: float
    heading: float
    speed: float = 0.0
    depth: float = 0.0
    turn_rate: float = 30.0
    tau: float = 1.0
    dive_rate: float = 0.5
    v_max: float = 2.0
    desired: dict = field(default_factory=dict)

    def step(self, dt: float) -> None:
        if "DESIRED_HEADING" in self.desired:
            err = (self.desired["DESIRED_HEADING"] - self.heading + 180.0) % 360.0 - 180.0
            self.heading = (self.heading + np.clip(err, -self.turn_rate * dt, self.turn_rate * dt)) % 360.0
        v_cmd = min(float(self.desired.get("DESIRED_SPEED", 0.0)), self.v_max)
        self.speed += (v_cmd - self.speed) * (1.0 - math.exp(-dt / self.tau))
        if "DESIRED_DEPTH" in self.desired:
            dz = self.desired["DESIRED_DEPTH"] - self.depth
            self.depth += float(np.clip(dz, -self.dive_rate * dt, self.dive_rate * dt))
        h = math.radians(self.heading)
        self.x += self.speed * math.sin(h) * dt
        self.y += self.speed * math.cos(h) * dt

    def nav(self) -> dict:
        return {
            "NAV_X": self.x,
            "NAV_Y": self.y,
            "NAV_HEADING": self.heading,
            "NAV_SPEED": self.speed,
            "NAV_DEPTH": self.depth,
        }


def run(helm, veh, t_end, contact=None, contact_name="diver", events=None, on_tick=None):
    """Integrate to ``t_end``; ``contact(t) -> (x, y, hdg, spd)``; ``events``: {t: mail}."""
    events = dict(events or {})
    outs = []
    n = int(round(t_end / 0.1))
    last_slot = -1
    for k in range(n + 1):
        t = k * 0.1
        slot = (2 * k) // 5
        if slot != last_slot:
            last_slot = slot
            mail = veh.nav()
            if contact is not None:
                cx, cy, ch, cv = contact(t)
                mail["NODE_REPORT"] = format_node_report(
                    NodeReport(contact_name, cx, cy, cv, ch, 0.0, time=t)
                )
            for te in [te for te in events if te <= t + 1e-9]:
                mail.update(events.pop(te))
            out = helm.step(t, mail)
            veh.desired.update(
                {k2: v for k2, v in out.posts if k2.startswith("DESIRED_")}
            )
            outs.append((t, veh.x, veh.y, veh.heading, veh.speed, veh.depth, out))
            if on_tick is not None:
                on_tick(t, veh, out)
        veh.step(0.1)
    return outs
