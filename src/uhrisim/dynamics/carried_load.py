"""How a carried object enters the VideoRay's equations of motion (paper eqs 1-4).

An object held rigidly by the ROV (in its gripper) moves with it, so in the 4-DOF model
of :mod:`uhrisim.dynamics.videoray`:

* **inertia** adds: its mass and added mass to the surge, sway and heave inertias
  (``m11 + m + a``, ...), and about the yaw axis ``(m + a)(x² + y²)`` (parallel-axis
  theorem, the object taken as a point at ``position_frd``);
* **heave force** adds its in-water weight ``W = (m - rho V) g`` (FRD z is down, so a
  sinking tool pulls +Z); the vehicle, trimmed neutral without it, must hold depth with
  ``T_vert = W`` more vertical thrust (:func:`hover_command`), and when that exceeds the
  thruster it sinks at the speed where the heave damping takes the rest
  (``Z_w w + Z_ww |w| w = T_max - W``);
* **drag** adds the object's own quadratic drag ``1/2 rho C_d A`` to ``X_uu`` and
  ``Z_ww`` (it is towed through the water), ``A`` the object's area **projected across
  each axis**: towed ahead (surge) the water meets its face across the vehicle's x, in
  heave the one across its z. For a box of sides ``a × b × c`` (its own x, y, z) turned
  by ``R`` (its frame → the vehicle's), the area seen along a unit direction ``n`` is
  ``|n·R e_x| b c + |n·R e_y| a c + |n·R e_z| a b`` (the faces' shadows; exact for a
  box, :func:`box_projected_areas`). ``C_d`` is the object's own (the catalogue's flat
  plate face-on, 1.2: Hoerner, *Fluid-Dynamic Drag*, 1965, 1.17-1.28; a blunt block met
  on a smaller face has ~1.05, the cube's, in the same source — so an edge-on tow is
  still slightly pessimistic). The teamwork stage passes a held tool's areas from its
  box and its pose in the jaws (the folded lift bag, 0.35 × 0.25 × 0.10 m, gripped at the
  planned fetch heading shows ~0.043 m² ahead where its largest face is 0.0875 m²,
  docs/hri.md). Without ``areas_frd`` the object's one reference area serves every axis.
* **moments** of an off-centre weight, ``(y W, -x W)`` about roll and pitch, have no
  place in the 4-DOF model (roll and pitch are held at zero: planes of symmetry, paper
  §II); the vehicle **trims** instead until its righting moment ``m_v g BG sin(theta)``
  balances them (:func:`trim_angles`); VideoRay trims its Pro 4 the same way with ballast
  in the skid pods (Pro 4 Ultra Operator's Manual, "Buoyancy and Depth Control",
  download.videoray.com).

:func:`loaded_params` gives the VideoRay parameters with the load;
:func:`xdot_loaded` is :func:`uhrisim.dynamics.videoray.xdot` with them plus the
weight's heave force — a pure function the batched physics can take over unchanged.

The vehicle's righting arm (``VIDEORAY_BG_M``, centre of gravity 2 cm below the centre of
buoyancy) and its mass in air 6.1 kg are **assumptions** for the Pro 4 (floats on top,
ballast below; no published BG).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.dynamics import videoray
from uhrisim.dynamics.free_body import GRAVITY, WATER_DENSITY, Hydro

VIDEORAY_MASS_KG = 6.1
VIDEORAY_BG_M = 0.02


@dataclass(frozen=True)
class CarriedLoad:
    """An object fixed to the vehicle: its water properties and where its centre is
    (body FRD, m, from the vehicle's reference point)."""

    hydro: Hydro
    position_frd: tuple[float, float, float]
    #: its areas (m²) projected across the vehicle's x, y and z (module docstring);
    #: None: ``hydro.area`` on every axis
    areas_frd: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        p = np.asarray(self.position_frd, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ConfigError(f"must be 3 finite numbers, got {self.position_frd!r}",
                              where="CarriedLoad.position_frd")
        if self.areas_frd is not None:
            a = np.asarray(self.areas_frd, dtype=float)
            if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a <= 0.0):
                raise ConfigError(f"must be 3 areas > 0 m², got {self.areas_frd!r}",
                                  where="CarriedLoad.areas_frd")

    def drag_frd(self) -> NDArray[np.float64]:
        """Its quadratic drag ``1/2 rho C_d A`` along the vehicle's x, y, z (kg/m)."""
        areas = (np.full(3, self.hydro.area) if self.areas_frd is None
                 else np.asarray(self.areas_frd, dtype=float))
        return 0.5 * WATER_DENSITY * self.hydro.drag_coefficient * areas

    @property
    def in_water_weight(self) -> float:
        """W (N), > 0 pulls the vehicle down."""
        return self.hydro.in_water_weight()

    @property
    def rigid_and_added_mass(self) -> float:
        """m + C_a rho V (kg)."""
        return self.hydro.inertia()


def loaded_params(params: videoray.VideoRayParams, load: CarriedLoad
                  ) -> videoray.VideoRayParams:
    """The VideoRay's parameters with ``load`` carried (module docstring): inertias and
    quadratic drag. The weight is not a parameter of eqs 1-4: see :func:`heave_bias`."""
    m = load.rigid_and_added_mass
    x, y, _ = load.position_frd
    surge, _, heave = (float(d) for d in load.drag_frd())
    return replace(params, m11=params.m11 + m, m22=params.m22 + m, m33=params.m33 + m,
                   J=params.J + m * (x * x + y * y), Xuu=params.Xuu - surge,
                   Zww=params.Zww - heave)


def box_projected_areas(size: ArrayLike, rotation: ArrayLike) -> tuple[float, float, float]:
    """Areas (m²) of a box of sides ``size`` (its own x, y, z; m) turned by ``rotation``
    (its frame → the vehicle's) seen along the vehicle's x, y and z (module docstring)."""
    a, b, c = (float(v) for v in np.asarray(size, dtype=float))
    faces = np.array([b * c, a * c, a * b])  # across its own x, y, z
    return tuple(float(v) for v in np.abs(np.asarray(rotation, dtype=float)) @ faces)


def heave_bias(load: CarriedLoad) -> float:
    """Extra heave force (N, FRD: down positive) of the load: its in-water weight."""
    return load.in_water_weight


def xdot_loaded(t: float, x: ArrayLike, u: ArrayLike, params: videoray.VideoRayParams,
                load: CarriedLoad) -> NDArray[np.float64]:
    """Eqs 1-4 with ``load`` carried: :func:`videoray.xdot` on :func:`loaded_params`
    plus ``W / m33'`` in heave. Pure; batch-aware like ``videoray.xdot``."""
    loaded = loaded_params(params, load)
    out = videoray.xdot(t, x, u, loaded)
    out[..., 6] += heave_bias(load) / loaded.m33
    return out


def _inverse_vertical(thrust: float, params: videoray.VideoRayParams) -> float:
    """Vertical command giving ``thrust`` N up (unsaturated inverse of the map)."""
    if params.thrust_map == "linear":
        return thrust / params.ct_vertical_linear
    ct = params.ct_vertical_up_quadratic if thrust >= 0 else params.ct_vertical_down_quadratic
    return math.copysign(math.sqrt(abs(thrust) / ct), thrust)


class Hover(NamedTuple):
    """What holding depth with a load takes: the vertical command (saturated at the
    limit), whether it saturates, the command an unlimited thruster would need, and the
    steady vertical speed that results (m/s, down positive; 0 when it holds)."""

    command: float
    saturated: bool
    needed_command: float
    steady_heave: float


def hover_command(params: videoray.VideoRayParams, load: CarriedLoad) -> Hover:
    """The extra vertical thrust to hold depth with ``load`` equals its in-water weight
    (steady state, ``w = 0``: ``-T_vert + W = 0``), through the inverse thruster map.
    Beyond the input limit the thruster saturates and the vehicle sinks (or rises) at the
    speed where the heave damping balances the remainder."""
    weight = load.in_water_weight
    needed = _inverse_vertical(weight, params)
    if abs(needed) <= params.input_limit:
        return Hover(needed, False, needed, 0.0)
    command = math.copysign(params.input_limit, needed)
    thrust = float(videoray.thruster_forces(np.array([0.0, 0.0, command]), params)[2])
    loaded = loaded_params(params, load)
    heave = videoray.steady_speed(weight - thrust, loaded.Zw, loaded.Zww)
    return Hover(command, True, needed, heave)


def max_hover_weight(params: videoray.VideoRayParams) -> float:
    """The largest in-water weight (N) the vertical thruster can hold at depth."""
    full = np.array([0.0, 0.0, params.input_limit])
    return float(videoray.thruster_forces(full, params)[2])


def trim_angles(load: CarriedLoad, vehicle_mass: float = VIDEORAY_MASS_KG,
                bg: float = VIDEORAY_BG_M) -> tuple[float, float]:
    """Static (roll, pitch) in radians the vehicle takes with ``load`` hanging off-centre
    (module docstring): ``sin(theta) = moment / (m_v g BG)``. Positive pitch is bow up: a
    sinking load forward of the centre pitches the bow down. NaN when the moment exceeds
    the righting moment (the vehicle cannot trim: it would roll or pitch over)."""
    weight = load.in_water_weight
    x, y, _ = load.position_frd
    righting = vehicle_mass * GRAVITY * bg
    roll_s, pitch_s = y * weight / righting, -x * weight / righting

    def angle(s: float) -> float:
        return math.asin(s) if abs(s) <= 1.0 else math.nan

    return angle(roll_s), angle(pitch_s)
