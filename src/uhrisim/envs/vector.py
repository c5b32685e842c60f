"""A native Gymnasium vector environment of the trail task: N episodes stepped as arrays.

``gymnasium.make_vec("uhrisim/TrailDiverState-v0", num_envs=N,
vectorization_mode="vector_entry_point")`` gives :class:`TrailDiverVectorEnv`: one process,
every step a handful of numpy calls over all N episodes, no Python loop over vehicles.

Per episode it keeps what :class:`~uhrisim.envs.trail_diver.TrailDiverEnv` (the
single env on the ordinary Simulation) has: the episode drawn from its seed by the same
:class:`~uhrisim.envs.episodes.TrailEpisodes` (start poses, the diver's loiter ring and
speed, pilings), the same VideoRay and diver models and controllers (the one physics path,
:func:`uhrisim.dynamics.videoray.rk4_steps`, :func:`uhrisim.dynamics.diver.step_exact`,
``inputs_many`` of the controllers; paper eqs 1-13), the same tick order (dynamics, the
diver's 4 Hz pilot, controllers), the same actions, observation, named reward terms,
termination and truncation (:mod:`uhrisim.envs.task`).

Two parts of the Simulation are replaced by array code for this task, and a test
(tests/integration/test_envs_vector.py) holds the result to the single envs, step for step:

* the diver's helm (ConstantDepth + Loiter) by a **batched loiter pilot**: it swims the
  episode's loiter polygon toward one vertex after another, reached within
  ``capture_radius`` or by slip (the closest approach within ``slip_radius`` and
  growing: IvP's WaypointEngine rule, as BHV_Loiter has it); its desired heading is the
  course grid's value nearest the bearing to the vertex, its speed and depth are the
  helm's own decisions for the behaviors' functions (computed once an episode), and
  BHV_Loiter itself (:class:`~uhrisim.autonomy.behaviors.loiter.Loiter`) says which
  vertex comes first. A bearing exactly halfway between two grid courses could round
  the other way than the helm's argmax; nothing else differs;
* the collision checks by the Simulation's own rules on arrays: bodies' spheres
  "touching and approaching", and for the ROV the sea floor and pilings through the
  Simulation's broad phase over all rows, then its swept-sphere narrow phase
  (:meth:`~uhrisim.world.scene.Scene.segment_clear`) for the few rows near one. The
  diver's moves are not checked against the floor and pilings (the randomised loiter
  ring keeps clear of both).

With numba (``uhrisim[fast]``) the ticks of a step and its measures (geometry, reward
terms, observation) run in one compiled call, episode by episode
(:mod:`uhrisim.envs.vector_ticks`); the array code here is their reference, and a test
holds the two equal.

Autoreset: Gymnasium 1.x ``NEXT_STEP``: the step after an episode ends resets that
sub-environment (its action is ignored) and returns the new episode's first observation
with reward 0. Sub-environment ``i`` seeded with ``seed + i`` (``reset(seed=seed)``) or
``seed[i]`` draws the same episodes as ``TrailDiverEnv`` reset with that seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, ClassVar, NamedTuple

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space
from pydantic import ValidationError

from uhrisim.autonomy.behaviors.base import common_key
from uhrisim.autonomy.behaviors.constant_depth import ConstantDepth, ConstantDepthParams
from uhrisim.autonomy.behaviors.loiter import LOITER_SPEED_ZAIC, Loiter
from uhrisim.autonomy.config import (
    BehaviorSpec,
    build_behavior_spec,
    default_domain,
    parse_domain,
)
from uhrisim.autonomy.geometry import signed_dist_to_polygon
from uhrisim.autonomy.zaic import zaic_peak_on_axis
from uhrisim.core.clock import ticks_for_rate
from uhrisim.core.elementwise import ARRAYS
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned, wrap_180
from uhrisim.dynamics.diver import body_rates_kernel
from uhrisim.dynamics.plants import DiverPlant, VideoRayPlant, finite_or_raise
from uhrisim.envs.task import REWARD_TERMS, THRUSTER_LIMIT
from uhrisim.envs.trail_diver import SEED_SPAN, STATE_SIZE, EnvArgumentError, TrailDiverEnv
from uhrisim.envs.vector_ticks import compiled_step, floor_cells
from uhrisim.scenario.build_world import add_object, build_static_scene
from uhrisim.scenario.load import ScenarioFile
from uhrisim.scenario.schema import CylinderObject, Pose
from uhrisim.vehicles import MODELS
from uhrisim.world.scene import Scene

#: No sub-environments (row indices).
NO_ROWS = np.zeros(0, np.int64)


class Piling(NamedTuple):
    """A piling of an episode: its axis (NED north, east; m), radius (m), the depth of its
    top (m) and its cylinder object (the scenario's mapping, for its scene)."""

    north: float
    east: float
    radius: float
    top: float
    object: dict


class EpisodeStart(NamedTuple):
    """An episode's start as the vector env's arrays take it (:meth:`TrailDiverVectorEnv.
    _load`): poses (a Pose's fields: NED m, compass deg), the diver's loiter (vertices NED
    m, first vertex, direction +1 clockwise), capture and slip radii (m), the helm's speed
    (m/s) and depth (m) decisions, the pilings and the world's water (its mapping)."""

    seed: int
    rov: dict
    diver: dict
    vertices: list[tuple[float, float]]
    first: int
    direction: int
    capture_radius: float
    slip_radius: float
    loiter_speed: float
    hold_depth: float
    pilings: list[Piling]
    water: dict


class TrailDiverVectorEnv(gymnasium.vector.VectorEnv):
    """N episodes of the trail task as arrays (module docstring). Arguments as
    :class:`~uhrisim.envs.trail_diver.TrailDiverEnv` (``observation="state"`` only, on
    scenarios whose target is a diver flying a Loiter, whose follower is a VideoRay),
    plus ``num_envs`` and ``threads``: the compiled steps shared among that many threads
    (numba lets go of the GIL; helpers step running episodes while the caller begins new
    ones; each episode's arithmetic is its own, so the results are the same bit for bit;
    one by default)."""

    metadata: ClassVar[dict[str, Any]] = {"autoreset_mode": AutoresetMode.NEXT_STEP}
    #: Rows of one share of the compiled step when threads share it (``threads > 1``).
    step_chunk: int = 64
    #: Rows the compiled step moves in the time an episode begins (0.38 ms of Python
    #: against 8.1 us a row, N = 1 024, 2026-11-26): the helpers' first shares.
    rows_per_beginning: int = 48
    #: The single env's observation this class makes (a subclass makes another).
    OBSERVATION: ClassVar[str] = "state"

    def __init__(self, num_envs: int = 1, observation: str = "state", threads: int = 1,
                 **kwargs: Any) -> None:
        for name, value in (("num_envs", num_envs), ("threads", threads)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise EnvArgumentError(f"{name} must be an integer >= 1, got {value!r}")
        if observation != self.OBSERVATION:
            raise EnvArgumentError(f"{type(self).__name__} makes observation="
                                   f"{self.OBSERVATION!r}, not {observation!r}")
        if kwargs.get("scenario_hook") is not None:
            raise EnvArgumentError("the vector env does not take scenario_hook (its episodes "
                                   "are arrays, not scenario files)")
        # The single env checks the arguments and holds the spaces, episodes and weights.
        self.template = TrailDiverEnv(observation, **kwargs)
        t = self.template
        self.num_envs = num_envs
        self.single_action_space = t.action_space
        self.single_observation_space = t.observation_space
        self.action_space = batch_space(t.action_space, num_envs)
        self.observation_space = batch_space(t.observation_space, num_envs)
        self.command, self.weights = t.command, t.weights
        base = t.episodes.base
        agents = {a.name: a for a in base.agents}
        follower, target = agents[t.follower], agents[t.target]
        self.dt = 1.0 / t.episodes.physics_rate_hz
        self.ticks_per_step = round(t.control_step_s / self.dt)
        rov_model, diver_model = MODELS[follower.model], MODELS[target.model]
        self.rov_plant = rov_model.make_plant(follower, self.dt, follower.name)
        self.diver_plant = diver_model.make_plant(target, self.dt, target.name)
        if not (isinstance(self.rov_plant, VideoRayPlant)
                and isinstance(self.diver_plant, DiverPlant) and _loiter(target)):
            raise EnvArgumentError("the vector env flies a VideoRay follower behind a diver "
                                   "target whose helm has a Loiter behavior")
        self.rov_control = rov_model.make_controller(follower, self.rov_plant)
        self.diver_control = diver_model.make_controller(target, self.diver_plant)
        self.rov_control_period = _period(follower.control_rate_hz, self.dt)
        self.diver_control_period = _period(target.control_rate_hz, self.dt)
        self.pilot_period = ticks_for_rate(target.helm.rate_hz, self.dt, "diver helm rate")
        where = f"agents.{target.name}.helm.domain"
        self.domain = (parse_domain(dict(target.helm.domain), where) if target.helm.domain
                       else default_domain(where))
        self.rov_radius = rov_model.collision_radius
        self.contact_distance = rov_model.collision_radius + diver_model.collision_radius
        self._source = ScenarioFile(base.model_copy(update={
            "world": base.world.model_copy(update={"objects": ()})}), t.episodes.path)
        self.floor = build_static_scene(self._source)
        self.shallowest_floor = float(np.min(self.floor.seafloor.depth)) \
            if self.floor.seafloor is not None else np.inf
        self._allocate(num_envs)
        self._rngs = [seeding.np_random(None)[0] for _ in range(num_envs)]
        self._floor_cells = floor_cells(self.floor.seafloor)
        self._course_values = np.ascontiguousarray(self.domain.axis("course").values, float)
        self._decisions: dict[tuple, float] = {}
        # What every episode keeps of the scenario file (_drawn_start): the start poses,
        # the diver's Loiter (one behavior, reset for each episode) and ConstantDepth
        # parameters, the file's pilings
        loiter_items = _loiter(target)
        # (the env takes no scenario hook; a loiter centre given by one coordinate reads
        # the polygon, so the order of its mapping counts: then each episode's data is read)
        self._drawn_episodes = not ({"xcenter_assign", "ycenter_assign"}
                                    & {common_key(k) for k in loiter_items})
        loiter = _built("Loiter", loiter_items)
        self._loiter, self._loiter_params = loiter.instantiate(), loiter.params
        hold = _behavior(target, "ConstantDepth")
        self._hold_params = None if hold is None else _built("ConstantDepth", hold).params
        self._file_starts = (follower.start.model_dump(), target.start.model_dump())
        self._file_cylinders = [_cylinder(o) for o in base.world.objects
                                if isinstance(o, CylinderObject)]
        self._file_water = base.world.water.model_dump(exclude_unset=True)
        #: The compiled step (:mod:`uhrisim.envs.vector_ticks`; numba): the ticks and
        #: measures (geometry, reward terms, state observation) of a share of the rows, or
        #: None: the numpy ticks of :meth:`_run` and :meth:`_geometry`,
        #: :meth:`_reward_terms`, :meth:`_observe`, the reference (always so for a subclass
        #: that follows each tick, :meth:`_moved`). Set it to None to run the reference.
        self.step_kernel = (compiled_step(self, self._step_arguments(
            np.arange(num_envs), np.zeros(num_envs, np.int64), np.zeros(num_envs, bool)))
            if type(self)._moved is TrailDiverVectorEnv._moved else None)
        self.threads = threads if self.step_kernel is not None else 1
        #: The threads beside the caller's that share the compiled steps.
        self._step_helpers = (ThreadPoolExecutor(self.threads - 1, "uhrisim-steps")
                              if self.threads > 1 else None)

    def prepare(self) -> None:
        """Build now what the first move near the sea floor builds (the floor's collision
        ray caster: ~0.3 s for the default 115 200-triangle floor, once per env), so that a
        timed or latency-bound run of steps does not meet it part-way. Steps give the same
        results with or without it."""
        if self.floor.seafloor is not None:
            self.floor.segment_clear(np.zeros(3), np.array([0.0, 0.0, 1e-3]), self.rov_radius)

    def close_extras(self, **kwargs: Any) -> None:
        if self._step_helpers is not None:
            self._step_helpers.shutdown()

    # -- state ---------------------------------------------------------------------------
    def _allocate(self, n: int) -> None:
        z = np.zeros
        self.rov = z((n, 8))
        self.rov_inputs = z((n, 3))
        self.rov_desired = z((n, 3))        # heading (deg), speed (m/s), depth (m)
        self.rov_hold = z(n, dtype=bool)    # thruster command held for the step
        self._held = z((n, 3))
        self.diver = z((n, 4))
        self.diver_inputs = z((n, 3))
        self.diver_desired = z((n, 3))
        self.vertices = z((n, 10, 2))       # NED north, east of the loiter polygon
        self.vertex_count = np.ones(n, dtype=np.int64)
        self.direction = np.ones(n, dtype=np.int64)
        self.target_vertex = z(n, dtype=np.int64)
        self.closest = np.full(n, np.inf)
        self.capture_radius, self.slip_radius = z(n), z(n)
        self.loiter_speed, self.hold_depth = z(n), z(n)
        slots = self.template.episodes.randomization.clutter + sum(
            o.type == "cylinder" for o in self.template.episodes.base.world.objects)
        self.pilings = np.full((n, slots, 3), np.nan)  # north, east, radius (m)
        self.piling_top = np.full((n, slots), np.inf)  # depth of the top (m)
        self.ticks = z(n, dtype=np.int64)
        self._trail_point = z((n, 3))       # of the last _geometry (NED, m)
        self._diver_next, self._rov_next = z((n, 4)), z((n, 8))  # the compiled ticks' moves
        self._diver_hit, self._pending, self._free = z(n, bool), z(n, bool), z(n)
        self._measured = z((7, n))          # the compiled step's geometry (_measure)
        self._terms = z((len(REWARD_TERMS), n))
        self._state_obs = z((n, STATE_SIZE), np.float32)
        self.steps = z(n, dtype=np.int64)
        self.episode_seed = z(n, dtype=np.int64)
        self.needs_reset = np.ones(n, dtype=bool)
        self._piling_objects: list[list[Piling]] = [[] for _ in range(n)]
        self._piling_scenes: list[Scene | None] = [None] * n
        self.max_steps = self.template._max_steps

    # -- the Gymnasium API ---------------------------------------------------------------
    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every sub-environment (``options["reset_mask"]``: only those). ``seed``:
        sub-environment i gets ``seed + i``, or ``seed[i]`` from a list.
        ``options["episode_seeds"]``: the episode each sub-environment flies now (N
        integers, as the single env's ``episode_seed`` option; later episodes are drawn)."""
        options = dict(options or {})
        mask = np.asarray(options.pop("reset_mask", np.ones(self.num_envs, bool)), bool)
        episodes = options.pop("episode_seeds", None)
        if options:
            raise EnvArgumentError(f"unknown reset option(s) {sorted(options)}; the vector "
                                   "env takes reset_mask and episode_seeds")
        if episodes is not None and (len(episodes) != self.num_envs or not all(
                isinstance(e, int | np.integer) and 0 <= e <= SEED_SPAN for e in episodes)):
            raise EnvArgumentError(f"reset option episode_seeds must be {self.num_envs} "
                                   f"integers in [0, {SEED_SPAN}]")
        seeds = ([seed + i for i in range(self.num_envs)] if isinstance(seed, int)
                 else list(seed) if seed is not None else [None] * self.num_envs)
        if len(seeds) != self.num_envs:
            raise EnvArgumentError(f"reset seed list has {len(seeds)} entries, num_envs is "
                                   f"{self.num_envs}")
        for i in np.flatnonzero(mask):
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        self._begin(np.flatnonzero(mask), episodes)
        self._run(self.ticks_per_step, mask)
        geometry, _, _ = self._measure(np.zeros(self.num_envs, bool))
        return self._observe(), self._info(*geometry, None, None)

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                           dict[str, Any]]:
        actions = np.asarray(actions, dtype=np.float64)
        if actions.shape != (self.num_envs, 3) or not np.all(np.isfinite(actions)):
            raise gymnasium.error.InvalidAction(
                f"actions must be {self.num_envs} rows of 3 finite numbers ({self.command}), "
                f"got shape {actions.shape}")
        starting = self.needs_reset.copy()
        live = ~starting
        space = self.single_action_space
        actions = np.minimum(np.maximum(actions, space.low), space.high)  # np.clip's values
        self._act(actions, live)
        resetting = starting.any()
        collided = self._run(self.ticks_per_step, np.ones(self.num_envs, bool),
                             np.flatnonzero(starting))
        geometry, terms, lost = self._measure(collided)
        reward = sum(terms.values())
        terminated = (collided | lost) & live
        self.steps += live
        truncated = live & ~terminated & (self.steps >= self.max_steps)
        if resetting:
            reward[starting] = 0.0
            for values in terms.values():
                values[starting] = 0.0
        self.needs_reset = terminated | truncated
        reason = np.full(self.num_envs, None, dtype=object)
        if terminated.any():
            reason[terminated & lost] = "lost"
            reason[terminated & collided] = "collision"
        return (self._observe(), reward, terminated, truncated,
                self._info(*geometry, terms, reason))

    # -- episodes ------------------------------------------------------------------------
    def _begin(self, envs: np.ndarray, episodes: Any = None) -> None:
        """Start a new episode in each sub-environment of ``envs`` (``episodes[i]``, or
        drawn from its generator) with its controllers at rest; the step that follows
        (:meth:`_run`, with the live ones) is its first control step, as the single env's
        reset flies it."""
        if envs.size == 0:
            return
        seeds = [int(episodes[i]) if episodes is not None
                 else int(self._rngs[i].integers(0, SEED_SPAN)) for i in envs]
        starts = []
        for seed in seeds:
            try:
                starts.append(self._drawn_start(seed) if self._drawn_episodes
                              else self._scenario_start(seed))
            except (ConfigError, ValidationError) as error:
                raise EnvArgumentError(f"episode {seed}: {error}") from None
        self._load(envs, starts)
        self.needs_reset[envs] = False
        self.steps[envs] = 0
        mask = np.zeros(self.num_envs, bool)
        mask[envs] = True
        self._control(mask, first=True)

    def _drawn_start(self, seed: int) -> EpisodeStart:
        """The episode of ``seed`` from its draws alone
        (:meth:`~uhrisim.envs.episodes.TrailEpisodes.draw`) on the scenario file's values,
        read once: what :meth:`_scenario_start` reads from the whole episode's data
        (a test holds the two equal), without the data, its validation, or a behavior
        built for each episode."""
        drawn = self.template.episodes.draw(seed)
        rov = drawn.follower_start or self._file_starts[0]
        diver = {**self._file_starts[1], **(drawn.target_start or {})}
        loiter, params = self._loiter, self._loiter_params
        for key, value in (drawn.loiter or {}).items():  # BHV_Loiter's own handlers
            params = Loiter.HANDLERS[key](params, value, key, "loiter")
        loiter.params = params
        loiter.reset()
        hold = self._hold_params
        if hold is not None and drawn.target_start is not None:
            hold = ConstantDepth.HANDLERS["depth"](hold, drawn.target_start["depth"], "depth",
                                                   "hold")
        return self._start(seed, rov, diver, loiter, hold,
                           [*self._file_cylinders, *map(_cylinder, drawn.clutter)],
                           {**self._file_water, **(drawn.water or {})})

    def _scenario_start(self, seed: int) -> EpisodeStart:
        """The episode of ``seed`` from its whole scenario data
        (:meth:`~uhrisim.envs.episodes.TrailEpisodes.episode_data`: the scenario file's,
        validated when the env was made, randomised within its bounds); the few sections
        read here are validated by their own models. The reference of
        :meth:`_drawn_start`, and the way for a Loiter whose centre reads its polygon."""
        data = self.template.episodes.episode_data(seed)
        agents = {a["name"]: a for a in data["agents"]}
        rov, diver = agents[self.template.follower], agents[self.template.target]
        behaviors = (diver.get("helm") or {}).get("behaviors", ())
        loiter = next(b for b in behaviors if b.get("type") == "Loiter")
        hold = next((b for b in behaviors if b.get("type") == "ConstantDepth"), None)
        cylinders = [_cylinder(CylinderObject.model_validate(o))
                     for o in (data.get("world") or {}).get("objects", ())
                     if o.get("type") == "cylinder"]
        return self._start(
            seed, Pose.model_validate(rov.get("start", {})).model_dump(),
            Pose.model_validate(diver.get("start", {})).model_dump(),
            _built("Loiter", loiter).instantiate(),
            None if hold is None else _built("ConstantDepth", hold).params, cylinders,
            (data.get("world") or {}).get("water", {}))

    def _start(self, seed: int, rov: dict, diver: dict, loiter: Loiter,
               hold: ConstantDepthParams | None, cylinders: list[Piling],
               water: dict) -> EpisodeStart:
        """An episode's start from its poses (a Pose's fields), its diver's Loiter behavior
        (reset with the episode's parameters), ConstantDepth parameters, pilings and
        water."""
        # BHV_Loiter itself says which vertex it approaches first: vertex 0, unless it starts
        # farther than acquire_dist outside the polygon (then its acquire rule picks one)
        x_east, y_north = moos_xy_from_ned(diver["north"], diver["east"])
        first, direction = loiter.index, loiter.direction
        p = loiter.params
        if signed_dist_to_polygon(x_east, y_north, loiter.vertices) > p.acquire_dist:
            first, direction = loiter.acquire(x_east, y_north, diver["heading_deg"] % 360.0)
        # The helm's speed and depth decisions: its argmax of the behaviors' ZAICs
        speed = self._decision(("speed", p.speed), lambda: _decided(
            self.domain.axis("speed"), p.speed, *LOITER_SPEED_ZAIC))
        depth = diver["depth"] if hold is None else self._decision(
            ("depth", hold), lambda: _decided(self.domain.axis("depth"), hold.depth,
                                              hold.peakwidth, hold.basewidth,
                                              hold.summitdelta))
        return EpisodeStart(
            seed, rov, diver, [(y, x) for x, y in loiter.vertices],  # MOOS (x east, y north) -> NED
            first, direction, p.capture_radius, p.slip_radius, speed, depth, cylinders,
            water)

    def _load(self, envs: np.ndarray, starts: list[EpisodeStart]) -> None:
        """The arrays of the sub-environments ``envs`` from their episodes' starts, written
        together."""
        def column(name: str) -> list:
            return [getattr(s, name) for s in starts]

        def pose(name: str, plant: Any) -> tuple[np.ndarray, np.ndarray]:
            poses = column(name)
            states = [plant.initial_state(np.array([q["north"], q["east"], q["depth"]]),
                                          math.radians(q["heading_deg"])) for q in poses]
            desired = [(q["heading_deg"] % 360.0, 0.0, q["depth"]) for q in poses]
            return np.array(states), np.array(desired)

        self.episode_seed[envs] = column("seed")
        self.ticks[envs] = 0
        self.rov[envs], self.rov_desired[envs] = pose("rov", self.rov_plant)
        self.rov_hold[envs] = False
        self.diver[envs], self.diver_desired[envs] = pose("diver", self.diver_plant)
        vertices = column("vertices")
        k = max(len(v) for v in vertices)
        if k > self.vertices.shape[1]:
            self.vertices = np.concatenate([self.vertices, np.zeros(
                (self.num_envs, k - self.vertices.shape[1], 2))], axis=1)
        for i, v in zip(envs, vertices, strict=True):
            self.vertices[i, :len(v)] = v
        self.vertex_count[envs] = [len(v) for v in vertices]
        self.direction[envs] = column("direction")
        self.target_vertex[envs] = column("first")
        self.capture_radius[envs] = column("capture_radius")
        self.slip_radius[envs] = column("slip_radius")
        self.loiter_speed[envs] = column("loiter_speed")
        self.hold_depth[envs] = column("hold_depth")
        self.closest[envs] = np.inf
        self.pilings[envs] = np.nan
        self.piling_top[envs] = np.inf
        slots = self.pilings.shape[1]
        for i, s in zip(envs, starts, strict=True):
            self._piling_objects[i], self._piling_scenes[i] = s.pilings, None
            for j, piling in enumerate(s.pilings[:slots]):
                self.pilings[i, j] = piling.north, piling.east, piling.radius
                self.piling_top[i, j] = piling.top

    def _decision(self, key: tuple, decide: Callable[[], float]) -> float:
        """The helm's decision for ``key`` (a behavior's parameters), made by ``decide`` the
        first time and kept (episodes draw their speeds and depths to the millimetre, so
        the same values come back)."""
        value = self._decisions.get(key)
        if value is None:
            value = self._decisions[key] = decide()
        return value

    # -- a step ----------------------------------------------------------------------------
    def _act(self, actions: np.ndarray, live: np.ndarray) -> None:
        """The actions of the live sub-environments, as the single env posts them."""
        if self.command == "thrusters":
            self.rov_hold = live.copy()
            self._held = actions
            return
        heading = heading_deg_from_yaw(self.rov[:, 3] + actions[:, 0])
        depth = np.maximum(0.0, self.rov[:, 2] + actions[:, 2])
        desired = np.stack([heading, actions[:, 1], depth], axis=-1)
        self.rov_desired[live] = desired[live]

    def _run(self, ticks: int, mask: np.ndarray, starting: np.ndarray = NO_ROWS) -> np.ndarray:
        """Advance the sub-environments of ``mask`` by ``ticks`` physics steps, those of
        ``starting`` (in ``mask``) in a new episode (:meth:`_begin`); which of them had the
        ROV touch something."""
        collided = np.zeros(self.num_envs, bool)
        if self.step_kernel is not None:
            return self._run_compiled(ticks, mask, starting, collided)
        self._begin(starting)
        rows: slice | np.ndarray = slice(None) if mask.all() else np.flatnonzero(mask)
        if not mask.any():
            return collided
        for _ in range(ticks):
            diver_before, rov_before = self.diver[rows], self.rov[rows]
            diver_after = self.diver_plant.step(0.0, diver_before, self.diver_inputs[rows])
            np.maximum(diver_after[:, 2], 0.0, out=diver_after[:, 2])
            diver_hit = _approaching(diver_before[:, :3], diver_after[:, :3],
                                     rov_before[:, :3], self.contact_distance)
            diver_after[diver_hit, :3] = diver_before[diver_hit, :3]
            rov_after = self.rov_plant.step(0.0, rov_before, self.rov_inputs[rows])
            above = rov_after[:, 2] < 0.0
            rov_after[above, 2] = 0.0
            rov_after[above, 6] = np.maximum(rov_after[above, 6], 0.0)
            bodies = _approaching(rov_before[:, :3], rov_after[:, :3], diver_after[:, :3],
                                  self.contact_distance)
            free = np.where(bodies, 0.0, self._scene_clear(rows, rov_before[:, :3],
                                                           rov_after[:, :3]))
            rov_hit = free < 1.0
            if rov_hit.any():  # stopped just short of the contact, as the Simulation does
                cut = np.maximum(0.0, free[rov_hit] - 1e-3)[:, None]
                before = rov_before[rov_hit, :3]
                rov_after[rov_hit, :3] = before + (rov_after[rov_hit, :3] - before) * cut
                rov_after[rov_hit, 4:7] = 0.0
            self.diver[rows], self.rov[rows] = diver_after, rov_after
            collided[rows] |= diver_hit | rov_hit
            self.ticks[rows] += 1
            self._moved(rows)
            self._pilot(mask)
            self._control(mask)
        return collided

    def _run_compiled(self, ticks: int, mask: np.ndarray, starting: np.ndarray,
                      collided: np.ndarray) -> np.ndarray:
        """:meth:`_run` by the compiled step, which also measures every row (those outside
        ``mask`` without a tick) for :meth:`_measure`; the narrow phase of the moves it
        leaves pending (near the floor or a piling) worked out here, between calls."""
        n = self.num_envs
        self._measured = np.empty((7, n))
        self._terms = np.empty((len(REWARD_TERMS), n))
        self._state_obs = np.empty((n, STATE_SIZE), np.float32)  # a new array each step
        self._pending[:] = False
        left = np.where(mask, ticks, 0)
        going = np.ones(n, bool)
        going[starting] = False
        self._share(np.flatnonzero(going), left, collided, starting)
        rows = starting  # begun by _share: their arrays as _begin left them
        while True:
            if rows.size:
                self.step_kernel(*self._step_arguments(rows, left, collided))
            rows = np.flatnonzero(self._pending)
            if not rows.size:
                break
            self._free[rows] = self._scene_clear(rows, self.rov[rows, :3],
                                                 self._rov_next[rows, :3])
        t = float(self.ticks.max() * self.dt)
        finite_or_raise(self.diver, self.diver_plant.name, t)
        finite_or_raise(self.rov, self.rov_plant.name, t)
        return collided

    def _step_arguments(self, rows: np.ndarray | None, ticks_left: np.ndarray,
                        collided: np.ndarray) -> tuple:
        """The compiled step's arguments (:func:`uhrisim.envs.vector_ticks._step`), of the
        same types at every call (its entry checks none)."""
        return (rows, ticks_left, self._pending, self._free, self._diver_next, self._rov_next,
                self._diver_hit, collided, self.ticks, self.rov, self.rov_inputs,
                self.rov_desired, self.rov_hold, self._held, self.diver, self.diver_inputs,
                self.diver_desired, self.vertices, self.vertex_count, self.direction,
                self.target_vertex, self.closest, self.capture_radius, self.slip_radius,
                self.loiter_speed, self.hold_depth, self.pilings, self.piling_top,
                *self._floor_cells, self._course_values, self._measured, self._terms,
                self._state_obs)

    def _share(self, rows: np.ndarray, ticks_left: np.ndarray, collided: np.ndarray,
               starting: np.ndarray) -> None:
        """The compiled step of ``rows`` while this thread begins the episodes of
        ``starting`` (:meth:`_begin`; other rows). With threads, the rows go in chunks of
        :attr:`step_chunk` that the helpers and this thread take in turn (a thread slowed
        by other work takes fewer); while this thread begins episodes (Python: it holds the
        GIL), each helper has a first chunk large enough not to need it
        (:attr:`rows_per_beginning`). Each chunk writes its rows alone."""
        arguments = self._step_arguments(None, ticks_left, collided)[1:]
        if self._step_helpers is None or rows.size < 2 * self.step_chunk:
            self._begin(starting)
            self.step_kernel(rows, *arguments)
            return
        helpers = self.threads - 1
        # the helpers' first shares, about as long as the beginnings (not more: a helper
        # slowed by other work would hold the step up)
        first = min(rows.size * helpers // self.threads,
                    starting.size * self.rows_per_beginning * helpers)
        shares = [*np.array_split(rows[:first], helpers)] if first else []
        shares += np.array_split(rows[first:], -(-(rows.size - first) // self.step_chunk))
        chunks = iter(shares)

        def work() -> None:
            for chunk in chunks:  # a list iterator: each chunk to one thread
                self.step_kernel(chunk, *arguments)

        running = [self._step_helpers.submit(work) for _ in range(helpers)]
        try:
            self._begin(starting)
            work()
        finally:  # the helpers done (or raised) before the arrays are read or changed
            for helper in running:
                helper.result()

    def _moved(self, rows: slice | np.ndarray) -> None:
        """After each physics tick of the sub-environments ``rows``, before their
        controllers: what a subclass keeps track of (nothing here)."""

    def _scene_clear(self, rows: slice | np.ndarray, start: np.ndarray,
                     end: np.ndarray) -> np.ndarray:
        """Fraction of each ROV move start→end (rows of ``rows``) free of the sea floor and
        the pilings: the Simulation's broad phase (within reach of the floor or of a
        piling's box) over all rows, then its narrow phase, the swept sphere of
        :meth:`~uhrisim.world.scene.Scene.segment_clear`, for the few rows near one."""
        margin = self.rov_radius + 0.5
        depth = end[:, 2] + margin
        near = np.zeros(len(end), bool)
        deep = np.flatnonzero(depth >= self.shallowest_floor)
        if deep.size:
            floor = np.asarray(self.floor.depth_at(end[deep, 0], end[deep, 1]), dtype=float)
            with np.errstate(invalid="ignore"):  # NaN off the floor's grid: no floor there
                near[deep] = depth[deep] >= floor
        if self.pilings.shape[1]:
            piles = self.pilings[rows]
            reach = piles[:, :, 2] + margin
            with np.errstate(invalid="ignore"):  # NaN slots: no piling there
                near |= ((np.abs(end[:, None, 0] - piles[:, :, 0]) <= reach)
                         & (np.abs(end[:, None, 1] - piles[:, :, 1]) <= reach)
                         & (depth[:, None] >= self.piling_top[rows])).any(axis=1)
        free = np.ones(len(end))
        envs = np.arange(self.num_envs)[rows]
        for k in np.flatnonzero(near):
            scenes = [self.floor, *self._piling_scene(int(envs[k]))]
            free[k] = min(scene.segment_clear(start[k], end[k], self.rov_radius)
                          for scene in scenes)
        return free

    def _piling_scene(self, i: int) -> list[Scene]:
        """Sub-environment ``i``'s pilings as a scene (built when first needed)."""
        if self._piling_scenes[i] is None:
            scene = Scene()
            for cylinder in self._cylinders(i):
                add_object(scene, cylinder, self._source, f"episode {self.episode_seed[i]}")
            self._piling_scenes[i] = scene
        return [self._piling_scenes[i]] if self._piling_objects[i] else []

    def _cylinders(self, i: int) -> list[CylinderObject]:
        """Sub-environment ``i``'s pilings as the scenario's cylinder objects."""
        return [CylinderObject.model_validate(p.object) for p in self._piling_objects[i]]

    def _pilot(self, mask: np.ndarray) -> None:
        """The diver's loiter pilot of the sub-environments in ``mask``, at its helm's rate
        (module docstring): arrival at the target vertex by capture or slip (IvP
        WaypointEngine's rule), then heading, speed and depth on the helm's grid."""
        due = np.flatnonzero(mask & (self.ticks % self.pilot_period == 0))
        if due.size == 0:
            return
        here = self.diver[due, :2]
        dist = self._vertex_distance(due, here)
        capture, closest = self.capture_radius[due], self.closest[due]
        arrived = (dist <= capture) | ((closest <= self.slip_radius[due])
                                       & (dist > closest + 1e-9))
        self.closest[due] = np.where(dist <= capture, closest, np.minimum(closest, dist))
        moved = due[arrived]
        if moved.size:
            self.target_vertex[moved] = ((self.target_vertex[moved] + self.direction[moved])
                                         % self.vertex_count[moved])
            fresh = self._vertex_distance(moved, self.diver[moved, :2])
            self.closest[moved] = np.where(fresh <= self.capture_radius[moved], np.inf, fresh)
        target = self.vertices[due, self.target_vertex[due]]
        bearing = np.degrees(np.arctan2(target[:, 1] - here[:, 1],
                                        target[:, 0] - here[:, 0])) % 360.0
        course = self.domain.axis("course")  # the grid course nearest the bearing
        nearest = np.rint((bearing - course.low) / course.delta).astype(np.int64) % course.npts
        self.diver_desired[due, 0] = course.values[nearest]
        self.diver_desired[due, 1] = self.loiter_speed[due]
        self.diver_desired[due, 2] = self.hold_depth[due]

    def _vertex_distance(self, envs: np.ndarray, here: np.ndarray) -> np.ndarray:
        """Horizontal distance (m) from ``here`` (NED north, east) to each sub-environment's
        target vertex."""
        target = self.vertices[envs, self.target_vertex[envs]]
        return np.hypot(target[:, 0] - here[:, 0], target[:, 1] - here[:, 1])

    def _control(self, mask: np.ndarray, first: bool = False) -> None:
        """Controllers of the sub-environments in ``mask`` that are due (all at a start)."""
        for kind, period in (("diver", self.diver_control_period),
                             ("rov", self.rov_control_period)):
            due = mask if first or period == 1 else mask & (self.ticks % period == 0)
            if not due.any():
                continue
            idx: slice | np.ndarray = slice(None) if due.all() else np.flatnonzero(due)
            if kind == "diver":
                d = self.diver_desired[idx]
                self.diver_inputs[idx] = self.diver_control.inputs_many(
                    self.diver[idx], d[:, 0], d[:, 1], d[:, 2])
                continue
            d = self.rov_desired[idx]
            inputs = self.rov_control.inputs_many(self.rov[idx], d[:, 0], d[:, 1], d[:, 2])
            held = self.rov_hold[idx]
            if held.any():
                inputs[held] = self._held[idx][held]
            self.rov_inputs[idx] = inputs

    # -- what the agent sees -------------------------------------------------------------
    def _measure(self, collided: np.ndarray) -> tuple[tuple[np.ndarray, ...],
                                                      dict[str, np.ndarray], np.ndarray]:
        """After a step: :meth:`_geometry`, :meth:`_reward_terms` and whether the diver is
        lost, by the compiled measures (which also form :meth:`_observe`'s observation)
        or on arrays."""
        if self.step_kernel is None:
            geometry = self._geometry()
            lost = geometry[2] > self.template.lost_range_m
            return geometry, self._reward_terms(geometry[1], geometry[3], collided, lost), lost
        measured, terms = self._measured, self._terms  # by _run's compiled step
        lost = measured[4] > self.template.lost_range_m
        terms[-1] = np.where(lost, -self.weights.lost, 0.0)
        self._trail_point = measured[:3].T
        return ((self._trail_point, *measured[3:]), dict(zip(REWARD_TERMS, terms, strict=True)),
                lost)

    def _geometry(self) -> tuple[np.ndarray, ...]:
        """Trail point (N, 3), 3-D error (m), horizontal range (m), bearing error (deg),
        depth error (m) of every sub-environment (:class:`~uhrisim.envs.task.TrailGeometry`);
        the trail point is kept for :meth:`_observe`."""
        trail_range, trail_angle = self.template._trail
        diver, rov = self.diver, self.rov[:, :3]
        wanted = diver[:, 3] + math.radians(trail_angle)
        point = np.empty((self.num_envs, 3))
        point[:, 0] = diver[:, 0] + trail_range * np.cos(wanted)
        point[:, 1] = diver[:, 1] + trail_range * np.sin(wanted)
        point[:, 2] = diver[:, 2]
        self._trail_point = point
        d = rov - diver[:, :3]
        bearing = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
        return (point, _row_norms(rov - point), np.hypot(d[:, 0], d[:, 1]),
                wrap_180(bearing - np.degrees(wanted)), d[:, 2])

    def _reward_terms(self, error: np.ndarray, bearing_error: np.ndarray,
                      collided: np.ndarray, lost: np.ndarray) -> dict[str, np.ndarray]:
        """The named terms of :func:`uhrisim.envs.task.reward_terms`, per sub-environment."""
        w = self.weights
        share = self.rov_inputs / THRUSTER_LIMIT
        share *= share
        effort = (share[:, 0] + share[:, 1] + share[:, 2]) / 3.0  # np.mean's sum, in order
        terms = {
            "trail_position": w.trail_position * (1.0 - np.minimum(error / w.position_scale_m,
                                                                   1.0)),
            "bearing": -w.bearing * np.abs(bearing_error) / 180.0,
            "collision": np.where(collided, -w.collision, 0.0),
            "energy": -w.energy * effort,
            "lost": np.where(lost, -w.lost, 0.0),
        }
        assert tuple(terms) == REWARD_TERMS
        return terms

    def _observe(self) -> np.ndarray:
        """The state observation of every sub-environment (docs/envs.md), float32, at the
        trail point of the last :meth:`_geometry`."""
        if self.step_kernel is not None:
            return self._state_obs
        rov, diver = self.rov, self.diver
        yaw = rov[:, 3]
        c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        ned = np.empty((self.num_envs, 6))  # trail point and diver from the ROV (m, NED)
        ned[:, :3] = self._trail_point
        ned[:, 3:] = diver[:, :3]
        ned[:, :3] -= rov[:, :3]
        ned[:, 3:] -= rov[:, :3]
        north, east = ned[:, 0::3], ned[:, 1::3]
        obs = np.empty((self.num_envs, 14))
        obs[:, 0:6:3] = c * north + s * east  # body FRD (task.body_frd)
        obs[:, 1:6:3] = -s * north + c * east
        obs[:, 2:6:3] = ned[:, 2::3]
        rel = diver[:, 3] - yaw
        obs[:, 6], obs[:, 7] = np.sin(rel), np.cos(rel)
        obs[:, 8] = np.abs(body_rates_kernel(*self.diver_inputs.T, self.diver_plant.params,
                                             ARRAYS)[0])
        obs[:, 9:13] = rov[:, 4:8]
        obs[:, 13] = rov[:, 2]
        space = self.single_observation_space
        np.maximum(obs, space.low, out=obs)  # np.clip's values
        return np.minimum(obs, space.high, out=obs).astype(np.float32)

    def _info(self, point: np.ndarray, error: np.ndarray, range_m: np.ndarray,
              bearing_error: np.ndarray, depth_error: np.ndarray,
              terms: dict[str, np.ndarray] | None, reason: np.ndarray | None) -> dict[str, Any]:
        del point
        info: dict[str, Any] = {
            "t": (self.ticks * self.dt), "episode_seed": self.episode_seed.copy(),
            "position_error_m": error, "range_m": range_m,
            "bearing_error_deg": bearing_error, "depth_error_m": depth_error}
        if terms is not None:
            info["reward_terms"] = terms
            info["termination"] = reason
        return info


def _loiter(agent: Any) -> dict | None:
    return _behavior(agent, "Loiter")


def _behavior(agent: Any, kind: str) -> dict | None:
    helm = agent.helm
    if helm is None:
        return None
    return next((dict(b) for b in helm.behaviors if b.get("type") == kind), None)


def _period(rate_hz: float | None, dt: float) -> int:
    return 1 if rate_hz is None else ticks_for_rate(rate_hz, dt, "control_rate_hz")


def _decided(axis: Any, summit: float, peakwidth: float, basewidth: float,
             summitdelta: float) -> float:
    """The helm's decision on ``axis`` for a ZAIC peak alone: the grid value of its first
    maximum (the solver's tie rule)."""
    return float(axis.values[int(np.argmax(zaic_peak_on_axis(axis, summit, peakwidth,
                                                             basewidth, summitdelta)))])


def _built(kind: str, behavior: dict) -> BehaviorSpec:
    """A behavior's spec from its scenario mapping (``where``: its kind)."""
    where = kind.lower()
    return build_behavior_spec(kind, [(k, v, where) for k, v in behavior.items()
                                      if k != "type"], where)


def _cylinder(o: CylinderObject | dict) -> Piling:
    """A piling from its cylinder object (validated, or a mapping drawn valid)."""
    if isinstance(o, dict):
        at = o["position"]
        return Piling(at["north"], at["east"], o["radius"], at["depth"] - 0.5 * o["height"], o)
    at = o.position
    return Piling(at.north, at.east, o.radius, at.depth - 0.5 * o.height, o.model_dump())


def _approaching(start: np.ndarray, end: np.ndarray, other: np.ndarray,
                 contact: float) -> np.ndarray:
    """The Simulation's rule for two bodies: the move start→end ends within ``contact``
    (m) of ``other``'s centre and closer than it began (rows)."""
    end_gap = _row_norms(end - other)
    return (end_gap < contact) & (end_gap < _row_norms(start - other))


def _row_norms(v: np.ndarray) -> np.ndarray:
    """|v| of each row of (N, 3) ``v``: ``np.linalg.norm(v, axis=1)``'s sum, in its order,
    without its dispatch."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])
