"""The vehicle models a scenario can put in the water, and the parts each is made of.

One :class:`VehicleModel` per ``agents[].model`` name (``videoray``, ``diver``,
``diver_boots``, ``kinematic``) in :data:`MODELS`: how to make its plant and its controller from its
scenario sections, and the facts the rest of the simulator needs of it — its collision
sphere, how it stops against an obstacle and at the surface, what it reports as a
contact (MOOS TYPE and length), the 3-D body it has, how fast it can be commanded to go,
whether it takes thruster commands. Nothing else compares model names: add a vehicle by
adding an entry here (docs/layout.md). The protocols say what each part must offer the
loop (:class:`Plant`, :class:`Controller`, :class:`Driver`, :class:`Sensor`).

Units and frames: docs/conventions.md (SI, NED, FRD).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from uhrisim.control.diver import DiverController, DiverGains, WalkerController
from uhrisim.control.marine_pid import MarinePidController, MarinePidGains
from uhrisim.control.videoray_p import GAIN_PRESETS, VideoRayPController
from uhrisim.core.errors import ConfigError
from uhrisim.dynamics.diver import DiverParams, leg_inputs
from uhrisim.dynamics.diver_body import Anthropometry, DiverSkeleton
from uhrisim.dynamics.diver_boots import BootsParams, FloorDepth
from uhrisim.dynamics.kinematic import KinematicParams
from uhrisim.dynamics.plants import (
    BootsPlant,
    DiverPlant,
    KinematicPlant,
    NavState,
    VideoRayPlant,
    carrying,
)
from uhrisim.dynamics.videoray import VideoRayParams, generalized_forces, steady_speed
from uhrisim.world.kick import flutter_kick


class Plant(Protocol):
    """A vehicle's dynamics, stepped by the loop: ``step`` returns a new state (the old
    one stays as it was); ``nav`` is navigation truth of a state and its inputs."""

    params: Any
    input_size: int

    def initial_state(self, position_ned: NDArray, yaw: float) -> NDArray: ...

    def step(self, t: float, x: NDArray, u: NDArray) -> NDArray: ...

    def nav(self, x: NDArray, u: NDArray) -> NavState: ...


class Controller(Protocol):
    """Turns the desired heading (compass deg), speed (m/s) and depth (m) into the
    plant's inputs for a state."""

    def inputs(self, x: NDArray, desired_heading_deg: float, desired_speed: float,
               desired_depth: float) -> NDArray: ...


class Driver(Protocol):
    """What decides an agent's DESIRED_* (a helm, a script): ``tick`` at its rate, with
    the agent (``uhrisim.sim.state.Agent``); returns a helm record or None."""

    def tick(self, t: float, agent: Any) -> Any: ...


class Sensor(Protocol):
    """A sensor that casts rays into the scene from its mount (sonar, camera): ``sense``
    is its ``ping`` or ``capture``, ``(raycaster, position NED, rotation body→NED, t,
    exclude=...)`` -> its output (a ping, a frame)."""

    mount_position: NDArray
    mount_rotation: NDArray


@dataclass(frozen=True)
class DiverBody:
    """What the teamwork stage (:mod:`uhrisim.sim.teamwork`) needs of a diver model:

    ``skeleton(agent config, plant)``: its articulated body
    (:class:`~uhrisim.dynamics.diver_body.DiverSkeleton`); ``directed_inputs(plant, x,
    speed, turn_rate, depth)``: the plant inputs that carry out an order executor's
    directive (m/s, rad/s, m or None; :mod:`uhrisim.teamwork.executor`); ``legs(plant, x,
    q, kick_phase)``: ``q`` with the legs as the body moves them (rad); ``footfalls(plant,
    x_before, x_after)``: the soles (NED m) set down between two states (they stir silt);
    ``walks``: it walks on the sea floor (weighted boots), else it swims.
    """

    skeleton: Callable[[Any, Any], DiverSkeleton]
    directed_inputs: Callable[[Any, NDArray, float, float, float | None], NDArray]
    legs: Callable[[Any, NDArray, NDArray, float], NDArray]
    footfalls: Callable[[Any, NDArray, NDArray], list[NDArray]]
    walks: bool


@dataclass(frozen=True)
class VehicleModel:
    """One vehicle model (module docstring).

    ``make_plant(agent config, dt, name, floor)`` and ``make_controller(agent config,
    plant)`` build its parts from the agent's scenario sections (``floor``: the sea
    floor's depth (m) at (north, east), None without one; a model that ``walks`` on it
    refuses None). ``collision_radius`` (m) of the
    sphere the loop keeps clear of the scene and the other agents; ``contact_stops``: the
    state components (velocities) an obstacle sets to zero; ``surface_stops``: the
    component (heave, down positive) the surface keeps from going up; ``vehicle_type``
    and ``length`` (m): what its node reports say by default; ``body``: its 3-D body in
    the scene (``videoray`` or ``diver``); ``viewer_kind``: how the viewer draws it;
    ``thrusters``: it takes [port, starboard, vertical] thruster commands;
    ``max_speed(plant params)`` (m/s): the fastest it can be commanded to go.
    ``diver``: a diver's articulated body and how orders drive it (:class:`DiverBody`),
    None for a vehicle; ``carrying(plant, load)``: its plant with a
    :class:`~uhrisim.dynamics.carried_load.CarriedLoad` in its gripper (None: nothing),
    for a vehicle that can carry one.
    """

    name: str
    make_plant: Callable[..., Plant]
    make_controller: Callable[[Any, Plant], Controller]
    collision_radius: float
    contact_stops: slice | None
    surface_stops: int | None
    vehicle_type: str
    length: float
    body: Literal["videoray", "diver", "figure"]
    viewer_kind: Literal["rov", "diver", "vehicle"]
    thrusters: bool
    max_speed: Callable[[Any], float]
    diver: DiverBody | None = None
    carrying: Callable[[Any, Any], Plant] | None = None


def _videoray_plant(cfg: Any, dt: float, name: str, floor: FloorDepth | None = None
                    ) -> VideoRayPlant:
    del floor
    return VideoRayPlant(VideoRayParams(**cfg.videoray.model_dump()), dt, name=name)


def _videoray_controller(cfg: Any, plant: Plant) -> VideoRayPController:
    given = {k: v for k, v in cfg.controller.model_dump().items()
             if k != "preset" and v is not None}
    return VideoRayPController(dataclasses.replace(GAIN_PRESETS[cfg.controller.preset],
                                                   **given), plant.params)


def _videoray_max_speed(params: VideoRayParams) -> float:
    """Thrust-drag balance at full forward thrust of both horizontal thrusters."""
    lim = params.input_limit
    surge = float(generalized_forces(np.array([lim, lim, 0.0]), params)[0])
    return abs(steady_speed(surge, params.Xu, params.Xuu))


def _diver_plant(cfg: Any, dt: float, name: str, floor: FloorDepth | None = None
                 ) -> DiverPlant:
    del floor
    limits = cfg.diver_limits
    return DiverPlant(DiverParams(max_speed=limits.max_speed,
                                  max_turn_rate=math.radians(limits.max_turn_rate_deg),
                                  max_vertical_rate=limits.max_vertical_rate), dt, name=name)


def _skeleton(cfg: Any, kind: Literal["scuba", "boots"]) -> DiverSkeleton:
    section = cfg.skeleton
    return DiverSkeleton(Anthropometry(section.stature_m), kind, section.rom_factor)


def _boots_plant(cfg: Any, dt: float, name: str, floor: FloorDepth | None = None
                 ) -> BootsPlant:
    if floor is None:
        raise ConfigError("a diver on weighted boots walks on the sea floor: give the "
                          "scenario a world.seafloor")
    return BootsPlant(BootsParams(skeleton=_skeleton(cfg, "boots")), dt, floor, name=name)


#: Vertical rate (m/s) per metre of depth error of a swimming diver carrying out orders.
SWIM_DEPTH_GAIN = 0.5


def _swimmer_inputs(plant: DiverPlant, x: NDArray, speed: float, turn_rate: float,
                    depth: float | None) -> NDArray:
    vertical = 0.0 if depth is None else SWIM_DEPTH_GAIN * (depth - float(x[2]))
    return np.array(leg_inputs(speed, turn_rate, vertical, plant.params))


def _walker_inputs(plant: BootsPlant, x: NDArray, speed: float, turn_rate: float,
                   depth: float | None) -> NDArray:
    del plant, x, depth  # a walker stays on the floor
    return np.array([speed, turn_rate, 0.0, 0.0])


def _swimmer_legs(plant: DiverPlant, x: NDArray, q: NDArray, kick_phase: float) -> NDArray:
    del plant, x
    return flutter_kick(_SCUBA, q, kick_phase)


def _walker_legs(plant: BootsPlant, x: NDArray, q: NDArray, kick_phase: float) -> NDArray:
    del kick_phase
    return plant.leg_angles(x, q)


def _walker_footfalls(plant: BootsPlant, before: NDArray, after: NDArray) -> list[NDArray]:
    return [f.position for f in plant.footfalls(before, after)]


_SCUBA = DiverSkeleton()  # the swimmer's legs kick alike whatever its stature


#: Collision spheres (m): VideoRay hull ~0.38 x 0.29 x 0.22 m; a prone diver with fins is
#: ~2.3 m long, a 0.6 m sphere covers the torso and tank where contact matters.
MODELS: dict[str, VehicleModel] = {m.name: m for m in (
    VehicleModel("videoray", _videoray_plant, _videoray_controller, collision_radius=0.25,
                 contact_stops=slice(4, 7), surface_stops=6, vehicle_type="UUV", length=0.38,
                 body="videoray", viewer_kind="rov", thrusters=True,
                 max_speed=_videoray_max_speed, carrying=carrying),
    VehicleModel("diver", _diver_plant,
                 lambda cfg, plant: DiverController(DiverGains(), plant.params),
                 collision_radius=0.6, contact_stops=None, surface_stops=None,
                 vehicle_type="DIVER", length=2.3, body="diver", viewer_kind="diver",
                 thrusters=False, max_speed=lambda params: params.max_speed,
                 diver=DiverBody(lambda cfg, plant: _skeleton(cfg, "scuba"), _swimmer_inputs,
                                 _swimmer_legs, lambda plant, before, after: [],
                                 walks=False)),
    # uSimMarine-style: thrust (%) = thrust_factor x speed, at most 100 %; looks like a ROV
    VehicleModel("kinematic",
                 lambda cfg, dt, name, floor=None: KinematicPlant(KinematicParams(), dt, name=name),
                 lambda cfg, plant: MarinePidController(MarinePidGains()),
                 collision_radius=0.5, contact_stops=slice(4, 5), surface_stops=None,
                 vehicle_type="UUV", length=1.0, body="videoray", viewer_kind="vehicle",
                 thrusters=False, max_speed=lambda params: 100.0 / params.thrust_factor),
    # the commercial diver on weighted boots (the paper's next diver model): a standing
    # diver's 0.6 m sphere is centred at the hips, 0.93 m above the soles
    VehicleModel("diver_boots", _boots_plant,
                 lambda cfg, plant: WalkerController(DiverGains()),
                 collision_radius=0.6, contact_stops=None, surface_stops=None,
                 vehicle_type="DIVER", length=0.5, body="figure", viewer_kind="diver",
                 thrusters=False, max_speed=lambda params: params.max_speed,
                 diver=DiverBody(lambda cfg, plant: plant.params.skeleton, _walker_inputs,
                                 _walker_legs, _walker_footfalls, walks=True)),
)}

def vehicle_model(name: str) -> VehicleModel:
    """The model called ``name`` (KeyError naming the known ones otherwise)."""
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError(f"unknown vehicle model {name!r}; known: {', '.join(MODELS)}") from None
