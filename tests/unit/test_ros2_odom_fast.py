"""The float-only odometry conversion equals its numpy reference bit for bit.

``odom_fields_from_ned`` feeds both the live ROS 2 odometry and the MCAP recorder; it
was rewritten on plain floats for speed, so it must give exactly the numbers of the
matrix version (``odom_fields_from_ned_reference``), signed zeros included, for every
heading (both quaternion branches, the branch boundary, multiples of pi/2) and for
inputs with exact zeros of either sign. No ROS needed."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError, NumericalError
from uhrisim.ros.convert import odom_fields_from_ned, odom_fields_from_ned_reference


def _bits(f) -> bytes:
    values = (*f.position_enu, *f.orientation_xyzw, *f.linear_flu, *f.angular_flu)
    return struct.pack(f"<{len(values)}d", *values)


_SPECIAL_YAWS = [0.0, -0.0, math.pi, -math.pi, math.pi / 2, -math.pi / 2, 3 * math.pi / 2,
                 2 * math.pi, -7 * math.pi / 6, -math.pi / 6, 7 * math.pi / 6, 1e-300, 100.0]


@pytest.mark.slow
def test_fast_equals_reference_bit_for_bit() -> None:
    rng = np.random.default_rng(2024)
    for i in range(20_000):
        p, v = rng.uniform(-80, 80, 3), rng.uniform(-2, 2, 3)
        if i % 3 == 0:  # exact zeros of both signs in any component
            p = np.where(rng.random(3) < 0.5, rng.choice([0.0, -0.0], 3), p)
            v = np.where(rng.random(3) < 0.5, rng.choice([0.0, -0.0], 3), v)
        psi = (_SPECIAL_YAWS[i % len(_SPECIAL_YAWS)] if i % 5 == 0
               else float(rng.uniform(-20.0, 20.0)))
        r = float(rng.choice([0.0, -0.0, rng.uniform(-1, 1)]))
        for pos, vel in ((p, v), (p.tolist(), v.tolist())):  # arrays and plain lists
            assert _bits(odom_fields_from_ned(pos, psi, vel, r)) == _bits(
                odom_fields_from_ned_reference(pos, psi, vel, r)), (p, psi, v, r)


def test_fast_checks_inputs_like_the_reference() -> None:
    for fn in (odom_fields_from_ned, odom_fields_from_ned_reference):
        with pytest.raises(NumericalError):
            fn(np.array([0.0, math.nan, 0.0]), 0.0, [0.0, 0.0, 0.0], 0.0)
        with pytest.raises(NumericalError):
            fn([0.0, 0.0, 0.0], 0.0, [math.inf, 0.0, 0.0], 0.0)
        with pytest.raises(NumericalError):
            fn([0.0, 0.0, 0.0], math.nan, [0.0, 0.0, 0.0], 0.0)
        with pytest.raises(ConfigError):
            fn([0.0, 0.0], 0.0, [0.0, 0.0, 0.0], 0.0)
    # integer input is converted to floats, as the reference does
    assert _bits(odom_fields_from_ned(np.array([1, 2, 3]), 0.5, [1, 0, 0], 0)) == _bits(
        odom_fields_from_ned_reference(np.array([1, 2, 3]), 0.5, [1, 0, 0], 0))
