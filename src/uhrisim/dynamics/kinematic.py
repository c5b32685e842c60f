"""A kinematic vehicle with MOOS uSimMarine semantics: what the authors' demo really ran.

In the paper's mission files both the diver and the ROV were moved by uSimMarine driven
by pMarinePID (docs/reference/vehicles-and-control.md, "What the authors' demo actually
ran"). Offering it beside the hydrodynamic model lets a user compare the two.

State ``[x_north, y_east, z_down, psi, speed]`` (NED m, compass yaw rad, m/s); input
``[thrust, rudder, elevator]`` in MOOS percent: thrust -100..100, rudder -100..100
(> 0 turns to starboard), elevator -100..100 (> 0 dives). Unlike the ODE models this is
a discrete-time update, exactly like uSimMarine's ``SimEngine``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

STATE_SIZE = 5


@dataclass(frozen=True)
class KinematicParams:
    """uSimMarine defaults (MOOS-IvP r5969): thrust_factor 20, turn_rate 70, max decel 0.5."""

    thrust_factor: float = 20.0  # percent thrust per m/s of target speed
    turn_rate: float = 70.0  # deg/s scale of the rudder at 50 % thrust
    rudder_speed_loss: float = 0.85  # fraction of speed lost at full rudder
    max_acceleration: float = 0.0  # m/s^2; 0 = reach the target speed at once
    max_deceleration: float = 0.5  # m/s^2; 0 = reach the target speed at once
    max_depth_rate: float = 0.5  # m/s at full elevator
    max_depth_rate_speed: float = 2.0  # m/s; slower vehicles dive proportionally slower

    def __post_init__(self) -> None:
        if not self.thrust_factor > 0.0:
            raise ValueError("KinematicParams.thrust_factor must be positive")
        if self.max_acceleration < 0.0 or self.max_deceleration < 0.0:
            raise ValueError("KinematicParams acceleration limits must be >= 0")


def kinematic_step(x: ArrayLike, u: ArrayLike, params: KinematicParams, dt: float) -> NDArray:
    """Advance the uSimMarine-like state by ``dt`` seconds with command ``u`` held."""
    north, east, depth, psi, speed = np.asarray(x, dtype=float)
    thrust, rudder, elevator = np.clip(np.asarray(u, dtype=float), -100.0, 100.0)
    p = params

    target = thrust / p.thrust_factor * (1.0 - p.rudder_speed_loss * abs(rudder) / 100.0)
    if target > speed:
        new_speed = min(target, speed + p.max_acceleration * dt) if p.max_acceleration else target
    else:
        new_speed = max(target, speed - p.max_deceleration * dt) if p.max_deceleration else target

    turn_deg = rudder * (p.turn_rate / 100.0) * dt * (1.0 + (thrust - 50.0) / 50.0)
    new_psi = psi + np.radians(turn_deg)

    mean_speed = 0.5 * (speed + new_speed)
    mean_psi = np.arctan2(np.sin(psi) + np.sin(new_psi), np.cos(psi) + np.cos(new_psi))
    ratio = min(1.0, abs(mean_speed) / p.max_depth_rate_speed)
    new_depth = depth + elevator / 100.0 * p.max_depth_rate * ratio * dt
    return np.array([
        north + mean_speed * np.cos(mean_psi) * dt,
        east + mean_speed * np.sin(mean_psi) * dt,
        new_depth,
        (new_psi + np.pi) % (2.0 * np.pi) - np.pi,
        new_speed,
    ])
