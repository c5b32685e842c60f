"""Exhaled bubble plumes of an open-circuit scuba diver, as moving sonar scatterers.

A diver breathes out every ``period_s`` seconds (a breath cycle; 12–20 breaths a minute
at rest), releasing a burst of bubbles at the regulator. Each burst is modelled as
``clusters`` small rigid clouds of ``bubbles_per_cluster`` air spheres (``radius_m``,
a few centimetres; scattered within ``cluster_radius_m``), which from the release point

* rise at ``rise_speed`` m/s (bubbles of a few mm to a cm rise at ~0.2–0.35 m/s; a
  cloud rises at about that speed),
* spread: each cloud drifts away horizontally at its own random velocity (σ
  ``spread_speed`` m/s per axis), so a burst opens up as it rises,
* and drift with the water current ``current_ned`` (m/s, north/east),

until they reach the surface (depth ≤ 0) or live ``max_age_s``. An air–water interface
reflects almost all of the incident sound (impedance ratio ~3500), so the spheres get a
bright material (``AIR_BUBBLE``); through the ray caster they are strong, moving,
short-lived returns that leave the diver — what real FLS images of open-circuit divers
show (``docs/reference/sonar.md``: "bubbles from open-circuit scuba add strong, moving
returns").

:class:`BubblePlume` is pure kinematics: given the bursts released so far (time, origin,
cloud velocities) it says where each cloud is at time t. The simulation owns the bodies
and calls it; randomness comes from the Generator it is handed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.settings import check_settings, setting
from uhrisim.world.materials import Material

if TYPE_CHECKING:
    import trimesh

#: Air bubbles: near-total reflection at the air–water interface (a default, like the
#: other materials: bright, not measured).
AIR_BUBBLE = Material("air_bubble", 0.6)

#: Where parked (inactive) clouds wait: far above the water, out of every sonar's reach.
PARKED_NED = np.array([0.0, 0.0, -1.0e4])


#: Most cloud bodies a plume may keep alive at once (bursts alive x clusters): each is a
#: mesh in the scene that every sonar ray and camera ray may hit.
MAX_CLOUDS = 200


@dataclass(frozen=True)
class BubbleParams:
    """Settings of a diver's bubble plume (SI; module docstring), declared with their
    physical ranges (:mod:`uhrisim.core.settings`); the plume's cost is bounded too: at most
    :data:`MAX_CLOUDS` clouds alive at once."""

    period_s: float = setting(4.0, "s", ge=0.5, le=60.0, cost="linear",
                              doc="time between breaths (12-20 a minute at work)")
    clusters: int = setting(3, "1", ge=1, le=10, integer=True, cost="linear",
                            doc="clouds per breath")
    bubbles_per_cluster: int = setting(6, "1", ge=1, le=50, integer=True, cost="linear",
                                       doc="air spheres per cloud")
    radius_m: float = setting(0.03, "m", gt=0.0, le=0.5, doc="radius of one air sphere")
    cluster_radius_m: float = setting(0.12, "m", gt=0.0, le=5.0,
                                      doc="radius of the ball a cloud's spheres fill")
    rise_speed: float = setting(0.3, "m/s", gt=0.0, le=2.0,
                                doc="rise speed (a few mm to cm bubbles: 0.2-0.4 m/s)")
    spread_speed: float = setting(0.12, "m/s", ge=0.0, le=2.0,
                                  doc="spreading speed of a cloud, sigma per axis")
    current_ned: tuple[float, float] = setting((0.0, 0.0), "m/s", ge=-5.0, le=5.0,
                                               doc="current (north, east) carrying the clouds")
    max_age_s: float = setting(12.0, "s", gt=0.0, le=600.0, cost="linear",
                               doc="a cloud's life if it does not reach the surface first")
    regulator_frd: tuple[float, float, float] = setting(
        (0.95, 0.0, -0.15), "m", ge=-5.0, le=5.0, doc="where the breath leaves the diver (FRD)")

    def __post_init__(self) -> None:
        check_settings(self)
        clouds = self.bursts_alive * self.clusters
        if clouds > MAX_CLOUDS:
            raise ConfigError(
                f"a breath every {self.period_s:g} s whose clouds live {self.max_age_s:g} s "
                f"keeps {self.bursts_alive} breaths x {self.clusters} clouds = {clouds} "
                f"alive, more than {MAX_CLOUDS} (a longer period, a shorter max_age or fewer "
                "clusters)", "BubbleParams")

    @property
    def bursts_alive(self) -> int:
        """Most bursts alive at once (their bodies are reused round-robin)."""
        return math.ceil(self.max_age_s / self.period_s) + 1


def cluster_mesh(params: BubbleParams, rng: np.random.Generator) -> trimesh.Trimesh:
    """One cloud of bubbles around its centre (body frame, m): spheres scattered
    uniformly in a ball of ``cluster_radius_m``."""
    import trimesh  # here: the scenario schema reads BubbleParams without the meshes

    spheres = []
    for _ in range(params.bubbles_per_cluster):
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction) + 1e-12
        offset = direction * params.cluster_radius_m * rng.random() ** (1.0 / 3.0)
        s = trimesh.creation.icosphere(subdivisions=1, radius=params.radius_m)
        s.apply_translation(offset)
        spheres.append(s)
    return trimesh.util.concatenate(spheres)


@dataclass
class BubblePlume:
    """The bursts of one diver and where their clouds are (module docstring).

    Clouds are numbered ``slot·clusters + k`` (slot = burst number modulo
    :attr:`BubbleParams.bursts_alive`), so a fixed set of bodies serves the whole run.
    """

    params: BubbleParams
    rng: np.random.Generator
    _bursts: dict[int, tuple[float, NDArray[np.float64], NDArray[np.float64]]] = field(
        default_factory=dict)
    _count: int = 0

    @property
    def n_clouds(self) -> int:
        return self.params.bursts_alive * self.params.clusters

    def next_burst_time(self) -> float:
        """When the next burst is due, s (the first one at t = period/2)."""
        return (self._count + 0.5) * self.params.period_s

    def release(self, t: float, origin_ned: NDArray[np.float64]) -> None:
        """Release a burst at ``t`` (s) from ``origin_ned`` (the regulator, m)."""
        p = self.params
        velocities = self.rng.normal(0.0, p.spread_speed, (p.clusters, 2))
        slot = self._count % p.bursts_alive
        self._bursts[slot] = (float(t), np.asarray(origin_ned, float).copy(), velocities)
        self._count += 1

    def positions(self, t: float) -> NDArray[np.float64]:
        """(n_clouds, 3) NED centres of every cloud at ``t``; parked ones at
        :data:`PARKED_NED`."""
        p = self.params
        out = np.tile(PARKED_NED, (self.n_clouds, 1))
        for slot, (t0, origin, velocities) in self._bursts.items():
            age = t - t0
            if age < 0.0 or age > p.max_age_s:
                continue
            depth = origin[2] - p.rise_speed * age
            if depth <= 0.0:
                continue
            horizontal = origin[:2] + (velocities + np.asarray(p.current_ned)) * age
            rows = slice(slot * p.clusters, (slot + 1) * p.clusters)
            out[rows, :2] = horizontal
            out[rows, 2] = depth
        return out
