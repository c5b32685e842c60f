"""Diver heading/speed/depth control: proportional on the leg inputs u_l, u_r (paper VI).

The heading error (wrapped, radians) sets a yaw rate ``K_h * e``; the commanded swim speed
is the common part of u_l and u_r and the yaw rate their difference (inverse of eqs
10-12). Vertical rate is proportional to the depth error. Saturation happens in the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numpy.typing import NDArray

from uhrisim.dynamics.diver import DiverParams, leg_inputs


@dataclass(frozen=True)
class DiverGains:
    """K_h in (rad/s) per rad of heading error; K_z in (m/s) per metre of depth error."""

    heading: float = 1.0
    depth: float = 0.5

    def __post_init__(self) -> None:
        if self.heading < 0.0 or self.depth < 0.0:
            raise ValueError("DiverGains must be >= 0")


@dataclass(frozen=True)
class DiverController:
    gains: DiverGains
    params: DiverParams

    def inputs(self, x: NDArray, desired_heading_deg: float, desired_speed: float,
               desired_depth: float) -> NDArray:
        heading_error = math.remainder(math.radians(desired_heading_deg) - x[3], math.tau)
        yaw_rate = self.gains.heading * heading_error
        vertical = self.gains.depth * (desired_depth - x[2])
        return leg_inputs(desired_speed, yaw_rate, vertical, self.params)
