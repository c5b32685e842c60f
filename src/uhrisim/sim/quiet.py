"""Quiet ticks in one compiled call (numba, ``uhrisim[fast]``).

Most ticks of a mission only move the agents and, at the control rate, run their
controllers: no helm, NAV_* post, contact report, sensor, event or hook is due. When
nobody looks at the ticks (:meth:`Simulation.run <uhrisim.sim.simulation.Simulation.run>`
without hooks), :meth:`QuietTicks.run` does a stretch of such ticks in one compiled call
instead of one Python tick each: the same kernels as the Python path (the VideoRay's RK4
and the diver's exact step of :mod:`uhrisim.dynamics`, the controllers'
:func:`~uhrisim.control.videoray_p.p_control_kernel` and
:func:`~uhrisim.control.diver.diver_control_kernel`), in the same order, on floats — the
same numbers bit for bit (a test holds a run to the tick-by-tick path).

The stretch does only what needs no decision of the loop. It stops before any tick where
an agent's move leaves a non-finite state, ends within reach of another agent (its
collision sphere plus 1e-6 m: touching or not, approaching or not) or may reach the sea
floor or a static object (the loop's own broad phase, ``Simulation._near_static``); the
loop then does that tick as always. It serves the VideoRay (its plant and P controller)
and the swimming diver (its plant and controller); a scenario with any other agent, a
team stage, bubbles, an assistant, movable objects, sonar contacts or an agent without a
driver steps tick by tick, as does every run without numba (``UHRISIM_NUMBA=0``: the
reference path).
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any, NamedTuple

import numpy as np

from uhrisim.control.diver import DiverController, DiverGains, diver_control_kernel
from uhrisim.control.videoray_p import (
    PGains,
    VideoRayPController,
    feedforward_input,
    p_control_kernel,
)
from uhrisim.core.compiled import float_ops, jit_with, record, typed_entry
from uhrisim.dynamics import videoray
from uhrisim.dynamics.diver import DiverParams, body_rates_kernel, leg_inputs, step_exact_kernel
from uhrisim.dynamics.plants import DiverPlant, VideoRayPlant
from uhrisim.world.kick import kick_phase_rate

#: agent kinds of the compiled stretch
_VIDEORAY, _DIVER = 0, 1
#: the largest state of a kind (the VideoRay's 8)
_STATE_COLUMNS = 8
#: a move that ends this close (m) to a touch, the floor or an object stops the stretch
#: (the loop's own checks then decide, exactly)
_SLACK = 1e-6


class QuietConstants(NamedTuple):
    """What the compiled stretch reads of the simulation and its agents' kinds (one
    argument: numba's disk cache keeps the kernel whatever the values). Every VideoRay
    shares the first five, every diver the next four."""

    rov_plant: Any           # record of the plants' VideoRayParams (thrust_map: its code)
    coefficients: tuple      # videoray.RateCoefficients of those parameters
    substeps: int            # RK4 steps a tick
    rov_control: Any         # record of the controllers' VideoRayParams
    rov_gains: Any           # record of PGains
    held_load_input: float   # the controllers' vertical feed-forward
    diver_plant: Any         # record of the plants' DiverParams
    diver_control: Any       # record of the controllers' DiverParams
    diver_gains: Any         # record of DiverGains
    dt: float                # physics step (s)
    shallowest_floor: float  # m (inf without a floor)
    floor_slope: float       # the floor's steepest slope (m/m)


class QuietTicks:
    """The compiled stretch of a simulation's quiet ticks; :meth:`of` says whether it can
    serve the simulation at all, :meth:`run` does the stretch that is due."""

    def __init__(self, sim: Any, constants: QuietConstants, kinds: np.ndarray) -> None:
        self._sim = sim
        self._agents = tuple(sim.agents.values())
        n = len(self._agents)
        self._kinds = kinds
        self._states = np.zeros((n, _STATE_COLUMNS))
        self._inputs = np.zeros((n, 3))
        self._desired = np.zeros((n, 3))
        self._kick = np.zeros(n)
        self._radii = np.array([a.radius for a in self._agents], dtype=float)
        self._control_periods = np.array([a.control_period for a in self._agents],
                                         dtype=np.int64)
        self._surface_stops = np.array([-1 if a.model.surface_stops is None
                                        else a.model.surface_stops for a in self._agents],
                                       dtype=np.int64)
        self._diver_bodies = np.array([a.is_diver_body for a in self._agents])
        self._sizes = [a.state.size for a in self._agents]
        self._call = None
        self._constants = constants
        #: after a stretch that stopped at its first tick, no new one before this tick
        #: (a vehicle near the floor would otherwise start one every tick)
        self._idle_until = 0

    @classmethod
    def of(cls, sim: Any) -> QuietTicks | None:
        """The stretch for ``sim`` (a :class:`~uhrisim.sim.simulation.Simulation`), or
        None where every tick must be the loop's (module docstring)."""
        if (_kernel() is None or sim.team is not None or sim.assistance is not None
                or sim.bubbles.active or sim.sonar_contacts.observers):
            return None
        kinds = [_kind(agent, sim.dt) for agent in sim.agents.values()]
        if None in kinds or any(a.driver is None for a in sim.agents.values()):
            return None
        rovs = [a for a, kind in zip(sim.agents.values(), kinds, strict=True)
                if kind == _VIDEORAY]
        divers = [a for a, kind in zip(sim.agents.values(), kinds, strict=True)
                  if kind == _DIVER]
        rov_settings = {(videoray.kernel_record(a.plant.params), a.plant._coefficient_values,
                         a.plant.integrator.substeps, videoray.kernel_record(a.controller.params),
                         record(a.controller.gains), a.controller.held_load_input)
                        for a in rovs}
        diver_settings = {(record(a.plant.params), record(a.controller.params),
                           record(a.controller.gains)) for a in divers}
        if len(rov_settings) > 1 or len(diver_settings) > 1:
            return None  # (vehicles of one kind with different settings: not served)
        unused_rov = videoray.VideoRayParams()  # (a kind no agent is: any settings)
        unused = videoray.kernel_record(unused_rov)
        rov = rov_settings.pop() if rov_settings else (
            unused, tuple(videoray.RateCoefficients.of(unused_rov)), 1, unused,
            record(PGains(heading=1.0, speed=1.0, depth=1.0)), 0.0)
        diver = diver_settings.pop() if diver_settings else (
            record(DiverParams()), record(DiverParams()), record(DiverGains()))
        constants = QuietConstants(*rov, *diver, float(sim.dt),
                                   float(sim._shallowest_floor), float(sim._floor_slope))
        return cls(sim, constants, np.array(kinds, dtype=np.int64))

    def run(self, end_tick: int, progress: bool) -> tuple[int, bool]:
        """Do the quiet ticks from the simulation's tick on, up to the next one where
        something is due (and not past ``end_tick``; ``progress``: every 100th tick is
        due, for a progress report), and that tick's moves. Returns how many ticks were
        advanced (0: the next tick is the loop's) and whether the last of them only
        moved: then the loop does the rest of it (``Simulation._after_moves``)."""
        sim = self._sim
        tick = sim.tick
        if (sim._inbox or sim._waiting_events or sim._has_movable_objects
                or tick < self._idle_until):
            return 0, False
        due = min(end_tick + 1, sim.contacts.next_due(tick))
        if progress:
            due = min(due, (tick // 100 + 1) * 100)
        for agent in self._agents:
            if (agent.in_contact or agent.actuator_override is not None
                    or agent.directed is not None):
                return 0, False
            due = min(due, _next_multiple(tick, agent.driver_period))
            if sim.raycaster is not None:
                for slot in (*agent.sonars, *agent.cameras):
                    due = min(due, _next_multiple(tick, slot.period))
        busy = due <= end_tick  # (else the stretch ends with the run)
        count = due - tick - (0 if busy else 1)
        states, inputs, desired, kick = self._states, self._inputs, self._desired, self._kick
        for i, agent in enumerate(self._agents):
            states[i, :self._sizes[i]] = agent.state
            inputs[i] = agent.inputs
            desired[i] = agent.desired()
            kick[i] = agent.kick_phase
        arguments = (tick, count, busy, self._kinds, states, inputs, desired, kick, self._radii,
                     self._control_periods, self._surface_stops, self._diver_bodies,
                     *sim._static_boxes)  # (an event may add an object)
        if self._call is None:
            self._call = typed_entry(_kernel(), self._constants, *arguments)
        done, controlled = self._call(self._constants, *arguments)
        if done == 0:
            self._idle_until = due
            return 0, False
        for i, agent in enumerate(self._agents):
            agent.update(state=states[i, :self._sizes[i]].copy(),
                         inputs=inputs[i].copy() if controlled else None)
            agent.kick_phase = float(kick[i])
        sim.tick = tick + done
        sim._scene_dirty = True
        return done, busy and done == count


def _kind(agent: Any, dt: float) -> int | None:
    """The compiled stretch's kind of ``agent``, None when it does not serve it."""
    plant, controller = agent.plant, agent.controller
    if plant.dt != dt:
        return None
    if type(plant) is VideoRayPlant and type(controller) is VideoRayPController:
        return None if agent.is_diver_body else _VIDEORAY
    if type(plant) is DiverPlant and type(controller) is DiverController:
        return _DIVER
    return None


def _next_multiple(tick: int, period: int) -> int:
    """The first tick after ``tick`` that is a multiple of ``period``."""
    return (tick // period + 1) * period


@cache
def _kernel() -> Any:
    """:func:`_quiet_ticks` compiled (kept on disk by numba); None without numba."""
    global _RK4
    _RK4 = videoray._compiled_kernel()
    return None if _RK4 is None else jit_with(_quiet_ticks, _HELPERS)


def _quiet_ticks(k: QuietConstants, tick: int, count: int, busy: bool, kinds: Any,
                 states: Any,
                 inputs: Any, desired: Any, kick: Any, radii: Any, control_periods: Any,
                 surface_stops: Any, diver_bodies: Any, lows: Any, highs: Any
                 ) -> tuple[int, bool]:
    """Up to ``count`` ticks after ``tick``: each agent's move (in the loop's order, each
    checked against the others' positions as the loop sees them), then the controllers
    that are due — but on the last tick when it is ``busy`` (the loop does the rest of
    it). Stops before a move the loop must make (module docstring). ``states`` (n, 8),
    ``inputs`` (n, 3), ``kick`` (n,) are changed in place; returns the ticks done and
    whether a controller ran."""
    ops = float_ops()
    n = kinds.shape[0]
    moved = np.empty((n, _STATE_COLUMNS))
    swim = np.zeros(n)
    controlled = False
    for done in range(count):
        for a in range(n):
            if kinds[a] == _VIDEORAY:
                surge, heave, yaw_moment = videoray.body_forces(
                    inputs[a, 0], inputs[a, 1], inputs[a, 2], k.rov_plant, ops)
                new = _RK4(states[a, 0], states[a, 1], states[a, 2], states[a, 3],
                           states[a, 4], states[a, 5], states[a, 6], states[a, 7], surge,
                           heave + 0.0, yaw_moment, k.coefficients,
                           k.dt / k.substeps, k.substeps)
                total = 0.0
                for j in range(8):
                    moved[a, j] = new[j]
                    total += new[j]
            else:
                speed, yaw_rate, vertical = body_rates_kernel(
                    inputs[a, 0], inputs[a, 1], inputs[a, 2], k.diver_plant, ops)
                north, east, depth, psi = step_exact_kernel(
                    states[a, 0], states[a, 1], states[a, 2], states[a, 3], speed, yaw_rate,
                    vertical, k.dt, ops)
                moved[a, 0], moved[a, 1], moved[a, 2], moved[a, 3] = north, east, depth, psi
                total = north + east + depth + psi
                swim[a] = speed
            if not math.isfinite(total):
                return done, controlled
            if moved[a, 2] < 0.0:  # the surface
                moved[a, 2] = 0.0
                if surface_stops[a] >= 0:
                    moved[a, surface_stops[a]] = max(moved[a, surface_stops[a]], 0.0)
            if _loop_decides(k, a, states, moved, radii, lows, highs):
                return done, controlled
        for a in range(n):
            size = 8 if kinds[a] == _VIDEORAY else 4
            for j in range(size):
                states[a, j] = moved[a, j]
            if diver_bodies[a]:
                kick[a] += kick_phase_rate(swim[a], ops) * k.dt
        if busy and done == count - 1:
            break
        now = tick + done + 1
        for a in range(n):
            if now % control_periods[a] == 0:
                controlled = True
                d = desired[a]
                if kinds[a] == _VIDEORAY:
                    inputs[a, 0], inputs[a, 1], inputs[a, 2] = p_control_kernel(
                        k.rov_gains, k.rov_control, states[a, 2], states[a, 3], states[a, 4],
                        d[0], d[1], d[2], ops, k.held_load_input)
                else:
                    inputs[a, 0], inputs[a, 1], inputs[a, 2] = diver_control_kernel(
                        k.diver_gains, k.diver_control, states[a, 2], states[a, 3], d[0],
                        d[1], d[2], ops)
    return count, controlled


def _loop_decides(k: QuietConstants, a: int, states: Any, moved: Any, radii: Any,
                  lows: Any, highs: Any) -> bool:
    """Whether agent ``a``'s move (``states[a]`` to ``moved[a]``) ends where the loop must
    decide: within reach of another agent (those before ``a`` have moved this tick), of
    the floor (``Simulation._near_static``'s reach with :data:`_SLACK` more) or of a
    static object's box."""
    ex, ey, ez = moved[a, 0], moved[a, 1], moved[a, 2]
    for b in range(states.shape[0]):
        if b == a:
            continue
        other = moved if b < a else states
        dx, dy, dz = ex - other[b, 0], ey - other[b, 1], ez - other[b, 2]
        if math.sqrt(dx * dx + dy * dy + dz * dz) < radii[a] + radii[b] + _SLACK:
            return True
    dx, dy, dz = ex - states[a, 0], ey - states[a, 1], ez - states[a, 2]
    step_m = math.sqrt(dx * dx + dy * dy + dz * dz)
    if ez + floor_reach(radii[a], step_m, k.floor_slope) + _SLACK >= k.shallowest_floor:
        return True
    margin = radii[a] + BOX_MARGIN_M + _SLACK
    for i in range(lows.shape[0]):
        if (lows[i, 0] - margin <= ex <= highs[i, 0] + margin
                and lows[i, 1] - margin <= ey <= highs[i, 1] + margin
                and lows[i, 2] - margin <= ez <= highs[i, 2] + margin):
            return True
    return False


#: how far (m) beyond an agent's radius the broad phase looks for static objects' boxes
BOX_MARGIN_M = 0.5


def floor_reach(radius: float, step_m: float, floor_slope: float) -> float:
    """How far (m) below the end of a move of ``step_m`` the broad phase looks for the
    floor (``Simulation._near_static``): a hit of the narrow phase's ray bundle lies within
    radius + step of the end, where the floor is at most max slope x that shallower."""
    return (radius + step_m) * (1.0 + floor_slope) + 1e-6


#: The VideoRay's RK4 on one vehicle's floats, the one-vehicle path's own compiled kernel
#: (:func:`uhrisim.dynamics.videoray.rk4_one`), set by :func:`_kernel`: numba calls it
#: instead of compiling a copy inside the stretch (on a cold cache 6 s -> 4 s of CPU).
_RK4: Any = None

_HELPERS = (body_rates_kernel, step_exact_kernel, leg_inputs, videoray.linear_thrust,
            videoray.body_forces, feedforward_input, p_control_kernel, diver_control_kernel,
            kick_phase_rate, floor_reach, _loop_decides)
