"""A minimal kinematic vehicle that follows DESIRED_* (first-order speed, rate-limited
turns and dives) and reports NAV_*: what the helm tests fly their helms on
(tests/integration/test_helm_behaviors.py, tests/integration/test_helm_paper_mission.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


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
            self.heading = (
                self.heading + np.clip(err, -self.turn_rate * dt, self.turn_rate * dt)
            ) % 360.0
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
