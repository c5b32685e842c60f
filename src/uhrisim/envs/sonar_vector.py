"""The native vector environment of ``uhrisim/TrailDiver-v0``: N episodes with sonar images.

``gymnasium.make_vec("uhrisim/TrailDiver-v0", num_envs=N,
vectorization_mode="vector_entry_point")`` gives :class:`TrailDiverSonarVectorEnv`: the
batched episodes of :class:`~uhrisim.envs.vector.TrailDiverVectorEnv` (dynamics,
controllers, the diver's loiter pilot, collisions, rewards, autoreset; one process) and,
at the end of every step, one ping of each follower's sonar, as the single env's
Simulation pings it (the last physics tick of the control step, the sonar's own body
unseen):

* **one cast for all N sonars**: the N fans (each sonar's mount on its ROV, its rays
  rotated into NED) go to Embree together
  (:meth:`~uhrisim.world.raycast.EmbreeRayCaster.cast_fans`): one query against the
  shared sea floor, one per rigid part group of the diver's body, posed per episode (its
  position, heading and flutter-kick phase, accumulated as the Simulation does); the
  episodes' pilings, vertical cylinders, are intersected in array code for all N fans at
  once (exact cylinders: the single env's are 32-sided meshes, a few millimetres apart);
* **the image of each ping** by that episode's own
  :class:`~uhrisim.sensors.sonar.sonar.ImagingSonar` (its configuration with the
  episode's water, its speckle drawn from the episode's seed, as the Simulation builds
  it): the hits inside each window picked for all N fans at once, then per episode only
  the polar display levels of
  :meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar.form_image` and their 8-bit image
  (its echoes, diffuse terms, speckle, TVG, display curve;
  :meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar.polar_bytes`, the same code; a ping
  with no hit in its window skips the echo stages there, the same bytes), each
  averaged down as the single env does while it is still in cache (``cv2.INTER_AREA``:
  its own loop compiled, bit for bit, :func:`_area_down_loops`); with ``threads``, each
  thread forms and averages its own episodes' images.

What differs from N single envs: the pilings' shape above, and the single env's refusal
of a sonar inside geometry (not checked here: the ROV's collisions keep it out). A
scenario with more in the water than the sea floor, the two agents and fixed cylinders
(other agents, the diver's bubbles, boxes, meshes, movable objects) is refused with a
one-line error naming them. A test
(tests/integration/test_envs_vector.py) holds the observations, rewards and ends to the
single envs' with the pilings cleared, and the images with pilings to within a few grey
levels.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import cache
from typing import Any, ClassVar

import cv2
import numpy as np

from uhrisim.core.compiled import jit
from uhrisim.core.elementwise import ARRAYS
from uhrisim.core.frames import rot_z, row_dots, wrap_pi
from uhrisim.core.rng import component_rng
from uhrisim.dynamics.diver import body_rates_kernel
from uhrisim.envs.task import body_frd
from uhrisim.envs.trail_diver import EnvArgumentError
from uhrisim.envs.vector import EpisodeStart, TrailDiverVectorEnv
from uhrisim.scenario.build_world import build_static_scene, material_named
from uhrisim.scenario.schema import SonarSensor, Water
from uhrisim.scenario.sections import part_settings
from uhrisim.sensors.sonar.cast import FanHits
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.sonar import ImagingSonar
from uhrisim.world.assets import diver_parts
from uhrisim.world.kick import kick_phase_rate
from uhrisim.world.materials import NEOPRENE


class TrailDiverSonarVectorEnv(TrailDiverVectorEnv):
    """N episodes of the trail task with the sonar observation (module docstring).
    Arguments as :class:`~uhrisim.envs.trail_diver.TrailDiverEnv` with
    ``observation="sonar"``, plus ``num_envs`` and ``threads``: each step's images formed
    by that many threads, each its own episodes (each episode its own sonar, scratch and
    speckle: the same images bit for bit; one by default)."""

    OBSERVATION: ClassVar[str] = "sonar"

    def __init__(self, num_envs: int = 1, observation: str = "sonar", threads: int = 1,
                 **kwargs: Any) -> None:
        super().__init__(num_envs, observation, threads, **kwargs)
        self.threads = threads
        self._image_pool = (ThreadPoolExecutor(threads, "uhrisim-images") if threads > 1
                            else None)
        t = self.template
        agents = {a.name: a for a in t.episodes.base.agents}
        follower, target = agents[t.follower], agents[t.target]
        if target.scene_body != "diver":
            raise EnvArgumentError("the sonar vector env sees a diver target with the "
                                   f"kicking diver body; {target.name!r} has "
                                   f"scene_body {target.scene_body!r}")
        unseen = ([f"agent {a.name!r}" for a in agents.values()
                   if a.name not in (follower.name, target.name)]
                  + [f"the bubbles of {target.name!r}"] * (target.bubbles is not None)
                  + [f"object {o.label!r} ({o.type})" for o in t.episodes.base.world.objects
                     if o.type != "cylinder" or o.movable])
        if unseen:
            raise EnvArgumentError("the sonar vector env images the sea floor, the diver and "
                                   "fixed cylinders only; this scenario also has "
                                   + ", ".join(unseen) + " (use vectorization_mode='sync')")
        self.sonar_index = next(k for k, s in enumerate(follower.sensors)
                                if s is t._sonar_config)
        #: Every episode's sonar (the file's, its rate as the env sets it; the episodes
        #: draw no sensor setting and the env takes no scenario hook).
        self._sonar_sensor = SonarSensor.model_validate(next(
            a for a in t.episodes.episode_data(0)["agents"] if a["name"] == t.follower
        )["sensors"][self.sonar_index])
        self.scene = build_static_scene(self._source)  # the shared sea floor
        material = (material_named(target.material, f"agents.{target.name}.material")
                    if target.material else NEOPRENE)
        self.scene.add_dynamic(target.name, diver_parts(material), target.label or "diver",
                               material, np.zeros(3), np.eye(3), 0.0)
        self.caster = self.scene.raycaster("embree")
        sonar = ImagingSonar(SonarConfig(**part_settings(t._sonar_config)),
                             np.random.default_rng(0))
        rays_body = sonar.geometry.dirs_sonar @ sonar.mount_rotation.T
        #: The widest horizontal angle (rad) of a ray from the ROV's heading.
        self.half_view = float(np.max(np.abs(np.arctan2(rays_body[:, 1], rays_body[:, 0]))))
        self.piling_reflectivity = np.zeros(self.pilings.shape[:2])
        (rows, columns), (bins, beams) = sonar.polar_shape, t.sonar_shape
        #: OpenCV's ``INTER_AREA`` tables (:func:`_area_table`: rows, columns) where it
        #: averages the polar image down by its generic loop (not both factors integers,
        #: which takes its integer path); None: OpenCV resizes each image.
        self._area_tables = (None if rows < bins or columns < beams
                             or (rows % bins == 0 and columns % beams == 0)
                             else (_area_table(rows, bins), _area_table(columns, beams)))
        #: :func:`_exact_blocks` of the columns' table (0: none).
        self._column_block = (0 if self._area_tables is None
                              else _exact_blocks(self._area_tables[1]))

    def close_extras(self, **kwargs: Any) -> None:
        super().close_extras(**kwargs)
        if self._image_pool is not None:
            self._image_pool.shutdown()

    def _allocate(self, n: int) -> None:
        super()._allocate(n)
        self.kick_phase = np.zeros(n)
        self.sonars: list[ImagingSonar | None] = [None] * n

    # -- episodes ------------------------------------------------------------------------
    def _load(self, envs: np.ndarray, starts: list[EpisodeStart]) -> None:
        """The episodes' arrays (:meth:`TrailDiverVectorEnv._load`), each diver at rest
        (kick phase 0) and each sonar as the Simulation builds it: the scenario sensor's
        settings with the episode's water, speckle from the episode's seed."""
        super()._load(envs, starts)
        t = self.template
        self.kick_phase[envs] = 0.0
        for i, start in zip(envs, starts, strict=True):
            water = Water.model_validate(start.water)
            config = SonarConfig(**part_settings(self._sonar_sensor),
                                 water_temperature_c=water.temperature_c,
                                 salinity_psu=water.salinity_psu, ph=water.ph)
            self.sonars[i] = ImagingSonar(config, component_rng(
                start.seed, f"{t.follower}/sonar{self.sonar_index}"))
            self.piling_reflectivity[i] = 0.0
            for j, o in enumerate(self._cylinders(i)[:self.pilings.shape[1]]):
                self.piling_reflectivity[i, j] = material_named(o.material,
                                                                o.label).reflectivity

    def _moved(self, rows: slice | np.ndarray) -> None:
        """The diver's flutter-kick phase, as the Simulation advances it each tick
        (:func:`~uhrisim.world.kick.diver_kick_phase_rate` of its speed)."""
        speed = body_rates_kernel(*self.diver_inputs[rows].T, self.diver_plant.params,
                                  ARRAYS)[0]
        self.kick_phase[rows] += kick_phase_rate(speed, ARRAYS) * self.dt

    # -- what the agent sees -------------------------------------------------------------
    def _observe(self) -> dict[str, np.ndarray]:
        """Sonar image, own navigation and (``include_contact``) the diver as a contact,
        per sub-environment (docs/envs.md), as the single env observes them."""
        t = self.template
        space = self.single_observation_space
        rov, diver = self.rov, self.diver
        yaw = rov[:, 3]
        nav = np.concatenate([rov[:, :3], np.sin(yaw)[:, None], np.cos(yaw)[:, None],
                              rov[:, 4:8]], axis=1)
        obs = {"sonar": self._ping(),
               "nav": np.clip(nav, space["nav"].low, space["nav"].high).astype(np.float32)}
        if t.include_contact:
            rel = diver[:, 3] - yaw
            speed = np.abs(body_rates_kernel(*self.diver_inputs.T, self.diver_plant.params,
                                             ARRAYS)[0])
            rows = [np.concatenate([body_frd(diver[i, :3] - rov[i, :3], yaw[i]),
                                    [math.sin(rel[i]), math.cos(rel[i]), speed[i]]])
                    for i in range(self.num_envs)]
            obs["contact"] = np.clip(np.array(rows), space["contact"].low,
                                     space["contact"].high).astype(np.float32)
        return obs

    def _ping(self) -> np.ndarray:
        """Every sub-environment's sonar image now, (N, range bins, beams) uint8: one cast
        of all N fans, the hits inside each sonar's window picked for all fans at once,
        each episode's 8-bit polar image (its own sonar: its speckle, its water) averaged
        down as soon as it is formed (module docstring)."""
        bins, beams = self.template.sonar_shape
        out = np.zeros((self.num_envs, bins, beams), dtype=np.uint8)
        sonars = [s for s in self.sonars if s is not None]
        if len(sonars) < self.num_envs:
            return out
        poses, dirs, distance, normal, reflectivity, label = self._cast_fans()
        window = np.array([s.cast_window_m for s in sonars])  # (N, 2): [near, far) m
        # the few rays that hit before the farthest window's end, then each in its window
        near = np.flatnonzero(distance.reshape(-1) < window[:, 1].max())
        fan, ray = np.divmod(near, distance.shape[1])
        inside = (distance[fan, ray] >= window[fan, 0]) & (distance[fan, ray] < window[fan, 1])
        fan, ray = fan[inside], ray[inside]
        first = np.searchsorted(fan, np.arange(self.num_envs + 1))
        hits = (distance[fan, ray], np.abs(row_dots(normal[fan, ray], dirs[fan, ray])),
                reflectivity[fan, ray], label[fan, ray].astype(np.int32))

        def form(share: range) -> None:
            """The images of episodes ``share`` (consecutive), averaged down into ``out``."""
            area_down = _area_down_compiled() if self._area_tables is not None else None
            for i in share:
                rows = slice(first[i], first[i + 1])
                # (each image to bytes, then averaged down, while it is in cache: the
                # display mapping of the whole stack at once, tens of megabytes, is slower)
                image = sonars[i].polar_bytes(*poses[i], FanHits(
                    ray[rows], *(h[rows] for h in hits)))
                if area_down is not None:  # OpenCV's INTER_AREA loop, compiled
                    area_down(image[None], *self._area_tables, self._column_block,
                              out[i : i + 1])
                else:
                    out[i] = cv2.resize(image, (beams, bins), interpolation=cv2.INTER_AREA)

        shares = [range(int(k[0]), int(k[-1]) + 1) for k in
                  np.array_split(np.arange(self.num_envs), self.threads) if k.size]
        if self._image_pool is None or len(shares) < 2:
            form(range(self.num_envs))
        else:
            list(self._image_pool.map(form, shares))
        return out

    def _cast_fans(self) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray,
                                  np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Each sonar's pose (origin NED, rotation sonar → NED), its rays in NED (N, R, 3)
        and their first hits (N, R): distance (m, inf on a miss), unit normal (N, R, 3),
        Lambert μ and scene label: the sea floor and the diver in one
        :meth:`~uhrisim.world.raycast.EmbreeRayCaster.cast_fans`, then the pilings."""
        sonars = [s for s in self.sonars if s is not None]
        poses = [s.sonar_pose(self.rov[i, :3], rot_z(self.rov[i, 3]))
                 for i, s in enumerate(sonars)]
        # every episode's sonar casts the scenario sensor's fan (the water changes no ray)
        rotations = np.stack([R for _, R in poses])
        dirs = np.matmul(sonars[0].geometry.dirs_sonar, rotations.transpose(0, 2, 1))
        origins = np.stack([p for p, _ in poses])
        body = np.zeros((self.num_envs, 4, 4))
        body[:, 3, 3] = 1.0
        body[:, :3, :3] = [rot_z(y) for y in self.diver[:, 3]]
        body[:, :3, 3] = self.diver[:, :3]
        hits = self.caster.cast_fans(origins, dirs, max(s.cast_window_m[1] for s in sonars),
                                     {self.template.target: (body, self.kick_phase)},
                                     checked=False)  # the sonars' own unit rays
        shape = dirs.shape[:2]
        distance, normal = hits.distance.reshape(shape), hits.normal.reshape(*shape, 3)
        reflectivity, label = hits.reflectivity.reshape(shape), hits.label.reshape(shape)
        self._pilings_hit(origins, dirs, distance, normal, reflectivity, label)
        return poses, dirs, distance, normal, reflectivity, label

    def _pilings_hit(self, origins: np.ndarray, dirs: np.ndarray, distance: np.ndarray,
                     normal: np.ndarray, reflectivity: np.ndarray, label: np.ndarray) -> None:
        """Each fan's rays against its episode's pilings (vertical cylinders from their
        top down to the floor, with a top cap), in array code over all fans, piling slot
        by slot; where one is nearer than the hit so far, it replaces it (in place; label
        -1). The side: the nearer root of |o + t d - c|² = r² in the horizontal plane."""
        far = max(s.cast_window_m[1] for s in self.sonars if s is not None)
        for j in range(self.pilings.shape[1]):
            seen = self._in_view(origins, self.pilings[:, j], far)
            if seen.size == 0:
                continue
            o, d = origins[seen], dirs[seen]
            north, east, radius = self.pilings[seen, j].T  # (M,) each
            top = self.piling_top[seen, j]
            rel_n, rel_e = o[:, 0] - north, o[:, 1] - east
            a = d[..., 0] ** 2 + d[..., 1] ** 2  # (M, R)
            c = rel_n ** 2 + rel_e ** 2 - radius ** 2  # > 0: the sonar is outside it
            with np.errstate(invalid="ignore"):
                b = d[..., 0] * rel_n[:, None] + d[..., 1] * rel_e[:, None]
                disc = b * b - a * c[:, None]
                fan, ray = np.nonzero((disc >= 0.0) & (b < 0.0) & (c[:, None] > 0.0))
            t_side = (-b[fan, ray] - np.sqrt(disc[fan, ray])) / a[fan, ray]
            z = o[fan, 2] + t_side * d[fan, ray, 2]
            keep = (z >= top[fan]) & (t_side < distance[seen[fan], ray])
            fan, ray, t_side = fan[keep], ray[keep], t_side[keep]
            point = o[fan] + t_side[:, None] * d[fan, ray]
            hit_normal = np.zeros_like(point)
            hit_normal[:, 0] = (point[:, 0] - north[fan]) / radius[fan]
            hit_normal[:, 1] = (point[:, 1] - east[fan]) / radius[fan]
            self._replace(j, (seen[fan], ray), t_side, hit_normal, distance, normal, reflectivity,
                          label)
            with np.errstate(invalid="ignore"):  # the top cap, seen from above it
                fan, ray = np.nonzero((o[:, 2] < top)[:, None] & (d[..., 2] > 0.0))
            t_cap = (top[fan] - o[fan, 2]) / d[fan, ray, 2]
            at_n = rel_n[fan] + t_cap * d[fan, ray, 0]
            at_e = rel_e[fan] + t_cap * d[fan, ray, 1]
            keep = (at_n ** 2 + at_e ** 2 <= radius[fan] ** 2) & (t_cap < distance[seen[fan], ray])
            up = np.zeros((np.count_nonzero(keep), 3))
            up[:, 2] = -1.0
            self._replace(j, (seen[fan[keep]], ray[keep]), t_cap[keep], up, distance, normal,
                          reflectivity, label)

    def _in_view(self, origins: np.ndarray, piling: np.ndarray, far: float) -> np.ndarray:
        """The fans (indices) that may see ``piling`` ((N, 3): north, east, radius; NaN:
        none): within ``far`` m of it and with it inside their horizontal field of view
        (:attr:`half_view`, around the ROV's heading)."""
        rel = piling[:, :2] - origins[:, :2]
        rho = np.hypot(rel[:, 0], rel[:, 1])
        with np.errstate(invalid="ignore"):
            spread = np.arcsin(np.minimum(piling[:, 2] / rho, 1.0))
            off = np.abs(wrap_pi(np.arctan2(rel[:, 1], rel[:, 0]) - self.rov[:, 3]))
            return np.flatnonzero((rho - piling[:, 2] <= far)
                                  & ((off <= self.half_view + spread + 0.01)
                                     | (rho <= piling[:, 2])))

    def _replace(self, slot: int, rows: tuple[np.ndarray, np.ndarray], t: np.ndarray,
                 hit_normal: np.ndarray, distance: np.ndarray, normal: np.ndarray,
                 reflectivity: np.ndarray, label: np.ndarray) -> None:
        """Rays ``rows`` (fan, ray) now hit piling ``slot`` at ``t`` m, ``hit_normal``."""
        distance[rows] = t
        normal[rows] = hit_normal
        reflectivity[rows] = self.piling_reflectivity[rows[0], slot]
        label[rows] = -1


def _area_table(size: int, size_out: int) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's ``INTER_AREA`` weights (its ``computeResizeAreaTab``, the same double
    arithmetic) for ``size`` pixels averaged down to ``size_out`` along one axis: (size_out,
    K) source indices and float32 weights, each output's in OpenCV's order, padded with
    weight 0 (adding 0·x leaves a float32 sum as it is)."""
    scale = 1.0 / (size_out / size)  # as cv::resize computes it, from the inverse scale
    entries: list[list[tuple[int, float]]] = []
    for k in range(size_out):
        start = k * scale
        end = start + scale
        cell = min(scale, size - start)
        first = min(math.ceil(start), min(math.floor(end), size - 1))
        last = min(math.floor(end), size - 1)
        entry = [(first - 1, (first - start) / cell)] if first - start > 1e-3 else []
        entry += [(i, 1.0 / cell) for i in range(first, last)]
        if end - last > 1e-3:
            entry.append((last, min(end - last, 1.0, cell) / cell))
        entries.append(entry)
    index = np.zeros((size_out, max(map(len, entries))), np.intp)
    weight = np.zeros(index.shape, np.float32)
    for k, entry in enumerate(entries):
        index[k, :len(entry)] = [i for i, _ in entry]
        weight[k, :len(entry)] = [w for _, w in entry]
    return index, weight


def _exact_blocks(table: tuple[np.ndarray, np.ndarray]) -> int:
    """K where ``table`` (:func:`_area_table`) averages blocks of K consecutive pixels
    (output k: pixels kK … kK + K − 1) with one weight 2⁻ᵐ: then every product and
    partial sum of bytes is exact in float32 (at most 8 + log2 K + m ≤ 24 bits), so the
    block's integer sum times the weight is OpenCV's sum bit for bit; 0 otherwise."""
    index, weight = table
    k = index.shape[1]
    w = float(weight[0, 0])
    exact = (w > 0.0 and math.frexp(w)[0] == 0.5 and 255 * k / w < 2.0 ** 24
             and bool(np.all(weight == weight[0, 0])))
    if not exact or not np.array_equal(index, np.arange(index.size).reshape(index.shape)):
        return 0
    return k


def _area_down_loops(images: np.ndarray, rows: tuple[np.ndarray, np.ndarray],
                     columns: tuple[np.ndarray, np.ndarray], column_block: int,
                     out: np.ndarray) -> None:
    """``cv2.resize(image, ..., interpolation=cv2.INTER_AREA)`` of each of ``images`` (N,
    H, W) uint8 into ``out`` (N, h, w), by OpenCV's generic area loop (``resizeArea_``,
    float32): each source row's weighted sums over ``columns`` (:func:`_area_table`), then
    per output row those of its source rows times their weights from ``rows``, added in
    order and rounded half to even. ``column_block``: :func:`_exact_blocks` of
    ``columns`` (K > 0: each row's sums as K-pixel integer sums times the weight)."""
    row_index, row_weight = rows
    column_index, column_weight = columns
    lines = np.empty((images.shape[1], out.shape[2]), np.float32)
    total = np.empty(out.shape[2], np.float32)
    sums = np.empty(out.shape[2], np.int32)
    for n in range(images.shape[0]):
        for y in range(images.shape[1]):
            source = images[n, y]
            if column_block > 0:
                sums[:] = 0
                for i in range(column_block):
                    for x in range(out.shape[2]):
                        sums[x] += source[x * column_block + i]
                for x in range(out.shape[2]):
                    lines[y, x] = np.float32(sums[x]) * column_weight[0, 0]
                continue
            for x in range(out.shape[2]):
                line = np.float32(0.0)
                for i in range(column_index.shape[1]):
                    line += np.float32(source[column_index[x, i]]) * column_weight[x, i]
                lines[y, x] = line
        for y in range(out.shape[1]):
            total[:] = 0.0
            for j in range(row_index.shape[1]):
                line_j, weight = lines[row_index[y, j]], row_weight[y, j]
                for x in range(out.shape[2]):
                    total[x] += weight * line_j[x]
            for x in range(out.shape[2]):
                out[n, y, x] = np.uint8(np.rint(total[x]))


@cache
def _area_down_compiled():  # type: ignore[no-untyped-def]
    """:func:`_area_down_loops` compiled (numba), or None without numba."""
    return jit(_area_down_loops)
