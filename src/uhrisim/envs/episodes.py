"""Episodes of the trail task: a scenario file, randomised from a seed, made ready for an
external (learning) pilot of the follower.

The scenario file is read once; every episode edits a copy of its data and validates it
again through the ordinary loader (:func:`uhrisim.scenario.load.validate_data`), so an
episode is an ordinary scenario run by the ordinary :class:`~uhrisim.sim.simulation.
Simulation` - there is no second physics path. Positions are NED (m), headings compass
degrees, as in the scenario files (``docs/conventions.md``); MOOS coordinates (x east,
y north) only where the helm's behaviors speak them.
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from uhrisim.core.errors import ConfigError
from uhrisim.core.files import regular_file_text
from uhrisim.core.rng import component_rng
from uhrisim.scenario.load import ScenarioFile, validate_data
from uhrisim.scenario.yaml_lines import load_with_lines

#: The randomised water (Francois-Garrison inputs of the sonar): a temperate-to-tropical
#: band of open sea water (°C, PSU).
WATER_TEMPERATURE_C = (4.0, 28.0)
WATER_SALINITY_PSU = (30.0, 38.0)
#: The diver's randomised loiter: polygon radius (m), vertices, swim speed (m/s; 0.5 m/s
#: is the scenario's realistic swim, the range spans a slow to a brisk diver).
LOITER_RADIUS_M = (10.0, 25.0)
LOITER_POINTS = (6, 8, 10)
DIVER_SPEED = (0.3, 0.6)
DIVER_DEPTH_M = (1.0, 4.0)
#: Where the follower starts: this far (m) from the diver, within this angle (deg) of the
#: trail bearing, heading within this angle (deg) of the line of sight to the diver.
FOLLOWER_START_RANGE_M = (2.5, 6.0)
FOLLOWER_START_BEARING_DEG = 60.0
FOLLOWER_START_HEADING_DEG = 45.0
#: Clutter: vertical pilings (radius m) kept this far (m) from the diver's loiter ring and
#: from the follower's start, within this margin (m) outside the ring.
PILING_RADIUS_M = (0.15, 0.5)
CLUTTER_CLEARANCE_M = 5.0
CLUTTER_MARGIN_M = 10.0


#: A user's randomisation: edits an episode's scenario data in place from a generator.
ScenarioHook = Callable[[dict, np.random.Generator], None]


@dataclass(frozen=True)
class Randomization:
    """What each episode draws from its seed (all on by default).

    * ``diver_path``: the target's Loiter polygon (centre, radius, vertices, direction)
      and swim speed;
    * ``start_poses``: the target's start heading and depth (its ConstantDepth follows),
      the follower's start range, bearing, depth and heading;
    * ``water``: temperature and salinity (sound speed and absorption of the sonar);
    * ``clutter``: how many vertical pilings stand on the sea floor around the loiter.
    """

    diver_path: bool = True
    start_poses: bool = True
    water: bool = True
    clutter: int = 2

    def __post_init__(self) -> None:
        if not isinstance(self.clutter, int) or isinstance(self.clutter, bool) or not (
                0 <= self.clutter <= 50):
            raise ConfigError(f"randomization.clutter must be an integer in [0, 50], "
                              f"got {self.clutter!r}")

    @classmethod
    def none(cls) -> Randomization:
        """Every episode is the scenario file as written."""
        return cls(diver_path=False, start_poses=False, water=False, clutter=0)


@dataclass(frozen=True)
class EpisodeDraw:
    """What one episode draws from its seed (:meth:`TrailEpisodes.draw`), as the scenario
    file's fields (NED m, compass degrees); None where it draws nothing (the file's)."""

    #: The world's water: temperature_c, salinity_psu.
    water: dict | None
    #: The target's start heading_deg and depth (its ConstantDepth's depth too).
    target_start: dict | None
    #: The follower's whole start pose: north, east, depth, heading_deg.
    follower_start: dict | None
    #: The target's Loiter: polygon (a radial spec), speed, clockwise.
    loiter: dict | None
    #: Cylinder objects added to the world's.
    clutter: tuple[dict, ...]


class TrailEpisodes:
    """Scenarios for episodes of ``follower`` trailing ``target`` in ``scenario_path``.

    ``sonar_rate_hz``: the follower's sonar pings at this rate in every episode (None:
    as the file says). ``physics_rate_hz``: the episodes' physics rate (None: as the file
    says). ``hook(data, rng)``: your own randomisation, called after the
    built-in draws with the episode's scenario data (the YAML mapping, NED metres and
    compass degrees as in the files) to edit in place and a generator of its own stream
    ``"envs/episode/hook"``; the result is validated like a file. The trail geometry
    (range, angle) comes from the file's ``metrics`` section, which the file must have.
    """

    def __init__(self, scenario_path: str | Path, follower: str, target: str,
                 randomization: Randomization, sonar_rate_hz: float | None = None,
                 hook: ScenarioHook | None = None,
                 physics_rate_hz: float | None = None) -> None:
        self.path = Path(scenario_path)
        try:
            text = regular_file_text(self.path)
        except OSError as error:
            raise ConfigError(f"cannot read scenario file: {error}", where=str(self.path)) from None
        self._data, self._lines = load_with_lines(text, str(self.path))
        base = validate_data(self._data, str(self.path), self._lines)
        names = [a.name for a in base.agents]
        for role, name in (("follower", follower), ("target", target)):
            if name not in names:
                raise ConfigError(f"{role} {name!r} is no agent of the scenario; agents: "
                                  f"{', '.join(names)}", where=str(self.path))
        if base.metrics is None:
            raise ConfigError("the trail task needs the scenario's 'metrics' section "
                              "(follower, target, range, angle_deg)", where=str(self.path))
        self.follower, self.target = follower, target
        self.trail_range_m = base.metrics.range
        self.trail_angle_deg = base.metrics.angle_deg
        self.randomization = randomization
        self.sonar_rate_hz = sonar_rate_hz
        self.physics_rate_hz = (base.physics_rate_hz if physics_rate_hz is None
                                else float(physics_rate_hz))
        self.hook = hook
        floor = base.world.seafloor
        self.floor_depth_m = getattr(floor, "depth", None)
        self.base = base

    def scenario(self, seed: int, follower_helm: bool = False) -> ScenarioFile:
        """The episode of ``seed`` (a non-negative integer): the file's data randomised
        from the stream ``"envs/episode"`` of ``seed``; the follower is driven from
        outside (``driver: external``), or by its own helm for ``follower_helm``."""
        return ScenarioFile(validate_data(self.episode_data(seed, follower_helm),
                                          str(self.path), self._lines), self.path, self._lines)

    def episode_data(self, seed: int, follower_helm: bool = False) -> dict[str, Any]:
        """:meth:`scenario`'s data before validation (a fresh copy the caller may keep):
        for those who read a few fields of many episodes (the vector env)."""
        data = pickle.loads(pickle.dumps(self._data, pickle.HIGHEST_PROTOCOL))  # plain YAML
        data["seed"] = int(seed)
        data["physics_rate_hz"] = self.physics_rate_hz
        agents = {a["name"]: a for a in data["agents"]}
        follower, target = agents[self.follower], agents[self.target]
        if not follower_helm:
            follower["driver"] = "external"
        if self.sonar_rate_hz is not None:
            for sensor in follower.get("sensors", []):
                sensor["rate_hz"] = self.sonar_rate_hz
        drawn = self.draw(seed)
        if drawn.water is not None:
            data.setdefault("world", {}).setdefault("water", {}).update(drawn.water)
        if drawn.target_start is not None:
            target.setdefault("start", {}).update(drawn.target_start)
            hold = _behavior(target, "ConstantDepth")
            if hold is not None:
                hold["depth"] = drawn.target_start["depth"]
        if drawn.follower_start is not None:
            follower["start"] = dict(drawn.follower_start)
        if drawn.loiter is not None:
            _behavior(target, "Loiter").update(drawn.loiter)
        if self.randomization.clutter:
            world = data.setdefault("world", {})
            world["objects"] = [*world.get("objects", []), *drawn.clutter]
        if self.hook is not None:
            self.hook(data, component_rng(int(seed), "envs/episode/hook"))
        return data

    def draw(self, seed: int) -> EpisodeDraw:
        """What the episode of ``seed`` draws from its stream ``"envs/episode"``
        (:class:`Randomization`), in :meth:`episode_data`'s units, before the hook: for
        those who need only these numbers (the vector env)."""
        rng = component_rng(int(seed), "envs/episode")
        r = self.randomization
        agents = {a["name"]: a for a in self._data["agents"]}  # read only
        follower, target = agents[self.follower], agents[self.target]
        water = target_start = follower_start = loiter_draw = None
        if r.water:
            water = {"temperature_c": round(float(rng.uniform(*WATER_TEMPERATURE_C)), 2),
                     "salinity_psu": round(float(rng.uniform(*WATER_SALINITY_PSU)), 2)}
        if r.start_poses:
            target_start, follower_start = self._draw_starts(rng, target.get("start", {}))
        loiter = _behavior(target, "Loiter")
        if r.diver_path and loiter is not None:
            loiter_draw = self._draw_loiter(rng, target.get("start", {}))
        clutter: tuple[dict, ...] = ()
        if r.clutter:
            clutter = self._draw_clutter(rng, follower_start or follower.get("start", {}),
                                         loiter_draw or loiter)
        return EpisodeDraw(water, target_start, follower_start, loiter_draw, clutter)

    def _draw_starts(self, rng: np.random.Generator, start: dict) -> tuple[dict, dict]:
        """The target's start heading and depth (its ConstantDepth's too), and the
        follower's start, behind the target's ``start`` (north, east)."""
        heading = float(rng.uniform(0.0, 360.0))
        depth = float(rng.uniform(*DIVER_DEPTH_M))
        # behind the diver (the trail bearing), within the start cone
        bearing = math.radians(heading + self.trail_angle_deg + rng.uniform(
            -FOLLOWER_START_BEARING_DEG, FOLLOWER_START_BEARING_DEG))
        distance = float(rng.uniform(*FOLLOWER_START_RANGE_M))
        north = start.get("north", 0.0) + distance * math.cos(bearing)
        east = start.get("east", 0.0) + distance * math.sin(bearing)
        sight = math.degrees(bearing) + 180.0  # from the follower to the diver
        return {"heading_deg": round(heading, 2), "depth": round(depth, 3)}, {
            "north": round(north, 3), "east": round(east, 3),
            "depth": round(float(rng.uniform(0.0, depth + 1.0)), 3),
            "heading_deg": round((sight + rng.uniform(-FOLLOWER_START_HEADING_DEG,
                                                      FOLLOWER_START_HEADING_DEG)) % 360.0, 2)}

    def _draw_loiter(self, rng: np.random.Generator, start: dict) -> dict:
        """A loiter ring through the diver's ``start``: centre, radius, vertices,
        direction, and the swim speed (the Loiter's polygon, speed, clockwise)."""
        radius = float(rng.uniform(*LOITER_RADIUS_M))
        side = float(rng.uniform(0.0, 2.0 * math.pi))  # where on the ring the diver starts
        x_east = start.get("east", 0.0) - radius * math.sin(side)
        y_north = start.get("north", 0.0) - radius * math.cos(side)
        points = int(rng.choice(LOITER_POINTS))
        return {"polygon": (f"format=radial, x={x_east:.3f}, y={y_north:.3f}, "
                            f"radius={radius:.3f}, pts={points}"),
                "speed": round(float(rng.uniform(*DIVER_SPEED)), 3),
                "clockwise": "true" if rng.random() < 0.5 else "false"}

    def _draw_clutter(self, rng: np.random.Generator, follower_start: dict,
                      loiter: dict | None) -> tuple[dict, ...]:
        """Vertical pilings (cylinder objects) from the sea floor to near the surface,
        clear of the loiter ring and of the follower's start."""
        floor = self.floor_depth_m or 10.0
        centre, ring = _loiter_ring(loiter)
        if centre is None:  # no loiter: around the follower's start
            start = follower_start
            centre, ring = np.array([start.get("north", 0.0), start.get("east", 0.0)]), 0.0
        outer = ring + CLUTTER_MARGIN_M
        follower_ne = np.array([follower_start.get("north", 0.0),
                                follower_start.get("east", 0.0)])
        objects: list[dict] = []
        for _ in range(200 * self.randomization.clutter):  # rejection sampling, bounded
            if len(objects) == self.randomization.clutter:
                break
            rho = outer * math.sqrt(float(rng.random()))
            phi = float(rng.uniform(0.0, 2.0 * math.pi))
            point = centre + rho * np.array([math.cos(phi), math.sin(phi)])
            if abs(rho - ring) < CLUTTER_CLEARANCE_M or np.linalg.norm(
                    point - follower_ne) < CLUTTER_CLEARANCE_M:
                continue
            height = floor - 0.5  # from the floor to 0.5 m below the surface
            objects.append({
                "type": "cylinder", "label": f"clutter{len(objects)}",
                "radius": round(float(rng.uniform(*PILING_RADIUS_M)), 3),
                "height": height,
                "position": {"north": round(float(point[0]), 3),
                             "east": round(float(point[1]), 3),
                             "depth": round(floor - height / 2.0, 3)}})
        return tuple(objects)


def _behavior(agent: dict, kind: str) -> dict | None:
    """The first behavior of type ``kind`` in an agent's inline helm section, if any."""
    helm = agent.get("helm") or {}
    return next((b for b in helm.get("behaviors", []) if b.get("type") == kind), None)


def _loiter_ring(loiter: dict | None) -> tuple[Any, float]:
    """Centre (NED north, east; m) and radius (m) of a radial loiter polygon, or None."""
    if loiter is None:
        return None, 0.0
    fields = dict(part.split("=", 1) for part in
                  (p.strip() for p in str(loiter.get("polygon", "")).split(",")) if "=" in part)
    try:
        return (np.array([float(fields["y"]), float(fields["x"])]),
                float(fields["radius"]))
    except (KeyError, ValueError):
        return None, 0.0
