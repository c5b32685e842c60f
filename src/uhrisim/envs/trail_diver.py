"""``uhrisim/TrailDiver-v0`` and ``uhrisim/TrailDiverState-v0``: follow a diver.

One environment class, two observations. Each episode is a scenario file (default:
``scenarios/track_and_trail.yaml``) randomised from the episode's seed
(:mod:`uhrisim.envs.episodes`) and run by the ordinary
:class:`~uhrisim.sim.simulation.Simulation`; the follower (the VideoRay) has no helm of its
own (``driver: external``) and the action enters through the same typed input path the
ROS 2 and MOOS bridges use (:meth:`Simulation.post` of DESIRED_*, or
:meth:`Simulation.set_actuators`). One step advances ``control_step_s`` simulated seconds
(default 0.25 s = 15 physics steps at 60 Hz). Units and frames: SI, world NED, body FRD
(``docs/conventions.md``); the spaces are listed in ``docs/envs.md``.

Actions (``command=``):

* ``"desired"`` (default), float32 (3,): [heading change (rad, > 0 turns to starboard;
  desired heading = current compass heading + this), speed (m/s through the water),
  depth change (m, > 0 deeper; desired depth = current depth + this, at least 0)],
  bounds [-π, 0, -2] .. [π, 1.0, 2] (1.07 m/s is the VideoRay's full-thrust speed: a
  higher demand saturates both thrusters and leaves no yaw authority); the ROV's own
  controller (paper eqs 5-9) tracks it.
* ``"thrusters"``, float32 (3,): [port, starboard, vertical] commands in [-150, 150]
  (positive port/starboard push forward, negative vertical dives), held for the step.

Either reaches the thrusters at the controller's next tick (20 Hz in the shipped
scenario), as a bridge's command would. Out-of-bound values are clipped; a wrong shape
or a value that is not finite is an ``InvalidAction``.

Observations (``observation=``):

* ``"state"`` (TrailDiverState-v0), float32 (14,), body FRD of the ROV unless noted:
  trail point (forward, starboard, down; m), diver (forward, starboard, down; m),
  sin and cos of (diver heading − ROV heading), diver speed (m/s), ROV surge, sway,
  heave (m/s), yaw rate (rad/s, > 0 to starboard), ROV depth (m, NED).
* ``"sonar"`` (TrailDiver-v0), a Dict: ``sonar`` uint8 (96, 64) polar image of the
  forward-looking sonar (rows: range bins, nearest first; columns: beams, port to
  starboard; the simulated P900-45's 375 x 256 image averaged down, cv2.INTER_AREA),
  ``nav`` float32 (9,): own navigation [north, east, depth (m, NED), sin ψ, cos ψ,
  u, v, w (m/s, FRD), r (rad/s)], and (``include_contact=True``) ``contact`` float32
  (6,): the tracked diver as a truth contact, like the scenario's node reports [forward,
  starboard, down (m, FRD), sin and cos of relative heading, speed (m/s)].

Reward, termination and truncation: :mod:`uhrisim.envs.task`.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any, ClassVar, Literal

import cv2
import gymnasium
import numpy as np
from gymnasium import spaces

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw
from uhrisim.dynamics.plants import NavState
from uhrisim.envs.episodes import Randomization, ScenarioHook, TrailEpisodes
from uhrisim.envs.render import render_frame
from uhrisim.envs.task import (
    THRUSTER_LIMIT,
    RewardWeights,
    TrailGeometry,
    body_frd,
    reward_terms,
)
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.hooks import TickFrame, sensor_key
from uhrisim.sim.simulation import BaseHook, Simulation
from uhrisim.vehicles import MODELS

SONAR_SHAPE = (96, 64)  # (range bins, beams) of the observed polar image
#: The episodes' physics rate (Hz): the shipped scenarios' controllers run at 20 Hz, so a
#: finer step only re-applies the same held inputs (docs/envs.md, "Physics rate").
PHYSICS_RATE_HZ = 20.0
STATE_SIZE = 14
NAV_SIZE = 9
CONTACT_SIZE = 6
POSITION_BOUND_M = 1000.0  # observation bounds; values beyond are clipped
RELATIVE_BOUND_M = 200.0
SPEED_BOUND = 5.0          # m/s
YAW_RATE_BOUND = 10.0      # rad/s
# Speed bound: the model's steady surge with both horizontal thrusters at +150 is
# 1.075 m/s (scenario videoray, linear thrust map; measured through this env).
DESIRED_LOW = np.array([-math.pi, 0.0, -2.0], dtype=np.float32)
DESIRED_HIGH = np.array([math.pi, 1.0, 2.0], dtype=np.float32)
SEED_SPAN = 2**31 - 1


class EnvArgumentError(ConfigError, gymnasium.error.Error):
    """A bad constructor argument or reset option (a Gymnasium error and a ConfigError)."""


def _box(low: list[float], high: list[float]) -> spaces.Box:
    return spaces.Box(np.array(low, dtype=np.float32), np.array(high, dtype=np.float32),
                      dtype=np.float32)


def _state_space() -> spaces.Box:
    rel, v = RELATIVE_BOUND_M, SPEED_BOUND
    return _box([-rel] * 6 + [-1, -1, 0, -v, -v, -v, -YAW_RATE_BOUND, 0],
                [rel] * 6 + [1, 1, v, v, v, v, YAW_RATE_BOUND, rel])


def _nav_space() -> spaces.Box:
    p, v = POSITION_BOUND_M, SPEED_BOUND
    return _box([-p, -p, 0, -1, -1, -v, -v, -v, -YAW_RATE_BOUND],
                [p, p, p, 1, 1, v, v, v, YAW_RATE_BOUND])


def _contact_space() -> spaces.Box:
    rel = RELATIVE_BOUND_M
    return _box([-rel, -rel, -rel, -1, -1, 0], [rel, rel, rel, 1, 1, SPEED_BOUND])


class _LatestPing(BaseHook):
    """Keeps the newest ping of one sonar (``key``: ``"<agent>/<sensor>"``; read-only)."""

    def __init__(self, key: str) -> None:
        self.key = key
        self.ping: Any = None

    def on_tick(self, frame: TickFrame) -> None:
        ping = frame.pings.get(self.key)
        if ping is not None:
            self.ping = ping


class TrailDiverEnv(gymnasium.Env):
    """Follow a diver at the scenario's trail point (module docstring: spaces, units).

    Arguments (keyword): ``observation`` "sonar" | "state"; ``command`` "desired" |
    "thrusters"; ``scenario`` path of a scenario file with a ``metrics`` section (default:
    the shipped track_and_trail.yaml); ``follower``/``target`` agent names;
    ``control_step_s`` simulated seconds per step (a whole number of physics steps);
    ``physics_rate_hz`` the physics rate of the episodes (default 20 Hz, the controllers'
    rate: the VideoRay's RK4 sub-steps keep their length, so trajectories match the
    file's 60 Hz within millimetres at a third of the cost — a test holds them; None: the
    scenario file's own);
    ``time_limit_s`` truncation; ``lost_range_m`` horizontal range (m) beyond which the
    diver is lost; ``include_contact`` (sonar observation only); ``sonar`` the name of the
    follower's sonar the observation shows (default: its first); ``sonar_shape`` (range
    bins, beams); ``randomization`` a :class:`Randomization` or a dict of its fields;
    ``reward_weights`` a :class:`RewardWeights` or a dict; ``scenario_hook`` your own
    randomisation ``hook(data, rng)`` (:class:`~uhrisim.envs.episodes.TrailEpisodes`);
    ``render_mode`` None | "rgb_array".
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, observation: Literal["sonar", "state"] = "sonar",
                 command: Literal["desired", "thrusters"] = "desired", *,
                 scenario: str | Path | None = None, follower: str = "videoray",
                 target: str = "diver", control_step_s: float = 0.25,
                 physics_rate_hz: float | None = PHYSICS_RATE_HZ,
                 time_limit_s: float = 120.0, lost_range_m: float = 12.0,
                 include_contact: bool = True, sonar: str | None = None,
                 sonar_shape: tuple[int, int] = SONAR_SHAPE,
                 randomization: Randomization | dict | None = None,
                 reward_weights: RewardWeights | dict | None = None,
                 scenario_hook: ScenarioHook | None = None,
                 render_mode: str | None = None, **unknown: Any) -> None:
        _refuse_unknown(unknown, "TrailDiverEnv argument", _ARGUMENTS)
        _one_of("observation", observation, ("sonar", "state"))
        _one_of("command", command, ("desired", "thrusters"))
        _one_of("render_mode", render_mode, (None, *self.metadata["render_modes"]))
        for name, value in (("control_step_s", control_step_s), ("time_limit_s", time_limit_s),
                            ("lost_range_m", lost_range_m),
                            ("physics_rate_hz", 1.0 if physics_rate_hz is None
                             else physics_rate_hz)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise EnvArgumentError(f"{name} must be a finite number > 0, got {value!r}")
        if (not isinstance(sonar_shape, tuple | list) or len(sonar_shape) != 2 or
                not all(isinstance(n, int) and 8 <= n <= 1024 for n in sonar_shape)):
            raise EnvArgumentError(f"sonar_shape must be two integers in [8, 1024] (range "
                                   f"bins, beams), got {sonar_shape!r}")
        self.observation_kind, self.command = observation, command
        self.render_mode = render_mode
        self.time_limit_s, self.lost_range_m = float(time_limit_s), float(lost_range_m)
        self.include_contact = bool(include_contact)
        self.sonar_shape = (int(sonar_shape[0]), int(sonar_shape[1]))
        self.weights = _dataclass_arg(RewardWeights, reward_weights, "reward_weights")
        randomization = _dataclass_arg(Randomization, randomization, "randomization")
        path = Path(scenario) if scenario is not None else shipped_scenario()
        try:
            self.episodes = TrailEpisodes(
                path, follower, target, randomization,
                sonar_rate_hz=1.0 / control_step_s if observation == "sonar" else None,
                hook=scenario_hook, physics_rate_hz=physics_rate_hz)
        except ConfigError as error:
            raise EnvArgumentError(str(error)) from None
        physics_hz = self.episodes.physics_rate_hz
        ticks = control_step_s * physics_hz
        if abs(ticks - round(ticks)) > 1e-6 or round(ticks) < 1:
            raise EnvArgumentError(f"control_step_s must be a whole number of physics steps "
                                   f"(1/{physics_hz:g} s), got {control_step_s!r}")
        self.control_step_s = round(ticks) / physics_hz
        self._max_steps = max(1, round(self.time_limit_s / self.control_step_s))
        self._steps = 0
        self.follower, self.target = follower, target
        sonars = [s for a in self.episodes.base.agents if a.name == follower
                  for s in a.sensors if s.type == "sonar"]
        self._sonar_config = next((s for s in sonars if sonar in (None, s.name)), None)
        if observation == "sonar" and self._sonar_config is None:
            raise EnvArgumentError(
                f"observation='sonar' needs a sonar on {follower!r}; its scenario agent has "
                + (f"no sonar named {sonar!r} (its sonars: "
                   f"{', '.join(s.name for s in sonars) or 'none'})" if sonar is not None
                   else "no sonar"))
        follower_model = next(a.model for a in self.episodes.base.agents if a.name == follower)
        if command == "thrusters" and not MODELS[follower_model].thrusters:
            raise EnvArgumentError(f"command='thrusters' drives a VideoRay's three thrusters; "
                                   f"{follower!r} is a {follower_model} model: use "
                                   "command='desired'")
        if scenario_hook is not None and not callable(scenario_hook):
            raise EnvArgumentError(f"scenario_hook must be a callable (data, rng), got "
                                   f"{scenario_hook!r}")
        if command == "desired":
            self.action_space = spaces.Box(DESIRED_LOW, DESIRED_HIGH, dtype=np.float32)
        else:
            self.action_space = spaces.Box(-THRUSTER_LIMIT, THRUSTER_LIMIT, (3,),
                                           dtype=np.float32)
        if observation == "state":
            self.observation_space = _state_space()
        else:
            parts: dict[str, spaces.Space] = {
                "sonar": spaces.Box(0, 255, self.sonar_shape, dtype=np.uint8),
                "nav": _nav_space()}
            if self.include_contact:
                parts["contact"] = _contact_space()
            self.observation_space = spaces.Dict(parts)
        self._sim: Simulation | None = None
        self._ping_hook: _LatestPing | None = None
        self._done = False
        self._episode_seed = 0
        self._track: list[tuple[np.ndarray, np.ndarray]] = []

    # -- the Gymnasium API ---------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[Any, dict[str, Any]]:
        """Start an episode. ``options``: ``{"episode_seed": n}`` runs the episode of
        scenario seed ``n`` (default: drawn from the environment's seeded generator)."""
        super().reset(seed=seed)
        options = dict(options or {})
        _refuse_unknown(options, "reset option", ("episode_seed",))
        episode_seed = options.get("episode_seed")
        if episode_seed is None:
            episode_seed = int(self.np_random.integers(0, SEED_SPAN))
        elif isinstance(episode_seed, bool) or not isinstance(episode_seed, int | np.integer) \
                or not 0 <= episode_seed <= SEED_SPAN:
            raise EnvArgumentError(f"reset option episode_seed must be an integer in "
                                   f"[0, {SEED_SPAN}], got {episode_seed!r}")
        self._begin(int(episode_seed), follower_helm=False)
        navs = self._navs()
        return self._observe(*navs), self._info(TrailGeometry.of(*navs, *self._trail), {}, None)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self._sim is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        if self._done:
            raise gymnasium.error.ResetNeeded("the episode has ended (terminated or truncated); "
                                              "call reset() before step()")
        self._act(self._checked(action))
        return self._advance()

    def render(self) -> np.ndarray | None:
        """``rgb_array``: (H, W, 3) uint8, a top-down map (north up) beside the sonar fan."""
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without render_mode='rgb_array'")
            return None
        if self._sim is None:
            raise gymnasium.error.ResetNeeded("call reset() before render()")
        follower, target = self._navs()
        ping = self._ping_hook.ping if self._ping_hook is not None else None
        info = ping.info if ping is not None else None  # the fan's own range and width
        return render_frame(
            self._sim.scene, follower, target,
            TrailGeometry.of(follower, target, *self._trail).trail_point_ned, self._track,
            ping.fan_u8 if ping is not None else None,
            info.range_max_m if info is not None else None,
            math.radians(info.fov_deg) / 2.0 if info is not None else 0.0, self._sim.t)

    def close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None

    # -- beyond the API ------------------------------------------------------------------
    def helm_episode(self, seed: int | None = None, episode_seed: int | None = None
                     ) -> dict[str, Any]:
        """Run one whole episode with the follower's own helm from the scenario file
        driving (no actions), scored exactly like a policy's episode: ``return``,
        ``steps``, ``termination`` and ``mean_position_error_m``. The episode is the one
        :meth:`reset` with the same ``seed`` (or ``episode_seed``) would give."""
        if episode_seed is None:
            super().reset(seed=seed)
            episode_seed = int(self.np_random.integers(0, SEED_SPAN))
        self._begin(int(episode_seed), follower_helm=True)
        total, steps, errors, info = 0.0, 0, [], {}
        done = False
        while not done:
            _, reward, terminated, truncated, info = self._advance()
            total += reward
            steps += 1
            errors.append(info["position_error_m"])
            done = terminated or truncated
        return {"return": total, "steps": steps, "termination": info.get("termination"),
                "mean_position_error_m": float(np.mean(errors))}

    # -- internals -----------------------------------------------------------------------
    @property
    def _trail(self) -> tuple[float, float]:
        return self.episodes.trail_range_m, self.episodes.trail_angle_deg

    def _begin(self, episode_seed: int, follower_helm: bool) -> None:
        self.close()
        self._episode_seed = episode_seed
        try:
            source = self.episodes.scenario(episode_seed, follower_helm=follower_helm)
        except ConfigError as error:  # e.g. a scenario_hook that wrote a bad value
            raise EnvArgumentError(f"episode {episode_seed}: {error}") from None
        sonar = self.observation_kind == "sonar"
        self._ping_hook = _LatestPing(
            sensor_key(self.follower, self._sonar_config.name)) if sonar else None
        self._sim = Simulation(source, raycast_sensors=sonar,
                               hooks=[self._ping_hook] if self._ping_hook else ())
        self._sim.start()
        self._done = False
        self._steps = 0
        self._track = []
        # One control step with the follower's commands at rest (speed 0, its start
        # heading and depth) or its helm driving: the first observation shows a ping.
        self._sim.run(self.control_step_s)

    def _checked(self, action: Any) -> np.ndarray:
        try:
            values = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise gymnasium.error.InvalidAction(
                f"action must be 3 numbers ({self.command}), got {action!r}") from None
        if values.shape != (3,):
            raise gymnasium.error.InvalidAction(
                f"action must have shape (3,) ({self.command}), got shape {values.shape}")
        if not np.all(np.isfinite(values)):
            raise gymnasium.error.InvalidAction(
                f"action must be finite ({self.command}), got {values.tolist()}")
        return np.clip(values, self.action_space.low, self.action_space.high)

    def _act(self, action: np.ndarray) -> None:
        sim = self._sim
        assert sim is not None
        if self.command == "thrusters":  # held until just past the next step
            sim.set_actuators(self.follower, action,
                              hold_s=self.control_step_s + 0.5 * sim.dt)
            return
        nav = sim.snapshot(sim.agents[self.follower]).nav
        heading = float(heading_deg_from_yaw(nav.yaw + action[0]))
        sim.post(self.follower, "DESIRED_HEADING", heading, source="envs")
        sim.post(self.follower, "DESIRED_SPEED", float(action[1]), source="envs")
        sim.post(self.follower, "DESIRED_DEPTH",
                 max(0.0, float(nav.position_ned[2] + action[2])), source="envs")

    def _advance(self) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        sim = self._sim
        assert sim is not None
        logged = len(sim.events_log)
        sim.run(self.control_step_s)
        collided = any(e.kind == "collision" and self._touches_follower(e.detail)
                       for e in sim.events_log[logged:])
        follower, target = self._navs()
        geometry = TrailGeometry.of(follower, target, *self._trail)
        lost = geometry.range_m > self.lost_range_m
        inputs = sim.snapshot(sim.agents[self.follower]).inputs
        terms = reward_terms(self.weights, geometry, collided, lost, np.asarray(inputs))
        reason = "collision" if collided else "lost" if lost else None
        terminated = reason is not None
        self._steps += 1
        truncated = not terminated and self._steps >= self._max_steps
        self._done = terminated or truncated
        if self.render_mode is not None:
            self._track.append((follower.position_ned, target.position_ned))
        return (self._observe(follower, target), float(sum(terms.values())), terminated,
                truncated, self._info(geometry, terms, reason))

    def _touches_follower(self, detail: str) -> bool:
        return detail.startswith(f"{self.follower} touched") or detail.endswith(
            f"touched {self.follower}")

    def _navs(self) -> tuple[NavState, NavState]:
        sim = self._sim
        assert sim is not None
        return (sim.snapshot(sim.agents[self.follower]).nav,
                sim.snapshot(sim.agents[self.target]).nav)

    def _observe(self, follower: NavState, target: NavState) -> Any:
        rel_heading = target.yaw - follower.yaw
        diver = body_frd(target.position_ned - follower.position_ned, follower.yaw)
        if self.observation_kind == "state":
            point = TrailGeometry.of(follower, target, *self._trail).trail_point_ned
            trail = body_frd(point - follower.position_ned, follower.yaw)
            state = np.concatenate([trail, diver, [math.sin(rel_heading),
                                                   math.cos(rel_heading), target.speed],
                                    follower.velocity_body, [follower.yaw_rate,
                                                             follower.position_ned[2]]])
            return self._clip(state, self.observation_space)
        nav = np.concatenate([follower.position_ned, [math.sin(follower.yaw),
                                                      math.cos(follower.yaw)],
                              follower.velocity_body, [follower.yaw_rate]])
        obs = {"sonar": self._sonar_image(), "nav": self._clip(nav, self.observation_space["nav"])}
        if self.include_contact:
            contact = np.concatenate([diver, [math.sin(rel_heading), math.cos(rel_heading),
                                              target.speed]])
            obs["contact"] = self._clip(contact, self.observation_space["contact"])
        return obs

    @staticmethod
    def _clip(values: np.ndarray, space: spaces.Box) -> np.ndarray:
        return np.clip(values, space.low, space.high).astype(np.float32)

    def _sonar_image(self) -> np.ndarray:
        ping = self._ping_hook.ping if self._ping_hook is not None else None
        if ping is None:
            return np.zeros(self.sonar_shape, dtype=np.uint8)
        bins, beams = self.sonar_shape
        return cv2.resize(ping.polar_u8, (beams, bins), interpolation=cv2.INTER_AREA)

    def _info(self, geometry: TrailGeometry, terms: dict[str, float],
              reason: str | None) -> dict[str, Any]:
        sim = self._sim
        assert sim is not None
        return {"t": sim.t, "episode_seed": self._episode_seed, "reward_terms": terms,
                "position_error_m": geometry.position_error_m, "range_m": geometry.range_m,
                "bearing_error_deg": geometry.bearing_error_deg,
                "depth_error_m": geometry.depth_error_m, "termination": reason}


_ARGUMENTS = ("observation", "command", "scenario", "follower", "target", "control_step_s",
              "physics_rate_hz",
              "time_limit_s", "lost_range_m", "include_contact", "sonar", "sonar_shape",
              "randomization", "reward_weights", "scenario_hook", "render_mode")


def _refuse_unknown(given: dict[str, Any], what: str, known: tuple[str, ...]) -> None:
    for key in given:
        if key in known:
            continue
        close = difflib.get_close_matches(str(key), known, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else f"; known: {', '.join(known)}"
        raise EnvArgumentError(f"unknown {what} {key!r}{hint}")


def _one_of(name: str, value: Any, allowed: tuple[Any, ...]) -> None:
    if value not in allowed:
        raise EnvArgumentError(f"{name} must be one of {', '.join(map(repr, allowed))}, "
                               f"got {value!r}")


def _dataclass_arg(cls: type, value: Any, name: str) -> Any:
    """``value`` as a ``cls`` (a dataclass of settings): given, built from a dict, or the
    defaults for None; unknown fields are an :class:`EnvArgumentError`."""
    if value is None:
        return cls()
    if isinstance(value, cls):
        return value
    if not isinstance(value, dict):
        raise EnvArgumentError(f"{name} must be a {cls.__name__} or a dict, got {value!r}")
    _refuse_unknown(value, f"{name} field", tuple(cls.__dataclass_fields__))
    try:
        return cls(**value)
    except ConfigError as error:
        raise EnvArgumentError(str(error)) from None
