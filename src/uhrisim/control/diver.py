"""Diver heading/speed/depth control: proportional on the leg inputs u_l, u_r (paper VI).

The heading error (wrapped, radians) sets a yaw rate ``K_h * e``; the commanded swim speed
is the common part of u_l and u_r and the yaw rate their difference (inverse of eqs
10-12). Vertical rate is proportional to the depth error. Saturation happens in the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.elementwise import ARRAYS, FLOATS, Elementwise
from uhrisim.dynamics.diver import DiverParams, leg_inputs

_RADIANS_PER_DEGREE = math.pi / 180.0  # math.radians multiplies by the same constant


@dataclass(frozen=True)
class DiverGains:
    """K_h in (rad/s) per rad of heading error; K_z in (m/s) per metre of depth error."""

    heading: float = 1.0
    depth: float = 0.5

    def __post_init__(self) -> None:
        if self.heading < 0.0 or self.depth < 0.0:
            raise ValueError("DiverGains must be >= 0")


@dataclass(frozen=True)
class DiverController:
    """``inputs(x, desired) -> [u_l, u_r, u_z]`` for one diver, :meth:`inputs_many` for N;
    both run :meth:`kernel`."""

    gains: DiverGains
    params: DiverParams

    def inputs(self, x: NDArray, desired_heading_deg: float, desired_speed: float,
               desired_depth: float) -> NDArray:
        _, _, depth, yaw = np.asarray(x[:4], dtype=float).tolist()
        return np.array(self.kernel(depth, yaw, float(desired_heading_deg),
                                    float(desired_speed), float(desired_depth)))

    def inputs_many(self, x: NDArray, desired_heading_deg: NDArray, desired_speed: NDArray,
                    desired_depth: NDArray) -> NDArray:
        """Leg inputs (N, 3) of N divers: states ``x`` (N, 4), desired values (N,) each."""
        x = np.asarray(x, dtype=float)
        return np.stack(self.kernel(x[:, 2], x[:, 3], np.asarray(desired_heading_deg, float),
                                    np.asarray(desired_speed, float),
                                    np.asarray(desired_depth, float), ARRAYS), axis=-1)

    def kernel(self, depth: Any, yaw: Any, desired_heading_deg: Any, desired_speed: Any,
               desired_depth: Any, ops: Elementwise = FLOATS) -> tuple[Any, Any, Any]:
        """On floats (one diver) or (N,) arrays (``ops``): the leg inputs, the inverse of
        eqs 10-12 (:func:`~uhrisim.dynamics.diver.leg_inputs`) of the commanded speed, the
        yaw rate K_h·e (e the wrapped heading error, rad) and the vertical rate K_z·Δz."""
        return diver_control_kernel(self.gains, self.params, depth, yaw, desired_heading_deg,
                                    desired_speed, desired_depth, ops)


def diver_control_kernel(gains: DiverGains, params: DiverParams, depth: Any, yaw: Any,
                         desired_heading_deg: Any, desired_speed: Any, desired_depth: Any,
                         ops: Elementwise) -> tuple[Any, Any, Any]:
    """:meth:`DiverController.kernel` with its gains and parameters as arguments (a function
    numba can compile, given them as records: :func:`uhrisim.core.compiled.record`)."""
    heading_error = ops.remainder(desired_heading_deg * _RADIANS_PER_DEGREE - yaw, math.tau)
    yaw_rate = gains.heading * heading_error
    vertical = gains.depth * (desired_depth - depth)
    return leg_inputs(desired_speed, yaw_rate, vertical, params)


@dataclass(frozen=True)
class WalkerController:
    """The diver on weighted boots (:class:`~uhrisim.dynamics.plants.BootsPlant`) driven
    by DESIRED_*: walking speed as commanded, turn rate ``K_h * e`` (e the wrapped heading
    error, rad); it stays on the floor (suit valve held, standing): the desired depth is
    not a command a walking diver follows."""

    gains: DiverGains = DiverGains()

    def inputs(self, x: NDArray, desired_heading_deg: float, desired_speed: float,
               desired_depth: float) -> NDArray:
        del desired_depth
        error = math.remainder(desired_heading_deg * _RADIANS_PER_DEGREE - float(x[3]), math.tau)
        return np.array([desired_speed, self.gains.heading * error, 0.0, 0.0])
