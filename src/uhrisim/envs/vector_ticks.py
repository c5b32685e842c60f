"""The vector env's step compiled (numba, ``uhrisim[fast]``): one call runs every tick of
a step for a share of the N episodes, row by row, then forms each row's geometry, reward
terms and observation, with no numpy call per operation and without the GIL.

:meth:`TrailDiverVectorEnv._run <uhrisim.envs.vector.TrailDiverVectorEnv>` on arrays is the
reference; this runs the same tick, in the same order, on one episode's floats: the diver's
exact step and the VideoRay's RK4 (the kernels of :mod:`uhrisim.dynamics.diver` and
:mod:`uhrisim.dynamics.videoray`, compiled), the Simulation's contact rules, the batched
loiter pilot and the controllers (:func:`~uhrisim.control.videoray_p.p_control_kernel`,
:func:`~uhrisim.control.diver.diver_control_kernel`, compiled). A test holds the two equal,
bit for bit. Each row's arithmetic is its own, so any split of the rows among threads gives
the same results.

The env's settings are an argument (:class:`StepConstants`), so numba keeps the compiled
kernel on disk for every process and env (:func:`uhrisim.core.compiled.jit`); the env calls
it through its typed entry (:func:`uhrisim.core.compiled.typed_entry`), which skips
numba's typing of the settings at each call.

The narrow phase of the ROV's collision with the sea floor and the pilings (a swept sphere
cast by Embree) stays in Python: a tick whose move ends near either (a conservative test:
the shallowest corner of the floor's grid cell, a piling's box) is left pending, the env
works out the free fraction of the move (its own ``_scene_clear``) and calls again; the
pending tick then finishes and the row goes on.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache, partial
from typing import Any, NamedTuple

import numpy as np

from uhrisim.control.diver import diver_control_kernel
from uhrisim.control.videoray_p import feedforward_input, p_control_kernel
from uhrisim.core.compiled import float_ops, jit_with, numba_module, record, typed_entry
from uhrisim.core.frames import wrap_180
from uhrisim.dynamics import videoray
from uhrisim.dynamics.diver import body_rates_kernel, leg_inputs, step_exact_kernel
from uhrisim.envs.task import THRUSTER_LIMIT


def floor_cells(seafloor: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sea floor's grid (north, east edges, m) and the depth of each cell's shallowest
    corner (m): the floor lies nowhere in a cell above that (it is linear on the cell's
    triangles). Empty without a sea floor."""
    if seafloor is None:
        return np.zeros(0), np.zeros(0), np.zeros((0, 0))
    z = seafloor.depth
    shallowest = np.minimum(np.minimum(z[:-1, :-1], z[1:, :-1]), np.minimum(z[1:, 1:], z[:-1, 1:]))
    return (np.ascontiguousarray(seafloor.north, float), np.ascontiguousarray(seafloor.east, float),
            np.ascontiguousarray(shallowest, float))


class StepConstants(NamedTuple):
    """What the compiled step reads of one env (one argument of the kernel: numba's disk
    cache keeps the kernel whatever the values)."""

    rov_params: Any          # videoray.kernel_record of VideoRayParams
    coefficients: tuple      # videoray.RateCoefficients
    substeps: int
    h: float                 # RK4 step (s)
    diver_params: Any        # record of DiverParams
    rov_gains: Any           # record of PGains
    diver_gains: Any         # record of DiverGains
    dt: float                # physics step (s)
    pilot_period: int        # ticks
    rov_period: int
    diver_period: int
    course_low: float        # the helm's course grid (deg)
    course_delta: float
    course_points: int
    contact: float           # ROV-diver contact distance (m)
    margin: float            # broad phase reach beyond the ROV's centre (m)
    shallowest_floor: float  # m
    trail_range: float       # m
    trail_angle: float       # rad
    weights: Any             # record of RewardWeights
    low: tuple               # observation bounds
    high: tuple


def compiled_step(env: Any, arguments: tuple) -> Callable[..., None] | None:
    """The compiled step of ``env`` (a :class:`~uhrisim.envs.vector.TrailDiverVectorEnv`):
    ``step(*arguments)`` runs :func:`_step` with the env's constants, for arguments of the
    types of ``arguments`` (the env's arrays); None without numba."""
    kernel = _kernel()
    if kernel is None:
        return None
    course = env.domain.axis("course")
    substeps = env.rov_plant.integrator.substeps
    trail_range, trail_angle = env.template._trail
    space = env.single_observation_space
    constants = StepConstants(
        videoray.kernel_record(env.rov_plant.params), tuple(env.rov_plant.coefficients), substeps,
        env.dt / substeps, record(env.diver_plant.params), record(env.rov_control.gains),
        record(env.diver_control.gains), env.dt, env.pilot_period, env.rov_control_period,
        env.diver_control_period, float(course.low), float(course.delta), int(course.npts),
        float(env.contact_distance),
        float(env.rov_radius) + 0.5, float(env.shallowest_floor), float(trail_range),
        math.radians(trail_angle), record(env.weights), tuple(map(float, space.low)),
        tuple(map(float, space.high)))
    return partial(typed_entry(kernel, constants, *arguments), constants)


@cache
def _kernel() -> Callable[..., None] | None:
    """:func:`_step` compiled (kept on disk by numba); None without numba."""
    return jit_with(_step, _HELPERS) if numba_module() is not None else None


def _approaching(contact: float, sx: float, sy: float, sz: float, ex: float, ey: float,
                 ez: float, ox: float, oy: float, oz: float) -> bool:
    """``vector._approaching`` on one row."""
    dx, dy, dz = ex - ox, ey - oy, ez - oz
    end_gap = math.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = sx - ox, sy - oy, sz - oz
    return end_gap < contact and end_gap < math.sqrt(dx * dx + dy * dy + dz * dz)


def _near(k: StepConstants, i: int, x: float, y: float, z: float, pilings: Any,
          piling_top: Any, floor_north: Any, floor_east: Any, floor_shallowest: Any) -> bool:
    """Whether the ROV at (x, y, z) may be within reach of the floor or a piling (more
    often than ``vector._scene_clear``'s broad phase, never less)."""
    depth = z + k.margin
    if floor_north.size and depth >= k.shallowest_floor and (
            floor_north[0] <= x <= floor_north[-1] and floor_east[0] <= y <= floor_east[-1]):
        a = min(max(np.searchsorted(floor_north, x, side="right") - 1, 0), floor_north.size - 2)
        b = min(max(np.searchsorted(floor_east, y, side="right") - 1, 0), floor_east.size - 2)
        if depth >= floor_shallowest[a, b]:
            return True
    for j in range(pilings.shape[1]):
        reach = pilings[i, j, 2] + k.margin
        if (abs(x - pilings[i, j, 0]) <= reach and abs(y - pilings[i, j, 1]) <= reach
                and depth >= piling_top[i, j]):
            return True
    return False


def _pilot(k: StepConstants, i: int, diver: Any, diver_desired: Any, vertices: Any,
           vertex_count: Any, direction: Any, target_vertex: Any, closest: Any, capture: Any,
           slip: Any, loiter_speed: Any, hold_depth: Any, courses: Any) -> None:
    """``TrailDiverVectorEnv._pilot`` on one row that is due."""
    hn, he = diver[i, 0], diver[i, 1]
    v = target_vertex[i]
    dist = math.hypot(vertices[i, v, 0] - hn, vertices[i, v, 1] - he)
    c = closest[i]
    arrived = dist <= capture[i] or (c <= slip[i] and dist > c + 1e-9)
    closest[i] = c if dist <= capture[i] else min(c, dist)
    if arrived:
        v = (v + direction[i]) % vertex_count[i]
        target_vertex[i] = v
        fresh = math.hypot(vertices[i, v, 0] - hn, vertices[i, v, 1] - he)
        closest[i] = math.inf if fresh <= capture[i] else fresh
    bearing = math.degrees(math.atan2(vertices[i, v, 1] - he, vertices[i, v, 0] - hn)) % 360.0
    nearest = round((bearing - k.course_low) / k.course_delta) % k.course_points  # half even
    diver_desired[i, 0] = courses[nearest]
    diver_desired[i, 1] = loiter_speed[i]
    diver_desired[i, 2] = hold_depth[i]


def _control(k: StepConstants, ops: Any, i: int, ticks: Any, rov: Any, rov_inputs: Any,
             rov_desired: Any, rov_hold: Any, held: Any, diver: Any, diver_inputs: Any,
             diver_desired: Any) -> None:
    """``TrailDiverVectorEnv._control`` on one row: the controllers that are due."""
    if ticks[i] % k.diver_period == 0:
        d = diver_desired[i]
        diver_inputs[i, 0], diver_inputs[i, 1], diver_inputs[i, 2] = diver_control_kernel(
            k.diver_gains, k.diver_params, diver[i, 2], diver[i, 3], d[0], d[1], d[2], ops)
    if ticks[i] % k.rov_period == 0:
        if rov_hold[i]:
            rov_inputs[i, 0], rov_inputs[i, 1], rov_inputs[i, 2] = held[i, 0], held[i, 1], \
                held[i, 2]
        else:
            d = rov_desired[i]
            rov_inputs[i, 0], rov_inputs[i, 1], rov_inputs[i, 2] = p_control_kernel(
                k.rov_gains, k.rov_params, rov[i, 2], rov[i, 3], rov[i, 4], d[0], d[1], d[2],
                ops, 0.0)


def _step(k: StepConstants, rows: Any, ticks_left: Any, pending: Any, free: Any,
          diver_next: Any, rov_next: Any, diver_hit: Any, collided: Any, ticks: Any, rov: Any,
          rov_inputs: Any, rov_desired: Any, rov_hold: Any, held: Any, diver: Any,
          diver_inputs: Any, diver_desired: Any, vertices: Any, vertex_count: Any,
          direction: Any, target_vertex: Any, closest: Any, capture: Any, slip: Any,
          loiter_speed: Any, hold_depth: Any, pilings: Any, piling_top: Any,
          floor_north: Any, floor_east: Any, floor_shallowest: Any, courses: Any,
          geometry: Any, terms: Any, obs: Any) -> None:
    """Run ``ticks_left[i]`` ticks of each row ``i`` of ``rows``, then measure it
    (:func:`_measure`). A row whose move ends near the floor or a piling stops with
    ``pending[i]`` set (its moves in ``diver_next``, ``rov_next``, ``diver_hit``),
    unmeasured, until called again with the free fraction of the ROV's move in
    ``free[i]``. Each row reads and writes its own elements alone. (The ticks are written
    here, not in a function called per row: numba would count the references of every
    array passed at each call.)"""
    ops = float_ops()
    for i in rows:
        while ticks_left[i] > 0:
            if pending[i]:
                pending[i] = False
                fraction = free[i]
            else:
                speed, yaw_rate, vertical = body_rates_kernel(
                    diver_inputs[i, 0], diver_inputs[i, 1], diver_inputs[i, 2], k.diver_params,
                    ops)
                dn, de, dd, dpsi = step_exact_kernel(diver[i, 0], diver[i, 1], diver[i, 2],
                                                     diver[i, 3], speed, yaw_rate, vertical,
                                                     k.dt, ops)
                dd = max(dd, 0.0)
                hit = _approaching(k.contact, diver[i, 0], diver[i, 1], diver[i, 2], dn, de, dd,
                                   rov[i, 0], rov[i, 1], rov[i, 2])
                if hit:
                    dn, de, dd = diver[i, 0], diver[i, 1], diver[i, 2]
                diver_next[i, 0], diver_next[i, 1] = dn, de
                diver_next[i, 2], diver_next[i, 3] = dd, dpsi
                diver_hit[i] = hit
                surge, heave, yaw_moment = videoray.body_forces(
                    rov_inputs[i, 0], rov_inputs[i, 1], rov_inputs[i, 2], k.rov_params, ops)
                state = _RK4(rov[i, 0], rov[i, 1], rov[i, 2], rov[i, 3], rov[i, 4], rov[i, 5],
                             rov[i, 6], rov[i, 7], surge, heave + 0.0, yaw_moment,
                             k.coefficients, k.h, k.substeps)
                for j in range(8):
                    rov_next[i, j] = state[j]
                if rov_next[i, 2] < 0.0:
                    rov_next[i, 2] = 0.0
                    rov_next[i, 6] = max(rov_next[i, 6], 0.0)
                if _approaching(k.contact, rov[i, 0], rov[i, 1], rov[i, 2], rov_next[i, 0],
                                rov_next[i, 1], rov_next[i, 2], dn, de, dd):
                    fraction = 0.0
                elif _near(k, i, rov_next[i, 0], rov_next[i, 1], rov_next[i, 2], pilings,
                           piling_top, floor_north, floor_east, floor_shallowest):
                    pending[i] = True
                    break
                else:
                    fraction = 1.0
            rov_hit = fraction < 1.0
            if rov_hit:  # stopped just short of the contact
                cut = max(0.0, fraction - 1e-3)
                for j in range(3):
                    rov_next[i, j] = rov[i, j] + (rov_next[i, j] - rov[i, j]) * cut
                for j in range(4, 7):
                    rov_next[i, j] = 0.0
            for j in range(4):
                diver[i, j] = diver_next[i, j]
            for j in range(8):
                rov[i, j] = rov_next[i, j]
            collided[i] = collided[i] or diver_hit[i] or rov_hit
            ticks[i] += 1
            ticks_left[i] -= 1
            if ticks[i] % k.pilot_period == 0:
                _pilot(k, i, diver, diver_desired, vertices, vertex_count, direction,
                       target_vertex, closest, capture, slip, loiter_speed, hold_depth, courses)
            _control(k, ops, i, ticks, rov, rov_inputs, rov_desired, rov_hold, held, diver,
                     diver_inputs, diver_desired)
        if not pending[i]:
            _measure(k, ops, i, rov, diver, rov_inputs, diver_inputs, collided, geometry,
                     terms, obs)


def _measure(k: StepConstants, ops: Any, i: int, rov: Any, diver: Any, rov_inputs: Any,
             diver_inputs: Any, collided: Any, geometry: Any, terms: Any, obs: Any) -> None:
    """Row ``i``'s ``geometry[:, i]`` (trail point north, east, down; 3-D error, range
    (m), bearing error (deg), depth error (m)), reward ``terms[:4, i]``
    (task.REWARD_TERMS order; the last, ``lost``, is the caller's) and float32
    observation ``obs[i]``: ``TrailDiverVectorEnv._geometry``, ``_reward_terms`` and
    ``_observe`` on one row."""
    w, limit = k.weights, THRUSTER_LIMIT
    wanted = diver[i, 3] + k.trail_angle
    px = diver[i, 0] + k.trail_range * math.cos(wanted)
    py = diver[i, 1] + k.trail_range * math.sin(wanted)
    pz = diver[i, 2]
    dx, dy, dz = rov[i, 0] - diver[i, 0], rov[i, 1] - diver[i, 1], rov[i, 2] - diver[i, 2]
    ex, ey, ez = rov[i, 0] - px, rov[i, 1] - py, rov[i, 2] - pz
    error = math.sqrt(ex * ex + ey * ey + ez * ez)
    range_m = math.hypot(dx, dy)
    bearing_error = wrap_180(math.degrees(math.atan2(dy, dx)) - math.degrees(wanted))
    geometry[0, i], geometry[1, i], geometry[2, i] = px, py, pz
    geometry[3, i], geometry[4, i], geometry[5, i], geometry[6, i] = \
        error, range_m, bearing_error, dz
    u0, u1, u2 = rov_inputs[i, 0] / limit, rov_inputs[i, 1] / limit, rov_inputs[i, 2] / limit
    terms[0, i] = w.trail_position * (1.0 - min(error / w.position_scale_m, 1.0))
    terms[1, i] = -w.bearing * abs(bearing_error) / 180.0
    terms[2, i] = -w.collision if collided[i] else 0.0
    terms[3, i] = -w.energy * ((u0 * u0 + u1 * u1 + u2 * u2) / 3.0)
    yaw = rov[i, 3]
    c, s = math.cos(yaw), math.sin(yaw)
    tn, te = px - rov[i, 0], py - rov[i, 1]
    vn, ve = -dx, -dy
    rel = diver[i, 3] - yaw
    speed = abs(body_rates_kernel(diver_inputs[i, 0], diver_inputs[i, 1],
                                  diver_inputs[i, 2], k.diver_params, ops)[0])
    values = (c * tn + s * te, -s * tn + c * te, pz - rov[i, 2],
              c * vn + s * ve, -s * vn + c * ve, -dz, math.sin(rel), math.cos(rel),
              speed, rov[i, 4], rov[i, 5], rov[i, 6], rov[i, 7], rov[i, 2])
    for j in range(14):
        obs[i, j] = min(max(values[j], k.low[j]), k.high[j])


#: The VideoRay's RK4 on one vehicle's floats (compiled where called, as the helpers are).
_RK4 = videoray._FLOAT_KERNEL

_HELPERS = (_RK4, body_rates_kernel, step_exact_kernel, leg_inputs, videoray.linear_thrust,
            videoray.body_forces, feedforward_input, p_control_kernel, diver_control_kernel,
            _approaching, _near, _pilot, _control, _measure)
