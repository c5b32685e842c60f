"""Frame and angle conversions. The conventions are stated in docs/conventions.md.

Inside uhrisim: world NED (x north, y east, z down, metres), body FRD (x forward,
y starboard, z down), yaw psi in radians = compass heading (0 north, clockwise
positive seen from above). Other frames live only at the edges:

* MOOS-IvP: x east, y north, heading in compass degrees, depth positive down.
* ROS (REP-103): world ENU, body FLU.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

_ONES3 = np.ones(3)


def wrap_pi(angle_rad: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap radians to [-pi, pi)."""
    a = np.asarray(angle_rad, dtype=float)
    out = (a + np.pi) % (2.0 * np.pi) - np.pi
    return float(out) if out.ndim == 0 else out


def wrap_180(angle_deg: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap degrees to [-180, 180)."""
    if isinstance(angle_deg, float | int):  # one number: the same arithmetic, no numpy call
        return (float(angle_deg) + 180.0) % 360.0 - 180.0
    a = np.asarray(angle_deg, dtype=float)
    out = (a + 180.0) % 360.0 - 180.0
    return float(out) if out.ndim == 0 else out


def wrap_360(angle_deg: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap degrees to [0, 360)."""
    if isinstance(angle_deg, float | int):  # one number: the same arithmetic, no numpy call
        return float(angle_deg) % 360.0
    a = np.asarray(angle_deg, dtype=float)
    out = a % 360.0
    return float(out) if out.ndim == 0 else out


def heading_deg_from_yaw(yaw_rad: ArrayLike) -> NDArray[np.float64] | float:
    """Compass heading in degrees [0, 360) from NED yaw in radians."""
    if isinstance(yaw_rad, float | int):  # math.degrees multiplies by the same 180/pi
        return wrap_360(math.degrees(yaw_rad))
    return wrap_360(np.degrees(yaw_rad))


def row_dots(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N,) row-wise dot products of (N, 3) arrays (several times faster than einsum for
    three columns)."""
    return (a * b) @ _ONES3


_IDENTITY3 = np.eye(3)
_IDENTITY3.setflags(write=False)


def orthonormality_error(r: NDArray[np.float64]) -> float:
    """The largest entry of |R·Rᵀ − I| for a 3x3 ``r`` (0 for a rotation; NaN if ``r``
    holds one, so that every "≤ tolerance" test fails)."""
    gram = r @ r.T
    np.subtract(gram, _IDENTITY3, out=gram)
    return float(np.abs(gram).max())


def vector_length(v: NDArray[np.float64]) -> float:
    """The length of a 1-D float vector (its units): ``np.linalg.norm``'s own arithmetic for
    one, the square root of ``v . v``, without its checks (asked several times a step)."""
    return math.sqrt(v.dot(v))


def yaw_from_heading_deg(heading_deg: ArrayLike) -> NDArray[np.float64] | float:
    """NED yaw in radians [-pi, pi) from compass heading in degrees."""
    return wrap_pi(np.radians(heading_deg))


def moos_xy_from_ned(north: ArrayLike, east: ArrayLike) -> tuple:
    """MOOS local (x east, y north) from NED (north, east)."""
    return east, north


def ned_from_moos_xy(x_east: ArrayLike, y_north: ArrayLike) -> tuple:
    """NED (north, east) from MOOS local (x east, y north)."""
    return y_north, x_east


def rot_z(yaw_rad: float) -> NDArray[np.float64]:
    """3x3 rotation about the down axis: body-to-world for a pure yaw (NED/FRD)."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_zyx(roll_rad: float, pitch_rad: float, yaw_rad: float) -> NDArray[np.float64]:
    """Body(FRD)-to-world(NED) rotation for ZYX Euler angles (yaw, then pitch, then roll)."""
    cr, sr = np.cos(roll_rad), np.sin(roll_rad)
    cp, sp = np.cos(pitch_rad), np.sin(pitch_rad)
    cy, sy = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


# NED <-> ENU swaps x and y and flips z; FRD <-> FLU flips y and z. Both are involutions.
_NED_TO_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
_FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])


def enu_from_ned(v_ned: ArrayLike) -> NDArray[np.float64]:
    """A vector (or rows of vectors) in ENU from NED."""
    return np.asarray(v_ned, dtype=float) @ _NED_TO_ENU.T


def flu_from_frd(v_frd: ArrayLike) -> NDArray[np.float64]:
    """A body vector (or rows of vectors) in FLU from FRD."""
    return np.asarray(v_frd, dtype=float) @ _FRD_TO_FLU.T


def enu_rotation_from_ned(r_ned_frd: ArrayLike) -> NDArray[np.float64]:
    """Body(FLU)-to-world(ENU) rotation from a body(FRD)-to-world(NED) rotation."""
    return _NED_TO_ENU @ np.asarray(r_ned_frd, dtype=float) @ _FRD_TO_FLU


def quaternion_from_matrix(r: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion (x, y, z, w) of a rotation matrix, w >= 0."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = np.asarray(r, dtype=float).tolist()
    tr = m00 + m11 + m22
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    quat = np.asarray(q)
    quat /= np.linalg.norm(quat)
    return -quat if quat[3] < 0.0 else quat
