"""The trail task: reward terms, termination and the relative state of follower and target.

Geometry (NED, m; compass angles) as in :mod:`uhrisim.app.metrics`: the **trail point**
lies ``trail_range`` from the target at compass bearing (target heading + trail angle),
at the target's depth; the **bearing error** is wrap_180(bearing target→follower −
(target heading + trail angle)) in degrees; the **range** is the horizontal distance.

Reward of a step = the sum of the named terms (each also in ``info["reward_terms"]``):

* ``trail_position`` = w_p · (1 − min(e / s, 1)), e = 3-D distance (m) of the follower
  from the trail point, s = ``position_scale_m``: w_p at the trail point, 0 from s on.
  It is a bonus, not a penalty, so that staying with the diver pays more than ending
  the episode early;
* ``bearing`` = −w_b · |bearing error| / 180°;
* ``collision`` = −w_c on a step in which the follower touched anything (new contact);
* ``energy`` = −w_e · mean over the three thrusters of (input / 150)² (inputs at the end
  of the step; 150 = the VideoRay's command range, docs/conventions.md; a follower of
  another model has its three actuator inputs scaled the same way);
* ``lost`` = −w_l on the step the diver is lost (horizontal range > ``lost_range_m``).

An episode terminates on a collision or a lost diver and is truncated at ``time_limit_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import wrap_180
from uhrisim.dynamics.plants import NavState
from uhrisim.dynamics.videoray import INPUT_LIMIT as THRUSTER_LIMIT  # ±150 (conventions)

REWARD_TERMS = ("trail_position", "bearing", "collision", "energy", "lost")


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms (dimensionless; ``position_scale_m`` in m)."""

    trail_position: float = 1.0
    position_scale_m: float = 4.0
    bearing: float = 0.25
    collision: float = 10.0
    energy: float = 0.05
    lost: float = 10.0

    def __post_init__(self) -> None:
        for name in REWARD_TERMS:
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ConfigError(f"reward_weights.{name} must be a finite number >= 0, "
                                  f"got {value!r}")
        if not (math.isfinite(self.position_scale_m) and self.position_scale_m > 0.0):
            raise ConfigError(f"reward_weights.position_scale_m must be > 0 m, got "
                              f"{self.position_scale_m!r}")


@dataclass(frozen=True)
class TrailGeometry:
    """Where the follower should be relative to ``target`` (NED, m, rad)."""

    trail_point_ned: np.ndarray   # (3,)
    position_error_m: float       # 3-D distance follower -> trail point
    range_m: float                # horizontal distance follower - target
    bearing_error_deg: float      # wrapped to [-180, 180)
    depth_error_m: float          # follower depth - target depth

    @classmethod
    def of(cls, follower: NavState, target: NavState, trail_range_m: float,
           trail_angle_deg: float) -> TrailGeometry:
        wanted = target.yaw + math.radians(trail_angle_deg)
        point = np.array([target.position_ned[0] + trail_range_m * math.cos(wanted),
                          target.position_ned[1] + trail_range_m * math.sin(wanted),
                          target.position_ned[2]])
        d_north = follower.position_ned[0] - target.position_ned[0]
        d_east = follower.position_ned[1] - target.position_ned[1]
        bearing = math.degrees(math.atan2(d_east, d_north))
        return cls(point, float(np.linalg.norm(follower.position_ned - point)),
                   math.hypot(d_north, d_east),
                   float(wrap_180(bearing - math.degrees(wanted))),
                   float(follower.position_ned[2] - target.position_ned[2]))


def body_frd(vector_ned: np.ndarray, yaw: float) -> np.ndarray:
    """A NED vector (m) in the body FRD frame of a vehicle with compass yaw ``yaw`` (rad),
    roll and pitch zero (docs/conventions.md)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * vector_ned[0] + s * vector_ned[1],
                     -s * vector_ned[0] + c * vector_ned[1], vector_ned[2]])


def reward_terms(weights: RewardWeights, geometry: TrailGeometry, collided: bool,
                 lost: bool, thrusters: np.ndarray) -> dict[str, float]:
    """The named reward terms of one step (see the module docstring)."""
    closeness = 1.0 - min(geometry.position_error_m / weights.position_scale_m, 1.0)
    effort = float(np.mean((np.asarray(thrusters, dtype=float) / THRUSTER_LIMIT) ** 2))
    return {
        "trail_position": weights.trail_position * closeness,
        "bearing": -weights.bearing * abs(geometry.bearing_error_deg) / 180.0,
        "collision": -weights.collision if collided else 0.0,
        "energy": -weights.energy * effort,
        "lost": -weights.lost if lost else 0.0,
    }
