"""VideoRay Pro 4 ROV: the paper's 4-DOF hydrodynamic model (eqs 1-4) and thruster map.

State layout (docs/conventions.md): ``x = [x_north, y_east, z_down, psi, u, v, w, r]``
(NED metres, yaw rad = compass heading, FRD body velocities m/s, yaw rate rad/s).
Inputs: ``[port, starboard, vertical]`` dimensionless thruster commands, saturated at
+-150. All functions accept a batch: ``x`` of shape ``(..., 8)`` and ``u`` of ``(..., 3)``;
:func:`rk4_steps` steps one vehicle or N with the same kernel (the fast path; :func:`xdot`
with :func:`~uhrisim.dynamics.integrators.rk4_step` is its slow reference).

Coefficients: W. Wang, MASc thesis, Univ. of Waterloo 2006, p. 19 (VideoRay Pro III),
used by DeMarco et al. for their Pro 4; see docs/reference/vehicles-and-control.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.compiled import jit, record
from uhrisim.core.elementwise import ARRAYS, FLOATS, Elementwise
from uhrisim.core.settings import check_settings, setting

STATE_NAMES = ("x", "y", "z", "psi", "u", "v", "w", "r")
INPUT_NAMES = ("port", "starboard", "vertical")
STATE_SIZE = 8
INPUT_SIZE = 3
#: The thruster commands' range, ±this (dimensionless; the paper's and the authors' code).
INPUT_LIMIT = 150.0


@dataclass(frozen=True)
class VideoRayParams:
    """Rigid-body + added-mass inertia, damping and thruster constants (SI units).

    Source: Wang 2006 table (docs/reference/vehicles-and-control.md); ``J`` defaults to
    0.0118 kg m^2 (the authors' ROS node used 0.1; an older script 0.5). ``moment_arm`` =
    1 m reproduces the authors' code, which had no arm.
    """

    m11: float = 1.94  # kg, surge inertia
    m22: float = 6.05  # kg, sway inertia
    m33: float = 3.95  # kg, heave inertia
    J: float = setting(0.0118, "kg m²", gt=0.0, le=100.0, doc="yaw inertia")
    Xu: float = -0.95  # N s/m
    Yv: float = -5.87  # N s/m
    Zw: float = -3.70  # N s/m
    Nr: float = -0.023  # N m s
    Xuu: float = -6.04  # N s^2/m^2
    Yvv: float = -30.73  # N s^2/m^2
    Zww: float = -26.36  # N s^2/m^2
    Nrr: float = -0.45  # N m s^2
    thrust_map: Literal["linear", "quadratic"] = "linear"
    ct_linear: float = 4.0 / 150.0  # N per input unit, horizontal (authors' code: 4 N at 150)
    ct_vertical_linear: float = 4.0 / 150.0  # N per input unit, vertical
    ct_forward_quadratic: float = 2.59e-4  # N per unit^2, T = Ct u|u| (Wang thesis)
    ct_reverse_quadratic: float = 1.01e-4
    ct_vertical_up_quadratic: float = 1.19e-4
    ct_vertical_down_quadratic: float = 7.53e-5
    moment_arm: float = setting(1.0, "m", gt=0.0, le=10.0,
                                doc="lever of the horizontal thrusters about the yaw axis")
    input_limit: float = INPUT_LIMIT
    coupling: Literal["paper", "rigid-body"] = "paper"

    def __post_init__(self) -> None:
        for name in ("m11", "m22", "m33", "J", "ct_linear", "ct_vertical_linear", "input_limit"):
            if not getattr(self, name) > 0.0:
                value = getattr(self, name)
                raise ValueError(f"VideoRayParams.{name} must be positive, got {value}")
        for name in ("Xu", "Yv", "Zw", "Nr", "Xuu", "Yvv", "Zww", "Nrr"):
            if getattr(self, name) > 0.0:
                raise ValueError(f"VideoRayParams.{name} is a damping term and must be <= 0")
        if self.thrust_map not in ("linear", "quadratic"):
            raise ValueError(f"thrust_map must be 'linear' or 'quadratic', got {self.thrust_map!r}")
        if self.coupling not in ("paper", "rigid-body"):
            raise ValueError(f"coupling must be 'paper' or 'rigid-body', got {self.coupling!r}")
        check_settings(self)  # the declared ranges (J, moment_arm)


#: The thrust maps, in order: a compiled kernel's record of the parameters carries
#: ``thrust_map`` as its index here (an integer: no string compared in every tick).
THRUST_MAPS = ("linear", "quadratic")


def kernel_record(params: VideoRayParams) -> tuple:
    """``params`` as the compiled kernels read them (:func:`uhrisim.core.compiled.record`,
    ``thrust_map`` as its index in :data:`THRUST_MAPS`)."""
    return record(params)._replace(thrust_map=THRUST_MAPS.index(params.thrust_map))


def linear_thrust(params: Any) -> bool:
    """Whether ``params`` (:class:`VideoRayParams`, or a compiled kernel's record of them
    with ``thrust_map`` as its index in :data:`THRUST_MAPS`) map commands to thrust
    linearly."""
    return params.thrust_map == "linear" or params.thrust_map == 0


def thruster_forces(u: ArrayLike, params: VideoRayParams) -> NDArray[np.float64]:
    """Thrust of each thruster (N) for commands ``u = [port, star, vert]`` (saturated).

    Positive port/starboard thrust pushes forward; positive vertical thrust pushes UP
    (a negative vertical command dives, paper Fig. 7).
    """
    cmd = np.clip(np.asarray(u, dtype=float), -params.input_limit, params.input_limit)
    if params.thrust_map == "linear":
        return cmd * np.array([params.ct_linear, params.ct_linear, params.ct_vertical_linear])
    square = cmd * np.abs(cmd)
    horizontal_ct = np.where(cmd[..., :2] >= 0.0, params.ct_forward_quadratic,
                             params.ct_reverse_quadratic)
    vertical_ct = np.where(cmd[..., 2:] >= 0.0, params.ct_vertical_up_quadratic,
                           params.ct_vertical_down_quadratic)
    return square * np.concatenate([horizontal_ct, vertical_ct], axis=-1)


def generalized_forces(u: ArrayLike, params: VideoRayParams) -> NDArray[np.float64]:
    """Body forces ``[X, Z, N]``: surge (N, forward), heave (N, down), yaw moment (N m).

    ``N = arm * (T_port - T_star)``: more starboard thrust turns counter-clockwise seen
    from above (paper Fig. 5); ``Z = -T_vert`` because FRD z points down.
    """
    thrust = thruster_forces(u, params)
    surge = thrust[..., 0] + thrust[..., 1]
    heave = -thrust[..., 2]
    yaw = params.moment_arm * (thrust[..., 0] - thrust[..., 1])
    return np.stack([surge, heave, yaw], axis=-1)


def xdot(t: float, x: ArrayLike, u: ArrayLike, params: VideoRayParams) -> NDArray[np.float64]:
    """Time derivative of the state (paper eqs 1-4 + NED kinematics). Pure; batch-aware.

    ``coupling="paper"`` uses the Coriolis signs exactly as printed in the paper and the
    authors' Octave model (``m11 du/dt = -m22 v r ...``, ``m22 dv/dt = m11 u r ...``, no
    Munk moment in yaw). ``coupling="rigid-body"`` uses the standard 3-DOF form
    (Fossen 2011: ``+m22 v r``, ``-m11 u r`` and ``(m11 - m22) u v`` in yaw), whose
    coupling terms do no work.
    """
    del t  # time-invariant model
    x = np.asarray(x, dtype=float)
    psi, uu, v, w, r = x[..., 3], x[..., 4], x[..., 5], x[..., 6], x[..., 7]
    forces = generalized_forces(u, params)
    surge_force, heave_force, yaw_moment = forces[..., 0], forces[..., 1], forces[..., 2]
    p = params
    sign = -1.0 if p.coupling == "paper" else 1.0
    munk = 0.0 if p.coupling == "paper" else (p.m11 - p.m22) * uu * v
    du = (sign * p.m22 * v * r + p.Xu * uu + p.Xuu * np.abs(uu) * uu + surge_force) / p.m11
    dv = (-sign * p.m11 * uu * r + p.Yv * v + p.Yvv * np.abs(v) * v) / p.m22
    dw = (p.Zw * w + p.Zww * np.abs(w) * w + heave_force) / p.m33
    dr = (munk + p.Nr * r + p.Nrr * np.abs(r) * r + yaw_moment) / p.J
    cos_psi, sin_psi = np.cos(psi), np.sin(psi)
    dx_north = uu * cos_psi - v * sin_psi
    dy_east = uu * sin_psi + v * cos_psi
    return np.stack([dx_north, dy_east, w, r, du, dv, dw, dr], axis=-1)


def kinetic_energy(x: ArrayLike, params: VideoRayParams) -> NDArray[np.float64] | float:
    """Kinetic energy (J) with the model's total (rigid-body + added) inertia."""
    x = np.asarray(x, dtype=float)
    p = params
    energy = 0.5 * (p.m11 * x[..., 4] ** 2 + p.m22 * x[..., 5] ** 2 + p.m33 * x[..., 6] ** 2
                    + p.J * x[..., 7] ** 2)
    return float(energy) if np.ndim(energy) == 0 else energy


def steady_speed(force: float, linear: float, quadratic: float) -> float:
    """Speed at which ``force + linear*s + quadratic*|s|*s = 0`` (thrust-drag balance)."""
    if force == 0.0:
        return 0.0
    a, b, c = -quadratic, -linear, abs(force)  # a s^2 + b s - c = 0 for s > 0
    speed = (-b + np.sqrt(b * b + 4.0 * a * c)) / (2.0 * a) if a > 0.0 else c / b
    return float(np.copysign(speed, force))


def max_yaw_rate(params: VideoRayParams) -> float:
    """Largest steady yaw rate (rad/s): full differential thrust against yaw damping."""
    full = np.array([params.input_limit, -params.input_limit, 0.0])
    moment = float(generalized_forces(full, params)[2])
    return abs(steady_speed(moment, params.Nr, params.Nrr))


def stiffest_eigenvalue(params: VideoRayParams) -> float:
    """Magnitude (1/s) of the fastest decay rate of the velocity equations.

    The Jacobian of the damping ``(lin + quad |s| s)/m`` is ``-(lin_abs + 2 quad_abs |s|)/m``;
    it is largest in yaw at the highest reachable yaw rate (about 320 1/s with J=0.0118).
    """
    p = params
    full_forward = np.array([p.input_limit, p.input_limit, p.input_limit])
    forces = generalized_forces(full_forward, p)
    u_max = abs(steady_speed(float(forces[0]), p.Xu, p.Xuu))
    w_max = abs(steady_speed(float(forces[1]), p.Zw, p.Zww))
    r_max = max_yaw_rate(p)
    v_max = u_max  # sway is never driven harder than surge
    rates = [
        (abs(p.Xu) + 2.0 * abs(p.Xuu) * u_max) / p.m11,
        (abs(p.Yv) + 2.0 * abs(p.Yvv) * v_max) / p.m22,
        (abs(p.Zw) + 2.0 * abs(p.Zww) * w_max) / p.m33,
        (abs(p.Nr) + 2.0 * abs(p.Nrr) * r_max) / p.J,
    ]
    return float(max(rates))


def body_forces(port: Any, star: Any, vert: Any, p: VideoRayParams,
                ops: Elementwise = FLOATS) -> tuple[Any, Any, Any]:
    """Kernel of :func:`generalized_forces` on the three commands as floats (``ops``
    :data:`~uhrisim.core.elementwise.FLOATS`, one vehicle) or (N,) arrays
    (:data:`~uhrisim.core.elementwise.ARRAYS`): ``(X, Z, N)`` in N, N, N m."""
    limit = p.input_limit
    port, star, vert = (ops.clip(port, -limit, limit), ops.clip(star, -limit, limit),
                        ops.clip(vert, -limit, limit))
    if linear_thrust(p):
        t_port, t_star, t_vert = port * p.ct_linear, star * p.ct_linear, vert * p.ct_vertical_linear
    else:
        forward, reverse = p.ct_forward_quadratic, p.ct_reverse_quadratic
        t_port = port * abs(port) * ops.where(port >= 0.0, forward, reverse)
        t_star = star * abs(star) * ops.where(star >= 0.0, forward, reverse)
        t_vert = vert * abs(vert) * ops.where(vert >= 0.0, p.ct_vertical_up_quadratic,
                                              p.ct_vertical_down_quadratic)
    return t_port + t_star, -t_vert, p.moment_arm * (t_port - t_star)


class RateCoefficients(NamedTuple):
    """The velocity equations of :func:`xdot` with every coefficient divided by its inertia
    once: ``d(vel)/dt = c*coupling + b*vel + q*|vel|*vel + force/inertia`` (SI units)."""

    cu: float
    cv: float
    cr: float
    bu: float
    bv: float
    bw: float
    br: float
    qu: float
    qv: float
    qw: float
    qr: float
    m11: float
    m33: float
    J: float

    @classmethod
    def of(cls, p: VideoRayParams) -> RateCoefficients:
        sign = -1.0 if p.coupling == "paper" else 1.0
        munk = 0.0 if p.coupling == "paper" else (p.m11 - p.m22)
        return cls(sign * p.m22 / p.m11, -sign * p.m11 / p.m22, munk / p.J,
                   p.Xu / p.m11, p.Yv / p.m22, p.Zw / p.m33, p.Nr / p.J,
                   p.Xuu / p.m11, p.Yvv / p.m22, p.Zww / p.m33, p.Nrr / p.J,
                   p.m11, p.m33, p.J)


def rk4_steps(x: ArrayLike, u: ArrayLike, params: VideoRayParams, h: float, substeps: int,
              coefficients: RateCoefficients | None = None,
              compiled: bool = True, heave_bias: float = 0.0) -> NDArray[np.float64]:
    """``substeps`` RK4 steps of size ``h`` with the inputs held, for one vehicle (``x``
    (8,), ``u`` (3,)) or N at once (``x`` (N, 8), ``u`` (N, 3)): the one kernel,
    :func:`rk4_kernel`, on floats (one vehicle) or on arrays (N); with numba installed and
    ``compiled``, the float kernel compiled, looped over the rows for N
    (:mod:`uhrisim.core.compiled`; the same numbers, bit for bit).
    Equal (to rounding) to :func:`uhrisim.dynamics.integrators.rk4_step` on :func:`xdot`,
    the slow reference a test holds it to. ``coefficients``: those of ``params``, when the
    caller keeps them. ``heave_bias``: a constant extra heave force (N, down), such as a
    carried load's in-water weight."""
    coefficients = coefficients or RateCoefficients.of(params)
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        forces = rk4_forces(*np.asarray(u, dtype=float).tolist(), params, heave_bias)
        return np.array(rk4_one(x.tolist(), forces, tuple(coefficients), h, substeps,
                                compiled))
    commands = np.ascontiguousarray(np.asarray(u, dtype=float).T)
    with np.errstate(over="ignore", invalid="ignore"):  # a blow-up is reported by the caller
        surge, heave, yaw = body_forces(*commands, params, ARRAYS)
        forces = (surge, heave + heave_bias, yaw)
        rows = _compiled_rows() if compiled else None
        if rows is not None:
            out = np.empty_like(x)
            rows(np.ascontiguousarray(x), np.ascontiguousarray(np.stack(forces, axis=-1)),
                 tuple(coefficients), h, substeps, out)
            return out
        out = rk4_kernel(*np.ascontiguousarray(x.T), *forces, coefficients, h, substeps,
                         ARRAYS)
    return np.stack(out, axis=-1)


def rk4_forces(port: float, star: float, vert: float, params: VideoRayParams,
               heave_bias: float = 0.0) -> tuple[float, float, float]:
    """The body forces :func:`rk4_steps` integrates one vehicle under (N, N, N m): those
    of :func:`body_forces` for the three commands, ``heave_bias`` (N, down) added to the
    heave."""
    surge, heave, yaw = body_forces(port, star, vert, params)
    return surge, heave + heave_bias, yaw


def rk4_one(state: list[float], forces: tuple[float, float, float],
            coefficients: tuple[float, ...], h: float, substeps: int,
            compiled: bool = True) -> tuple[float, ...]:
    """:func:`rk4_steps` of one vehicle on floats: the eight state components (``state``
    in :data:`STATE_NAMES` order) after ``substeps`` RK4 steps of ``h`` (s) under the body
    forces ``(surge, heave, yaw moment)`` (N, N, N m; :func:`body_forces`), with the
    values of a :class:`RateCoefficients`; compiled with numba when it is installed and
    ``compiled``."""
    kernel = (_compiled_kernel() if compiled else None) or _FLOAT_KERNEL
    return kernel(*state, *forces, coefficients, h, substeps)


def rk4_kernel(north: Any, east: Any, depth: Any, psi: Any, su: Any, sv: Any, sw: Any, sr: Any,
               surge: Any, heave: Any, yaw_moment: Any, coefficients: RateCoefficients,
               h: float, substeps: int, ops: Elementwise = FLOATS) -> tuple[Any, ...]:
    """The state after ``substeps`` RK4 steps of ``h`` (s) under the body forces ``(surge,
    heave, yaw_moment)`` (N, N, N m; :func:`body_forces`): paper eqs 1-4 with NED
    kinematics, as floats (one vehicle) or (N,) arrays (``ops``). Returns the eight state
    components in :data:`STATE_NAMES` order."""
    kernel = _FLOAT_KERNEL if ops is FLOATS else _rk4_kernel_with(ops.cos, ops.sin)
    return kernel(north, east, depth, psi, su, sv, sw, sr, surge, heave, yaw_moment,
                  coefficients, h, substeps)


def _rk4_kernel_with(cos: Any, sin: Any) -> Any:
    """:func:`rk4_kernel` with its trigonometry bound (a closure numba can compile)."""

    def kernel(north: Any, east: Any, depth: Any, psi: Any, su: Any, sv: Any, sw: Any,
               sr: Any, surge: Any, heave: Any, yaw_moment: Any, coefficients: Any, h: float,
               substeps: int) -> tuple[Any, ...]:
        cu, cv, cr, bu, bv, bw, br, qu, qv, qw, qr, m11, m33, J = coefficients
        fu, fw, fr = surge / m11, heave / m33, yaw_moment / J

        def rates(psi: Any, uu: Any, v: Any, w: Any, r: Any) -> tuple[Any, ...]:
            """d(north, east, u, v, w, r)/dt; d(depth)/dt = w, d(psi)/dt = r need no work."""
            c, s_ = cos(psi), sin(psi)
            return (uu * c - v * s_, uu * s_ + v * c,
                    cu * v * r + bu * uu + qu * abs(uu) * uu + fu,
                    cv * uu * r + bv * v + qv * abs(v) * v,
                    bw * w + qw * abs(w) * w + fw,
                    cr * uu * v + br * r + qr * abs(r) * r + fr)

        half, sixth = 0.5 * h, h / 6.0
        for _ in range(substeps):
            a1, b1, e1, f1, g1, k1 = rates(psi, su, sv, sw, sr)
            w2, r2 = sw + half * g1, sr + half * k1
            a2, b2, e2, f2, g2, k2 = rates(psi + half * sr, su + half * e1, sv + half * f1,
                                           w2, r2)
            w3, r3 = sw + half * g2, sr + half * k2
            a3, b3, e3, f3, g3, k3 = rates(psi + half * r2, su + half * e2, sv + half * f2,
                                           w3, r3)
            w4, r4 = sw + h * g3, sr + h * k3
            a4, b4, e4, f4, g4, k4 = rates(psi + h * r3, su + h * e3, sv + h * f3, w4, r4)
            north = north + sixth * (a1 + 2.0 * (a2 + a3) + a4)
            east = east + sixth * (b1 + 2.0 * (b2 + b3) + b4)
            depth = depth + sixth * (sw + 2.0 * (w2 + w3) + w4)
            psi = psi + sixth * (sr + 2.0 * (r2 + r3) + r4)
            su = su + sixth * (e1 + 2.0 * (e2 + e3) + e4)
            sv = sv + sixth * (f1 + 2.0 * (f2 + f3) + f4)
            sw = sw + sixth * (g1 + 2.0 * (g2 + g3) + g4)
            sr = sr + sixth * (k1 + 2.0 * (k2 + k3) + k4)
        return north, east, depth, psi, su, sv, sw, sr

    return kernel


_FLOAT_KERNEL = _rk4_kernel_with(FLOATS.cos, FLOATS.sin)


@cache
def _compiled_kernel() -> Any:
    """The float kernel compiled (one vehicle: no Python per operation); None without
    numba."""
    return jit(_FLOAT_KERNEL)


@cache
def _compiled_rows() -> Any:
    """The float kernel compiled, looped over the rows of (N, 8) states and (N, 3) body
    forces into ``out``; None without numba."""
    kernel = _compiled_kernel()
    if kernel is None:
        return None

    def rows(states: Any, forces: Any, coefficients: Any, h: float, substeps: int,
             out: Any) -> None:
        for i in range(states.shape[0]):
            s, f = states[i], forces[i]
            new = kernel(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], f[0], f[1], f[2],
                         coefficients, h, substeps)
            for j in range(8):
                out[i, j] = new[j]

    return jit(rows)
