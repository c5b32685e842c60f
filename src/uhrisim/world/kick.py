"""The swimming diver's flutter kick: its geometry and timing, and the legs' joint angles.

The meshes that swing with it (:func:`uhrisim.world.assets.diver_parts`, the articulated
:mod:`uhrisim.world.diver_figure`) import these; the vehicles and the simulation use them
without the meshes (no trimesh here). Angles in rad, the phase advancing 2π a kick cycle.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.elementwise import FLOATS, Elementwise
from uhrisim.core.errors import ConfigError
from uhrisim.dynamics.diver_body import DiverSkeleton

#: Flutter-kick geometry and timing (assumptions, stated once):
#: a prone diver ~1.8 m head to toe, ~2.3 m with fins; legs swing about the hips in
#: opposite phase with DIVER_HIP_AMPLITUDE_RAD, fins bend about the ankles with
#: DIVER_ANKLE_AMPLITUDE_RAD lagging the legs by a quarter cycle (fins "follow").
DIVER_HIP_AMPLITUDE_RAD = 0.20
DIVER_ANKLE_AMPLITUDE_RAD = 0.35
DIVER_ANKLE_LAG_RAD = math.pi / 2.0
#: Distance covered per flutter-kick cycle and the fastest cycle rate (assumed: recreational
#: divers cruise at 0.3–0.6 m/s with roughly 0.5–1 kick cycles per second).
DIVER_STRIDE_M = 0.6
DIVER_MAX_KICK_HZ = 1.5
#: The swimmer's ankle about which the articulated figure's flutter kick swings (feet
#: pointed), rad.
SWIM_ANKLE_BIAS_RAD = math.radians(-20.0)


def diver_kick_phase_rate(speed_mps: float) -> float:
    """Flutter-kick phase rate (rad/s) for a forward swim speed (m/s).

    Model (assumption, see module constants): the kick frequency is proportional to
    speed, ``f = speed / DIVER_STRIDE_M`` (0.6 m per cycle), capped at
    ``DIVER_MAX_KICK_HZ`` = 1.5 Hz; a hovering diver (speed 0) does not kick. At 0.3 m/s
    this gives 0.5 Hz, at 0.6 m/s 1 Hz. Negative speeds (backing) use |speed|.
    """
    s = float(speed_mps)
    if not math.isfinite(s):
        raise ConfigError(f"must be finite, got {speed_mps!r}", where="diver_kick_phase_rate")
    return kick_phase_rate(s, FLOATS)


def kick_phase_rate(speed_mps: Any, ops: Elementwise) -> Any:
    """:func:`diver_kick_phase_rate` unchecked, on a float or (N,) array (``ops``): the
    form the batched env and the compiled quiet ticks call."""
    return 2.0 * math.pi * ops.clip(abs(speed_mps) / DIVER_STRIDE_M, 0.0, DIVER_MAX_KICK_HZ)


def flutter_kick(skeleton: DiverSkeleton, q: ArrayLike, kick_phase_rad: float
                 ) -> NDArray[np.float64]:
    """``q`` with the legs in the flutter kick of the swimming diver at ``kick_phase_rad``.

    The same kick as :func:`uhrisim.world.assets.diver_parts` (hip amplitude, ankle
    amplitude and its quarter-cycle lag, legs in opposite phase) about a streamlined
    ankle of ``SWIM_ANKLE_BIAS_RAD``; clipped into the joint limits.
    """
    out = np.array(q, dtype=float)
    for side, offset in (("left", 0.0), ("right", math.pi)):
        out[skeleton.index(f"{side}_hip_flex")] = (
            DIVER_HIP_AMPLITUDE_RAD * math.sin(kick_phase_rad + offset))
        out[skeleton.index(f"{side}_knee")] = 0.0
        out[skeleton.index(f"{side}_ankle")] = SWIM_ANKLE_BIAS_RAD + DIVER_ANKLE_AMPLITUDE_RAD * (
            math.sin(kick_phase_rad + offset - DIVER_ANKLE_LAG_RAD))
    return skeleton.clip(out)
