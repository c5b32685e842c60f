"""Uniform wrappers ("plants") around the vehicle models so the simulation can step any
of them: ``step(t, x, u) -> x`` over one physics step and ``nav(x) -> NavState``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import NumericalError
from uhrisim.dynamics import carried_load, diver, diver_boots, kinematic, videoray
from uhrisim.dynamics.integrators import FixedStepIntegrator


def finite_or_raise(x: NDArray, vehicle: str, t: float) -> NDArray:
    """``x`` if every entry is finite, else a NumericalError naming the vehicle and time.

    (The sum of a vector is NaN/inf exactly when an entry is, short of overflow - which
    is no valid state either; it is several times cheaper than ``all(isfinite(x))``, and
    for one vehicle's few entries, their sum as Python floats is cheaper still.)
    """
    if not math.isfinite(sum(x.tolist()) if x.ndim == 1 else x.sum()):
        raise NumericalError("state became NaN/inf during integration", vehicle=vehicle, t=t)
    return x


#: the key a :class:`LastValue` starts with (equal to no key)
_NOTHING_YET = object()


class LastValue:
    """One pure function's value for the key it was last asked with: the loop asks again
    and again with the same arguments (a VideoRay's body forces and a diver's body rates
    for its actuator inputs, which change at the control rate, a fraction of the physics
    ticks; a still diver on boots steps from the same state with the same command). The
    values are those of a fresh computation. ``copies``: the value is an array that
    callers may change, so a copy of it is kept and copies go out."""

    __slots__ = ("_copies", "_last")

    def __init__(self, copies: bool = False) -> None:
        self._last: tuple[Any, Any] = (_NOTHING_YET, None)  # (key, value)
        self._copies = copies

    def of(self, key: Any, compute: Callable[..., Any], *args: Any) -> Any:
        """``compute(*args)``, or its value when ``key`` (what the value follows from,
        compared with ``==``: a list of floats, bytes) equals the last one (one pair,
        replaced at once: threads sharing a plant see a matching one)."""
        last_key, value = self._last
        if key != last_key:
            value = compute(*args)
            self._last = (key, value.copy() if self._copies else value)
            return value
        return value.copy() if self._copies else value


@dataclass(frozen=True)
class NavState:
    """Navigation truth of one body: NED position (m), yaw (rad), FRD velocity (m/s), r (rad/s).

    The arrays are read-only copies, so a NavState can be shared safely.
    """

    position_ned: NDArray
    yaw: float
    velocity_body: NDArray
    yaw_rate: float

    def __post_init__(self) -> None:
        self.position_ned.setflags(write=False)
        self.velocity_body.setflags(write=False)

    @property
    def speed(self) -> float:
        """Horizontal speed through the water (m/s), what MOOS calls NAV_SPEED."""
        surge, sway = self.velocity_body[:2].tolist()
        if sway == 0.0:  # hypot(x, 0) is |x| exactly (C99 F.9.4.3): skip numpy's call
            return abs(surge)
        return float(np.hypot(surge, sway))


@dataclass(frozen=True)
class VideoRayPlant:
    """The hydrodynamic VideoRay model integrated by sub-stepped RK4."""

    params: videoray.VideoRayParams
    dt: float
    name: str = "videoray"
    substeps: int | None = None
    integrator: FixedStepIntegrator = field(init=False)
    coefficients: videoray.RateCoefficients = field(init=False)
    _coefficient_values: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _forces: LastValue = field(init=False, repr=False, compare=False)
    kind = "videoray"
    state_size = videoray.STATE_SIZE
    input_size = videoray.INPUT_SIZE

    def __post_init__(self) -> None:
        integrator = FixedStepIntegrator.for_model(
            videoray.xdot, self.dt, videoray.stiffest_eigenvalue(self.params),
            substeps=self.substeps, name=self.name)
        object.__setattr__(self, "integrator", integrator)
        coefficients = videoray.RateCoefficients.of(self.params)
        object.__setattr__(self, "coefficients", coefficients)
        object.__setattr__(self, "_coefficient_values", tuple(coefficients))
        object.__setattr__(self, "_forces", LastValue())

    def initial_state(self, position_ned: NDArray, yaw: float, speed: float = 0.0) -> NDArray:
        return np.array([*position_ned, yaw, speed, 0.0, 0.0, 0.0])

    def step(self, t: float, x: NDArray, u: NDArray) -> NDArray:
        """One physics step of one vehicle (``x`` (8,)) or N (``x`` (N, 8), ``u`` (N, 3)):
        the same kernel, :func:`uhrisim.dynamics.videoray.rk4_steps` (one vehicle: its
        :func:`~uhrisim.dynamics.videoray.rk4_one`, the forces kept while ``u`` holds)."""
        return self._step(t, x, u, self.params, self.coefficients, self._coefficient_values)

    def _step(self, t: float, x: NDArray, u: NDArray, params: videoray.VideoRayParams,
              coefficients: videoray.RateCoefficients, values: tuple[float, ...],
              heave_bias: float = 0.0) -> NDArray:
        """:meth:`step` with these parameters, their coefficients (``values``: as a
        tuple) and a constant extra heave force (N, down)."""
        n = self.integrator.substeps
        x = np.asarray(x, dtype=float)
        if x.ndim == 1:
            inputs = np.asarray(u, dtype=float).tolist()
            forces = self._forces.of(inputs, videoray.rk4_forces, *inputs, params, heave_bias)
            state = videoray.rk4_one(x.tolist(), forces, values, self.dt / n, n)
            return finite_or_raise(np.array(state), self.name, t + self.dt)
        return finite_or_raise(
            videoray.rk4_steps(x, u, params, self.dt / n, n, coefficients,
                               heave_bias=heave_bias),
            self.name, t + self.dt)

    def nav(self, x: NDArray, u: NDArray | None = None) -> NavState:
        del u  # velocities are part of the state
        return NavState(x[0:3].copy(), float(x[3]), x[4:7].copy(), float(x[7]))


@dataclass(frozen=True)
class DiverPlant:
    """The paper's differential-drive diver, stepped by its exact zero-order-hold solution."""

    params: diver.DiverParams
    dt: float
    name: str = "diver"
    _rates: LastValue = field(init=False, repr=False, compare=False,
                              default_factory=LastValue)
    kind = "diver"
    state_size = diver.STATE_SIZE
    input_size = 3

    def initial_state(self, position_ned: NDArray, yaw: float, speed: float = 0.0) -> NDArray:
        del speed  # a kinematic diver has no velocity state
        return np.array([*position_ned, yaw])

    def step(self, t: float, x: NDArray, u: NDArray) -> NDArray:
        """One physics step of one diver (``x`` (4,)) or N (``x`` (N, 4), ``u`` (N, 3)):
        :func:`uhrisim.dynamics.diver.step_exact` (one diver: its kernel on the body rates
        kept while ``u`` holds)."""
        x = np.asarray(x, dtype=float)
        if x.ndim == 1:
            inputs = np.asarray(u, dtype=float).tolist()
            rates = self._rates.of(inputs, diver.body_rates_kernel, *inputs, self.params)
            state = diver.step_exact_kernel(*x.tolist(), *rates, self.dt)
            return finite_or_raise(np.array(state), self.name, t + self.dt)
        return finite_or_raise(diver.step_exact(x, u, self.params, self.dt), self.name,
                               t + self.dt)

    def nav(self, x: NDArray, u: NDArray | None = None) -> NavState:
        inputs = None if u is None else np.asarray(u, dtype=float).tolist()
        speed, yaw_rate, vertical = (
            self._rates.of(inputs, diver.body_rates_kernel, *inputs, self.params)
            if inputs is not None else (0.0, 0.0, 0.0))
        return NavState(x[0:3].copy(), float(x[3]), np.array([speed, 0.0, vertical]), yaw_rate)


@dataclass(frozen=True)
class KinematicPlant:
    """uSimMarine-like kinematic vehicle (discrete update)."""

    params: kinematic.KinematicParams
    dt: float
    name: str = "vehicle"
    kind = "kinematic"
    state_size = kinematic.STATE_SIZE
    input_size = 3

    def initial_state(self, position_ned: NDArray, yaw: float, speed: float = 0.0) -> NDArray:
        return np.array([*position_ned, yaw, speed])

    def step(self, t: float, x: NDArray, u: NDArray) -> NDArray:
        del t
        return kinematic.kinematic_step(x, u, self.params, self.dt)

    def nav(self, x: NDArray, u: NDArray | None = None) -> NavState:
        del u
        return NavState(x[0:3].copy(), float(x[3]), np.array([x[4], 0.0, 0.0]), 0.0)


@dataclass(frozen=True)
class BootsPlant:
    """The commercial diver on weighted boots (:mod:`uhrisim.dynamics.diver_boots`) as a
    plant: it walks on ``floor_depth`` (depth (m) at north, east), rises only on suit gas.

    State (12,): hip centre NED (m), heading (rad), walking speed (m/s), gait phase (rad),
    suit gas (surface L), velocity afloat (NED m/s), afloat (0/1), crouch (0..1) — the
    fields of :class:`~uhrisim.dynamics.diver_boots.BootsState` in order. Inputs (4,):
    speed (m/s), turn rate (rad/s), suit valve (+1 inflate, 0 hold, -1 dump), crouch.
    """

    params: diver_boots.BootsParams
    dt: float
    floor_depth: diver_boots.FloorDepth
    name: str = "diver"
    #: the last step (a diver standing still steps from where it stood with the same
    #: command again and again: a pure function of the two, the very state a fresh
    #: step gives) and the last :meth:`leg_angles`
    _steps: LastValue = field(init=False, repr=False, compare=False,
                              default_factory=lambda: LastValue(copies=True))
    _legs: LastValue = field(init=False, repr=False, compare=False,
                             default_factory=LastValue)
    kind = "diver_boots"
    state_size = 12
    input_size = 4

    def initial_state(self, position_ned: NDArray, yaw: float, speed: float = 0.0) -> NDArray:
        """Standing on the floor under ``position_ned`` (its depth is replaced by the
        standing hip depth there)."""
        standing = diver_boots.BootsState((float(position_ned[0]), float(position_ned[1]), 0.0),
                                          yaw, speed)
        depth = diver_boots.standing_hip_depth(standing, self.params, self.floor_depth)
        return self.array(replace(standing, position=(standing.position[0],
                                                      standing.position[1], depth)))

    @staticmethod
    def array(state: diver_boots.BootsState) -> NDArray:
        """A :class:`BootsState` as this plant's state vector."""
        return np.array([*state.position, state.psi, state.speed, state.phase,
                         state.suit_litres, *state.velocity, float(state.afloat), state.crouch])

    @staticmethod
    def boots_state(x: NDArray) -> diver_boots.BootsState:
        """This plant's state vector as a :class:`BootsState`."""
        return diver_boots.BootsState((float(x[0]), float(x[1]), float(x[2])), float(x[3]),
                                      float(x[4]), float(x[5]), float(x[6]),
                                      (float(x[7]), float(x[8]), float(x[9])), bool(x[10] > 0.5),
                                      float(x[11]))

    def step(self, t: float, x: NDArray, u: NDArray) -> NDArray:
        return self._steps.of(x.tobytes() + u.tobytes(), self._step, t, x, u)

    def _step(self, t: float, x: NDArray, u: NDArray) -> NDArray:
        command = diver_boots.BootsCommand(float(u[0]), float(u[1]), int(np.sign(u[2])),
                                           float(u[3]))
        result = diver_boots.step(self.boots_state(x), command, self.params, self.dt,
                                  self.floor_depth)
        return finite_or_raise(self.array(result.state), self.name, t + self.dt)

    def leg_angles(self, x: NDArray, q: NDArray) -> NDArray:
        """:func:`~uhrisim.dynamics.diver_boots.leg_angles` of state ``x`` from joint
        angles ``q``. The legs' angles follow from the state and the pelvis's tilt
        alone, the others are ``q``'s (clipped into the limits): a diver standing still,
        working with his arms, gets the legs' angles of the last time again (clipping
        clipped angles changes no bit)."""
        q = np.asarray(q, dtype=float)
        posture, legs = self._leg_joints
        kept = self._legs.of(x.tobytes() + q[posture:posture + 1].tobytes(),
                             self._leg_angles, x, q)
        out = q.copy()
        out[legs] = kept[legs]
        return self.params.skeleton.clip(out)

    @cached_property
    def _leg_joints(self) -> tuple[int, NDArray[np.intp]]:
        """The positions in ``q`` of the pelvis's tilt and of the legs' joints."""
        skeleton = self.params.skeleton
        return skeleton.index("posture"), np.array(
            [skeleton.index(name) for name in diver_boots.LEG_JOINTS], dtype=np.intp)

    def _leg_angles(self, x: NDArray, q: NDArray) -> NDArray:
        return diver_boots.leg_angles(self.boots_state(x), self.params, self.floor_depth, q)

    def footfalls(self, before: NDArray, after: NDArray) -> list[diver_boots.Footfall]:
        """The feet set down between two consecutive states (for the silt they stir)."""
        return diver_boots.footfalls_between(float(before[5]), self.boots_state(after),
                                             self.params, self.floor_depth)

    def nav(self, x: NDArray, u: NDArray | None = None) -> NavState:
        yaw = float(x[3])
        if x[10] > 0.5:  # afloat: its water velocity, in the body frame
            c, s = math.cos(yaw), math.sin(yaw)
            velocity = np.array([c * x[7] + s * x[8], -s * x[7] + c * x[8], x[9]])
        else:
            velocity = np.array([x[4], 0.0, 0.0])
        limit = self.params.max_turn_rate
        turn = 0.0 if u is None else min(max(float(u[1]), -limit), limit)
        return NavState(x[0:3].copy(), yaw, velocity, turn)


@dataclass(frozen=True)
class LoadedVideoRayPlant(VideoRayPlant):
    """The VideoRay with ``load`` in its gripper: eqs 1-4 with the load's mass, added mass
    and drag (:func:`~uhrisim.dynamics.carried_load.loaded_params`) and its in-water
    weight as a heave force — :func:`~uhrisim.dynamics.carried_load.xdot_loaded`, its
    parameters worked out once — by the unloaded plant's RK4 kernel
    (:func:`~uhrisim.dynamics.videoray.rk4_steps`) and sub-steps (a heavier vehicle is no
    stiffer). ``params`` stay the unloaded vehicle's."""

    load: carried_load.CarriedLoad | None = None
    loaded: videoray.VideoRayParams | None = field(init=False, default=None)
    loaded_coefficients: videoray.RateCoefficients | None = field(init=False, default=None)
    _loaded_values: tuple[float, ...] = field(init=False, default=(), repr=False,
                                              compare=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.load is not None:
            loaded = carried_load.loaded_params(self.params, self.load)
            object.__setattr__(self, "loaded", loaded)
            coefficients = videoray.RateCoefficients.of(loaded)
            object.__setattr__(self, "loaded_coefficients", coefficients)
            object.__setattr__(self, "_loaded_values", tuple(coefficients))

    def step(self, t: float, x: NDArray, u: NDArray) -> NDArray:
        if self.load is None:
            return super().step(t, x, u)
        return self._step(t, x, u, self.loaded, self.loaded_coefficients,
                          self._loaded_values, carried_load.heave_bias(self.load))


def carrying(plant: VideoRayPlant, load: carried_load.CarriedLoad | None
             ) -> LoadedVideoRayPlant:
    """``plant`` with ``load`` in its gripper (None: nothing)."""
    return LoadedVideoRayPlant(plant.params, plant.dt, plant.name, plant.substeps, load=load)
