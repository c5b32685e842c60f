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
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.elementwise import ARRAYS, FLOATS, Elementwise

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
    """``[forward speed, yaw rate, vertical rate]`` from leg inputs, after saturation
    (``u`` of shape (3,) or (N, 3))."""
    u = np.asarray(u, dtype=float)
    return np.stack(body_rates_kernel(u[..., 0], u[..., 1], u[..., 2], params, ARRAYS), axis=-1)


def body_rates_single(u: ArrayLike, params: DiverParams) -> tuple[float, float, float]:
    """:func:`body_rates` of one diver as floats (the same kernel, no numpy call)."""
    return body_rates_kernel(*np.asarray(u, dtype=float).tolist(), params)


def body_rates_kernel(left: Any, right: Any, vertical: Any, params: DiverParams,
                      ops: Elementwise = FLOATS) -> tuple[Any, Any, Any]:
    """Eqs 10-12 with the human limits, on floats or (N,) arrays (``ops``): forward speed
    (m/s), yaw rate (rad/s), vertical rate (m/s, down) from the leg inputs."""
    r, L = params.wheel_radius, params.track
    speed = ops.clip(0.5 * r * (left + right), -params.max_reverse_speed, params.max_speed)
    yaw_rate = ops.clip(r / L * (left - right), -params.max_turn_rate, params.max_turn_rate)
    vertical = ops.clip(vertical, -params.max_vertical_rate, params.max_vertical_rate)
    return speed, yaw_rate, vertical


def leg_inputs(speed: Any, yaw_rate: Any, vertical_rate: Any,
               params: DiverParams) -> tuple[Any, Any, Any]:
    """Inverse of :func:`body_rates` (before saturation): ``(u_l, u_r, u_z)``, floats or
    (N,) arrays like the arguments."""
    r, L = params.wheel_radius, params.track
    common = speed / r
    differential = 0.5 * L * yaw_rate / r
    return common + differential, common - differential, vertical_rate


def xdot(t: float, x: ArrayLike, u: ArrayLike, params: DiverParams) -> NDArray:
    """Time derivative of the diver state (paper eqs 10-13). Pure; batch-aware."""
    del t
    x = np.asarray(x, dtype=float)
    rates = body_rates(u, params)
    psi = x[..., 3]
    return np.stack([rates[..., 0] * np.cos(psi), rates[..., 0] * np.sin(psi), rates[..., 2],
                     rates[..., 1]], axis=-1)


def step_exact(x: ArrayLike, u: ArrayLike, params: DiverParams, dt: float) -> NDArray:
    """Exact solution of :func:`xdot` over ``dt`` with ``u`` held (a circular arc), for one
    diver (``x`` (4,), ``u`` (3,)) or N (``x`` (N, 4), ``u`` (N, 3)): the one kernel,
    :func:`step_exact_kernel`, on floats or arrays. Tests hold it to RK4 on :func:`xdot`."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        rates = body_rates_kernel(*np.asarray(u, dtype=float).tolist(), params)
        return np.array(step_exact_kernel(*x.tolist(), *rates, dt))
    commands = np.asarray(u, dtype=float).T
    rates = body_rates_kernel(*commands, params, ARRAYS)
    return np.stack(step_exact_kernel(*x.T, *rates, dt, ARRAYS), axis=-1)


def step_exact_kernel(north: Any, east: Any, depth: Any, psi: Any, speed: Any, yaw_rate: Any,
                      vertical: Any, dt: float, ops: Elementwise = FLOATS) -> tuple[Any, ...]:
    """The diver state after ``dt`` at constant body rates (:func:`body_rates_kernel`):
    psi(t) = psi0 + w t and north += (s/w)(sin psi(t) - sin psi0), east -= (s/w)(cos psi(t)
    - cos psi0); a straight line at the mean heading when |w dt| <= 1e-9. Floats or (N,)
    arrays (``ops``); returns ``(north, east, depth, psi)``."""
    new_psi = psi + yaw_rate * dt
    turning = abs(yaw_rate) * dt > 1e-9
    if not ops.batched and not turning:  # one diver going straight: skip the arc
        mid = psi + 0.5 * yaw_rate * dt
        return (north + speed * dt * math.cos(mid), east + speed * dt * math.sin(mid),
                depth + vertical * dt, new_psi)
    radius = speed / ops.where(turning, yaw_rate, 1.0)
    d_north = radius * (ops.sin(new_psi) - ops.sin(psi))
    d_east = -(radius * (ops.cos(new_psi) - ops.cos(psi)))
    if ops.batched:  # some of the N divers may go straight
        mid = psi + 0.5 * yaw_rate * dt
        d_north = ops.where(turning, d_north, speed * dt * ops.cos(mid))
        d_east = ops.where(turning, d_east, speed * dt * ops.sin(mid))
    return north + d_north, east + d_east, depth + vertical * dt, new_psi
