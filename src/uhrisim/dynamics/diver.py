"""Human diver: differential-drive kinematics of the paper (eqs 10-13), decoupled heave.

State ``[x_north, y_east, z_down, psi]`` (NED m, compass yaw rad). Input
``[u_l, u_r, u_z]``: left/right "leg" rates and the vertical rate (m/s, down positive).
With wheel radius r and track L (paper: r = 1, L = 0.5):

    forward speed  s     = (r/2)(u_l + u_r)
    yaw rate       dpsi  = (r/L)(u_l - u_r)    (compass sign: a faster left leg turns right)

The paper writes dtheta/dt = (r/L)(u_r - u_l) with a counter-clockwise angle; compass yaw
is its mirror image (docs/conventions.md). Neutral buoyancy: no vertical motion without
u_z. Speed, turn rate and vertical rate saturate at human limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

STATE_SIZE = 4


@dataclass(frozen=True)
class DiverParams:
    """Paper's r and L; limits are realistic defaults for a recreational scuba diver.

    Swim speed 0.3-1.0 m/s (docs/reference/vehicles-and-control.md), turn rate ~30 deg/s,
    ascent/descent rate 0.3 m/s (18 m/min, the usual maximum safe ascent rate).
    """

    wheel_radius: float = 1.0  # paper eq 10-12, "r"
    track: float = 0.5  # paper eq 12, "L"
    max_speed: float = 1.0  # m/s
    max_reverse_speed: float = 0.2  # m/s (back-finning)
    max_turn_rate: float = np.radians(30.0)  # rad/s
    max_vertical_rate: float = 0.3  # m/s

    def __post_init__(self) -> None:
        for name in ("wheel_radius", "track", "max_speed", "max_turn_rate", "max_vertical_rate"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"DiverParams.{name} must be positive")


def body_rates(u: ArrayLike, params: DiverParams) -> NDArray:
    """``[forward speed, yaw rate, vertical rate]`` from leg inputs, after saturation."""
    u = np.asarray(u, dtype=float)
    r, L = params.wheel_radius, params.track
    speed = np.minimum(np.maximum(0.5 * r * (u[..., 0] + u[..., 1]),
                                  -params.max_reverse_speed), params.max_speed)
    yaw_rate = np.minimum(np.maximum(r / L * (u[..., 0] - u[..., 1]), -params.max_turn_rate),
                          params.max_turn_rate)
    vertical = np.minimum(np.maximum(u[..., 2], -params.max_vertical_rate),
                          params.max_vertical_rate)
    return np.stack([speed, yaw_rate, vertical], axis=-1)


def body_rates_single(u: ArrayLike, params: DiverParams) -> tuple[float, float, float]:
    """Float twin of :func:`body_rates` for one diver (the hot path; tests hold them equal)."""
    left, right, vertical = np.asarray(u, dtype=float).tolist()
    r, L = params.wheel_radius, params.track
    speed = min(max(0.5 * r * (left + right), -params.max_reverse_speed), params.max_speed)
    yaw_rate = min(max(r / L * (left - right), -params.max_turn_rate), params.max_turn_rate)
    vertical = min(max(vertical, -params.max_vertical_rate), params.max_vertical_rate)
    return speed, yaw_rate, vertical


def leg_inputs(speed: float, yaw_rate: float, vertical_rate: float,
               params: DiverParams) -> NDArray:
    """Inverse of :func:`body_rates` (before saturation): ``[u_l, u_r, u_z]`` for one diver."""
    r, L = params.wheel_radius, params.track
    common = speed / r
    differential = 0.5 * L * yaw_rate / r
    return np.array([common + differential, common - differential, vertical_rate])


def xdot(t: float, x: ArrayLike, u: ArrayLike, params: DiverParams) -> NDArray:
    """Time derivative of the diver state (paper eqs 10-13). Pure; batch-aware."""
    del t
    x = np.asarray(x, dtype=float)
    rates = body_rates(u, params)
    psi = x[..., 3]
    return np.stack([rates[..., 0] * np.cos(psi), rates[..., 0] * np.sin(psi), rates[..., 2],
                     rates[..., 1]], axis=-1)


def step_exact(x: ArrayLike, u: ArrayLike, params: DiverParams, dt: float) -> NDArray:
    """Exact solution of :func:`xdot` over ``dt`` with ``u`` held (a circular arc).

    With speed s, yaw rate w and vertical rate v constant: psi(t) = psi0 + w t and
    north += (s/w)(sin psi(t) - sin psi0), east -= (s/w)(cos psi(t) - cos psi0); a
    straight line when w = 0. Tests hold it to RK4 on :func:`xdot`.
    """
    north, east, depth, psi = np.asarray(x, dtype=float).tolist()
    speed, yaw_rate, vertical = body_rates_single(u, params)
    new_psi = psi + yaw_rate * dt
    if abs(yaw_rate) * dt > 1e-9:
        radius = speed / yaw_rate
        north += radius * (math.sin(new_psi) - math.sin(psi))
        east -= radius * (math.cos(new_psi) - math.cos(psi))
    else:
        mid = psi + 0.5 * yaw_rate * dt
        north += speed * dt * math.cos(mid)
        east += speed * dt * math.sin(mid)
    return np.array([north, east, depth + vertical * dt, new_psi])
