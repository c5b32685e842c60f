"""A proportional pMarinePID-style controller for the kinematic (uSimMarine) vehicle.

thrust = desired_speed * speed_factor (pMarinePID SPEED_FACTOR, 20 by default, matching
uSimMarine's thrust_factor), rudder = K_h * heading error (deg), elevator = K_d * depth
error (m), all clipped to MOOS percent ranges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.frames import heading_deg_from_yaw, wrap_180


@dataclass(frozen=True)
class MarinePidGains:
    heading: float = 1.2  # rudder percent per degree (pMarinePID yaw_pid_kp in examples)
    speed_factor: float = 20.0  # thrust percent per m/s
    depth: float = 50.0  # elevator percent per metre


@dataclass(frozen=True)
class MarinePidController:
    gains: MarinePidGains

    def inputs(self, x: NDArray, desired_heading_deg: float, desired_speed: float,
               desired_depth: float) -> NDArray:
        error = float(wrap_180(desired_heading_deg - heading_deg_from_yaw(x[3])))
        thrust = desired_speed * self.gains.speed_factor
        rudder = self.gains.heading * error
        elevator = self.gains.depth * (desired_depth - x[2])
        return np.clip(np.array([thrust, rudder, elevator]), -100.0, 100.0)
