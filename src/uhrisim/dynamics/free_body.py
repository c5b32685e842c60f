"""Free bodies in water: a released tool sinks or rises to its terminal speed and rests.

An object no hand or gripper holds moves under its in-water weight and quadratic drag,
with the added mass of the water it accelerates (Newman, *Marine Hydrodynamics*, 1977,
§4.13; Fossen, *Handbook of Marine Craft Hydrodynamics and Motion Control*, 2011, §6):

    (m + C_a rho V) dv/dt = W e_down - 1/2 rho C_d A |v_r| v_r,   v_r = v - v_water
    W = (m - rho (V + V_gas)) g

so that, falling from rest, it approaches the terminal speed ``sqrt(2 |W| / (rho C_d A))``
(``v(t) = v_t tanh(g' t / v_t)`` with ``g' = W / (m + C_a rho V)``, :func:`fall_speed`).
The object does not rotate (its attitude is kept). ``V_gas`` is the gas of an open-bottom
lift bag, which follows Boyle's law with depth and spills what the bag cannot hold
(:func:`gas_volume`): a bag that starts to rise swells and rises faster, as real lift bags
do (US Navy Diving Manual, Rev. 7, 2016, salvage lift bags).

State ``x`` (6,): ``[north, east, down, v_north, v_east, v_down]`` (NED m, m/s). The
caller (the simulation) tells :func:`step` the floor depth under the object; an object
heavier than the water it displaces rests there, one lighter floats up to the surface.

Constants: sea water 1025 kg/m³ (typical surface sea water; the UNESCO EOS-80 equation of
state gives 1023-1028 kg/m³ at 35 psu, 5-25 °C), g = 9.80665 m/s² (standard gravity),
one standard atmosphere 101 325 Pa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.checks import require_positive
from uhrisim.core.errors import ConfigError

WATER_DENSITY = 1025.0  # kg/m³
GRAVITY = 9.80665  # m/s²
ATMOSPHERE_PA = 101_325.0  # Pa
STATE_SIZE = 6


@dataclass(frozen=True)
class Hydro:
    """What the water does to a rigid object (SI).

    Attributes:
        mass: mass in air (kg).
        volume: volume the solid displaces (m³).
        drag_coefficient: C_d on ``area`` (Hoerner, *Fluid-Dynamic Drag*, 1965: a sphere
            ~0.47, a cylinder across the flow ~1.2, a flat plate face-on ~1.2).
        area: reference (projected) area (m²).
        added_mass_coefficient: C_a, added mass over displaced mass (sphere 0.5; a default
            for compact tools).
        bottom_offset: depth of its lowest point below its reference point when resting
            (m); it rests when the reference point is this far above the floor.
    """

    mass: float
    volume: float
    drag_coefficient: float
    area: float
    added_mass_coefficient: float = 0.5
    bottom_offset: float = 0.0

    def __post_init__(self) -> None:
        require_positive(self, ("mass", "volume", "drag_coefficient", "area"), "Hydro")
        require_positive(self, ("added_mass_coefficient", "bottom_offset"), "Hydro",
                         allow_zero=True)

    def in_water_weight(self, gas_volume: float = 0.0, rho: float = WATER_DENSITY) -> float:
        """Weight minus buoyancy (N, > 0 sinks) with ``gas_volume`` (m³) of buoyant gas."""
        return in_water_weight(self.mass, self.volume, gas_volume, rho)

    def inertia(self, rho: float = WATER_DENSITY) -> float:
        """Mass plus added mass (kg)."""
        return self.mass + self.added_mass_coefficient * rho * self.volume

    def terminal_speed(self, gas_volume: float = 0.0, rho: float = WATER_DENSITY) -> float:
        """|v| (m/s) at which drag balances the in-water weight: sqrt(2|W| / (rho C_d A))."""
        weight = abs(self.in_water_weight(gas_volume, rho))
        return math.sqrt(2.0 * weight / (rho * self.drag_coefficient * self.area))


def in_water_weight(mass: float, volume: float, gas_volume: float = 0.0,
                    rho: float = WATER_DENSITY) -> float:
    """Weight minus buoyancy (N, > 0 sinks) of ``mass`` (kg) displacing ``volume`` (m³),
    with ``gas_volume`` (m³) of buoyant gas."""
    return (mass - rho * (volume + gas_volume)) * GRAVITY


def combined_weight(*parts: Hydro, gas_volume: float = 0.0) -> float:
    """The in-water weight (N) of :func:`combine` (``parts``) with ``gas_volume`` (m³) of
    gas: the same number, without making the assembly (its drag needs its size)."""
    return in_water_weight(sum(p.mass for p in parts), sum(p.volume for p in parts),
                           gas_volume)


def rests(depth: float, weight: float, resting_depth: float) -> bool:
    """Whether an object whose reference point is at ``depth`` (m) with in-water weight
    ``weight`` (N) rests where its reference point is at ``resting_depth`` (m; NaN: no
    floor): it is there (within 1 nm) and does not float (what :func:`step` asks first;
    it then stays with its depth ``resting_depth`` and no velocity)."""
    return math.isfinite(resting_depth) and depth >= resting_depth - 1e-9 and weight >= 0.0


def combine(*parts: Hydro, drag_coefficient: float, area: float,
            bottom_offset: float = 0.0) -> Hydro:
    """One rigid object of several (a load and the lift bag fast to it): masses, volumes
    and added masses add; the drag is that of the assembly (``drag_coefficient`` on
    ``area``)."""
    mass = sum(p.mass for p in parts)
    volume = sum(p.volume for p in parts)
    added = sum(p.added_mass_coefficient * p.volume for p in parts)
    return Hydro(mass, volume, drag_coefficient, area, added / volume, bottom_offset)


def gas_volume(surface_litres: float, depth: float, capacity_m3: float = math.inf,
               rho: float = WATER_DENSITY) -> float:
    """Volume (m³) of ``surface_litres`` of gas (litres at one atmosphere) at ``depth``
    (m, down): Boyle's law ``V = n p0 / (p0 + rho g z)``, capped at ``capacity_m3`` (an
    open-bottom bag spills the rest). Above the surface it is the surface volume."""
    pressure = ATMOSPHERE_PA + rho * GRAVITY * max(depth, 0.0)
    return min(1e-3 * surface_litres * ATMOSPHERE_PA / pressure, capacity_m3)


def xdot(t: float, x: ArrayLike, hydro: Hydro, gas_m3: float = 0.0,
         water_velocity: ArrayLike = (0.0, 0.0, 0.0), rho: float = WATER_DENSITY
         ) -> NDArray[np.float64]:
    """Time derivative of the state (module docstring). Pure. ``gas_m3``: buoyant gas
    volume (m³, held over the step); ``water_velocity``: the current, NED m/s."""
    del t
    x = np.asarray(x, dtype=float)
    relative = x[3:] - np.asarray(water_velocity, dtype=float)
    drag = -0.5 * rho * hydro.drag_coefficient * hydro.area * np.linalg.norm(relative) * relative
    force = drag + np.array([0.0, 0.0, hydro.in_water_weight(gas_m3, rho)])
    return np.concatenate([x[3:], force / hydro.inertia(rho)])


def fall_speed(hydro: Hydro, t: float, gas_m3: float = 0.0, rho: float = WATER_DENSITY
               ) -> float:
    """Exact vertical speed (m/s, down positive) ``t`` s after release from rest in still
    water: ``v_t tanh(g' t / v_t)``, negative for a rising object."""
    weight = hydro.in_water_weight(gas_m3, rho)
    if weight == 0.0:
        return 0.0
    v_t = hydro.terminal_speed(gas_m3, rho)
    accel = abs(weight) / hydro.inertia(rho)
    return math.copysign(v_t * math.tanh(accel * t / v_t), weight)


def _substeps(x: NDArray[np.float64], hydro: Hydro, gas_m3: float, dt: float, rho: float) -> int:
    """RK4 sub-steps for ``dt``: each at most 0.3 of the drag time constant
    (m + m_a) / (rho C_d A |v|) at the larger of the speed and the terminal speed."""
    speed = max(float(np.linalg.norm(x[3:])), hydro.terminal_speed(gas_m3, rho), 1e-3)
    tau = hydro.inertia(rho) / (rho * hydro.drag_coefficient * hydro.area * speed)
    return max(1, math.ceil(dt / (0.3 * tau)))


def step(x: ArrayLike, hydro: Hydro, dt: float, floor_depth: float, gas_m3: float = 0.0,
         water_velocity: ArrayLike = (0.0, 0.0, 0.0), rho: float = WATER_DENSITY
         ) -> tuple[NDArray[np.float64], str]:
    """Advance a free object by ``dt`` s (RK4, sub-stepped for stability), then apply the
    floor (``floor_depth``, m, under the object; NaN: no floor) and the surface.

    Returns the new state and where it is: ``"water"``, ``"floor"`` (resting: its lowest
    point on the floor, velocity zero; a negatively buoyant object stays) or
    ``"surface"`` (floating at z = 0, vertical speed zero).
    """
    x = np.array(x, dtype=float)
    if x.shape != (STATE_SIZE,) or not np.all(np.isfinite(x)):
        raise ConfigError(f"state must be {STATE_SIZE} finite numbers, got {x!r}",
                          where="free_body.step")
    weight = hydro.in_water_weight(gas_m3, rho)
    resting_depth = floor_depth - hydro.bottom_offset
    if rests(x[2], weight, resting_depth):
        x[2], x[3:] = resting_depth, 0.0
        return x, "floor"
    n = _substeps(x, hydro, gas_m3, dt, rho)
    h = dt / n
    for _ in range(n):
        k1 = xdot(0.0, x, hydro, gas_m3, water_velocity, rho)
        k2 = xdot(0.0, x + 0.5 * h * k1, hydro, gas_m3, water_velocity, rho)
        k3 = xdot(0.0, x + 0.5 * h * k2, hydro, gas_m3, water_velocity, rho)
        k4 = xdot(0.0, x + h * k3, hydro, gas_m3, water_velocity, rho)
        x = x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
    if math.isfinite(resting_depth) and x[2] >= resting_depth and weight >= 0.0:
        x[2], x[3:] = resting_depth, 0.0
        return x, "floor"
    if x[2] <= 0.0 and weight < 0.0:
        x[2], x[5] = 0.0, 0.0
        return x, "surface"
    return x, "water"
