"""Closest point of approach (CPA) between own ship and a contact on straight legs.

Frame: MOOS local (x east, y north, metres); headings in compass degrees (velocity
components vx = v sin(h), vy = v cos(h)). Both ships hold course and speed for
t in [0, T] (T = time on leg); the CPA distance is min over that interval of their range.

Closed form: with relative position r0 = p_own - p_cn and relative velocity
w = v_own - v_cn, range(t) = |r0 + w t| is minimised at t* = -(r0.w)/|w|^2 clipped to
[0, T]. :func:`cpa_distance` evaluates this for whole arrays of candidate (course, speed);
:class:`CpaGrid` does the same over a fixed course x speed grid with its own-ship
velocities cached (the helm's hot path; bit-identical to :func:`cpa_distance`);
:func:`cpa_distance_reference` samples time densely (slow, obviously correct).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.compiled import callable_compiled, jit

__all__ = [
    "AvoidUtility",
    "CpaGrid",
    "CutRangeUtility",
    "avoid_utility_inplace",
    "cpa_distance",
    "cpa_distance_reference",
    "cpa_time",
    "cut_range_utility_inplace",
    "velocity_xy",
]


def velocity_xy(heading_deg: ArrayLike, speed: ArrayLike) -> tuple[NDArray, NDArray]:
    """(vx east, vy north) in m/s from compass heading (deg) and speed (m/s)."""
    h = np.radians(np.asarray(heading_deg, dtype=float))
    s = np.asarray(speed, dtype=float)
    return s * np.sin(h), s * np.cos(h)


def _relative(
    osx: float,
    osy: float,
    courses_deg: ArrayLike,
    speeds: ArrayLike,
    cnx: float,
    cny: float,
    cnh_deg: float,
    cnv: float,
    horizon: float,
) -> tuple[NDArray, NDArray, NDArray, float]:
    """(a = |w|^2, b = r0.w, t* clipped, |r0|^2) broadcast over courses x speeds."""
    c = np.radians(np.asarray(courses_deg, dtype=float))
    s = np.asarray(speeds, dtype=float)
    h = np.radians(cnh_deg)
    shape = np.broadcast_shapes(c.shape, s.shape)
    wx = (s * np.sin(c)).reshape(-1)  # flat working copies (always real arrays)
    wx -= cnv * np.sin(h)
    wy = (s * np.cos(c)).reshape(-1)
    wy -= cnv * np.cos(h)
    dx, dy = osx - cnx, osy - cny
    a = wx * wx
    a += wy * wy
    wx *= dx
    wy *= dy
    b = np.add(wx, wy, out=wx)
    # a == 0 only when w == 0, where b == 0 too: t = 0 (no relative motion)
    t = np.divide(b, a + 1e-300)
    np.negative(t, out=t)
    np.clip(t, 0.0, max(horizon, 0.0), out=t)
    return a.reshape(shape), b.reshape(shape), t.reshape(shape), dx * dx + dy * dy


def cpa_time(
    osx: float,
    osy: float,
    courses_deg: ArrayLike,
    speeds: ArrayLike,
    cnx: float,
    cny: float,
    cnh_deg: float,
    cnv: float,
    horizon: float,
) -> NDArray[np.float64]:
    """Time (s) of closest approach in [0, horizon], broadcast over courses and speeds."""
    return _relative(osx, osy, courses_deg, speeds, cnx, cny, cnh_deg, cnv, horizon)[2]


def cpa_distance(
    osx: float,
    osy: float,
    courses_deg: ArrayLike,
    speeds: ArrayLike,
    cnx: float,
    cny: float,
    cnh_deg: float,
    cnv: float,
    horizon: float,
) -> NDArray[np.float64]:
    """CPA distance (m) over [0, horizon] for own course/speed candidates (broadcast).

    Pass ``courses[:, None]`` and ``speeds[None, :]`` to get the full (n_course, n_speed)
    grid. range(t)^2 = |r0|^2 + 2 b t + a t^2 evaluated at the clipped t*.
    """
    a, b, t, r2 = _relative(osx, osy, courses_deg, speeds, cnx, cny, cnh_deg, cnv, horizon)
    a *= t
    b *= 2.0
    a += b
    a *= t
    a += r2
    np.maximum(a, 0.0, out=a)
    return np.sqrt(a, out=a)


@dataclass(frozen=True, eq=False)
class CpaGrid:
    """Own-ship velocity over a course x speed grid, for repeated CPA evaluations.

    ``vx[i, j] = speeds[j] * sin(radians(courses[i]))`` (east) and ``vy`` likewise with
    cos (north), m/s - computed once (the same expressions as :func:`cpa_distance`, so
    :meth:`distance` returns bit-identical values with ~30 in-place grid operations).
    """

    courses_deg: NDArray[np.float64]
    speeds: NDArray[np.float64]
    vx: NDArray[np.float64]
    vy: NDArray[np.float64]

    @classmethod
    def over(cls, courses_deg: ArrayLike, speeds: ArrayLike) -> CpaGrid:
        """Grid for the 1-D candidate ``courses_deg`` (compass deg) x ``speeds`` (m/s)."""
        crs = np.asarray(courses_deg, dtype=float).reshape(-1)
        spd = np.asarray(speeds, dtype=float).reshape(-1)
        c = np.radians(crs[:, None])
        s = spd[None, :]
        vx, vy = s * np.sin(c), s * np.cos(c)
        for a in (crs, spd, vx, vy):
            a.flags.writeable = False
        return cls(crs, spd, vx, vy)

    @property
    def shape(self) -> tuple[int, int]:
        return self.vx.shape  # type: ignore[return-value]

    @staticmethod
    def point_args(osx: float, osy: float, cnx: float, cny: float, cnh_deg: float, cnv: float,
                   horizon: float, utility: AvoidUtility | CutRangeUtility | None = None,
                   ) -> tuple[float, float, float, float, float, float, int, float, float]:
        """What :func:`cpa_point` takes after own velocity, for :meth:`distance`'s
        arguments: the contact's velocity (east, north) m/s, own position relative to it,
        m, its square, the horizon clipped at 0, s, and the utility's kind and parameters."""
        h = math.radians(cnh_deg)  # (math's radians, sin and cos are numpy's on a float)
        dx, dy = float(osx - cnx), float(osy - cny)
        kind, p0, p1 = (_DISTANCE, 0.0, 0.0) if utility is None else utility.kernel_args()
        return (cnv * math.sin(h), cnv * math.cos(h), dx, dy, dx * dx + dy * dy,
                float(max(horizon, 0.0)), kind, float(p0), float(p1))

    def distance(
        self,
        osx: float,
        osy: float,
        cnx: float,
        cny: float,
        cnh_deg: float,
        cnv: float,
        horizon: float,
        utility: AvoidUtility | CutRangeUtility | None = None,
    ) -> NDArray[np.float64]:
        """CPA distance (m) over [0, horizon] for every grid (course, speed); a new array.
        With ``utility``, what it makes of the distance instead (0..100).

        Same operations as :func:`cpa_distance`, with b = r0.w carried negated
        (``nb = w.(-r0)``, exact) so that t* = nb / (a + 1e-300) needs no negation. With
        numba, one compiled pass (CPA and utility together, point by point).
        """
        compiled = _compiled_points()
        if compiled is not None:  # the same operations per grid point, compiled
            out = np.empty(self.vx.shape)
            compiled(self.vx, self.vy,
                     *self.point_args(osx, osy, cnx, cny, cnh_deg, cnv, horizon, utility), out)
            return out
        h = np.radians(cnh_deg)
        cwx, cwy = cnv * np.sin(h), cnv * np.cos(h)
        dx, dy = osx - cnx, osy - cny
        wx = np.subtract(self.vx, cwx)
        wy = np.subtract(self.vy, cwy)
        a = np.multiply(wx, wx)
        tmp = np.multiply(wy, wy)
        a += tmp
        wx *= -dx
        wy *= -dy
        nb = np.add(wx, wy, out=wx)
        np.add(a, 1e-300, out=tmp)
        t = np.divide(nb, tmp, out=wy)
        np.maximum(t, 0.0, out=t)  # clip to [0, T] (np.clip: slow for small arrays)
        np.minimum(t, max(horizon, 0.0), out=t)
        a *= t
        nb *= 2.0
        a -= nb  # a t + 2 b
        a *= t
        a += dx * dx + dy * dy
        np.maximum(a, 0.0, out=a)
        cpa = np.sqrt(a, out=a)
        return cpa if utility is None else utility.apply(cpa)


@dataclass(slots=True, unsafe_hash=True)
class AvoidUtility:
    """AvoidCollision's utility of the CPA (:func:`avoid_utility_inplace`), m. (Made at
    every build: slots, hashed by its fields, not frozen, which costs three times as much
    to make; read it, do not change it. Likewise :class:`CutRangeUtility`.)"""

    min_util: float
    max_util: float

    def apply(self, cpa: NDArray[np.float64]) -> NDArray[np.float64]:
        return avoid_utility_inplace(cpa, self.min_util, self.max_util)

    def kernel_args(self) -> tuple[int, float, float]:
        return _AVOID, self.min_util, 75.0 / max(self.max_util - self.min_util, 1e-9)


@dataclass(slots=True, unsafe_hash=True)
class CutRangeUtility:
    """Far Trail's utility of the CPA (:func:`cut_range_utility_inplace`), ``range_m`` m."""

    range_m: float

    def apply(self, cpa: NDArray[np.float64]) -> NDArray[np.float64]:
        return cut_range_utility_inplace(cpa, self.range_m)

    def kernel_args(self) -> tuple[int, float, float]:
        return _CUT_RANGE, self.range_m, 0.0


def avoid_utility_inplace(cpa: np.ndarray, min_util: float, max_util: float) -> np.ndarray:
    """AvoidCollision's utility of a CPA distance (m), in ``cpa``'s own storage: 0 below
    ``min_util``, 100 above ``max_util``, 25 -> 100 linearly between (IvP
    ``AOF_AvoidCollision::metric``); the same operations as
    :func:`~uhrisim.autonomy.behaviors.avoid_collision.cpa_utility`."""
    span = max(max_util - min_util, 1e-9)
    keep = cpa >= min_util  # cpa is never NaN: the complement of cpa < min_util
    u = cpa
    u -= min_util
    u *= 75.0 / span
    u += 25.0
    np.maximum(u, 25.0, out=u)
    np.minimum(u, 100.0, out=u)
    u *= keep  # x 1.0 keeps u exactly, x 0.0 zeroes it (u in [25, 100])
    return u


def cut_range_utility_inplace(cpa: np.ndarray, range_m: float) -> np.ndarray:
    """Far Trail's utility 100 - 100 cpa / ``range_m`` clipped to 0..100, in ``cpa``'s own
    storage (IvP ``AOF_CutRangeCPA``; ``range_m`` the distance to the trail point)."""
    u = cpa
    u *= 100.0
    u /= range_m
    np.subtract(100.0, u, out=u)
    np.maximum(u, 0.0, out=u)
    np.minimum(u, 100.0, out=u)
    return u


_DISTANCE, _AVOID, _CUT_RANGE = 0, 1, 2  # what the compiled kernel makes of the CPA


def _cpa_points(vx, vy, cwx, cwy, dx, dy, r2, horizon, kind, p0, p1, out):  # type: ignore[no-untyped-def]
    """:meth:`CpaGrid.distance` point by point (:func:`cpa_points_into`), compiled by numba."""
    cpa_points_into(vx.ravel(), vy.ravel(), cwx, cwy, dx, dy, r2, horizon, kind, p0, p1,
                    out.ravel())


def cpa_points_into(vx, vy, cwx, cwy, dx, dy, r2, horizon, kind, p0, p1, out):  # type: ignore[no-untyped-def]
    """``out[k]`` = :func:`cpa_point` at own velocity (``vx[k]``, ``vy[k]``), 1-D arrays; for
    compiled kernels. One loop per utility kind, each with its kind a constant, so that
    each vectorises."""
    if kind == _AVOID:
        for k in range(out.shape[0]):
            out[k] = cpa_point(vx[k], vy[k], cwx, cwy, dx, dy, r2, horizon, _AVOID, p0, p1)
    elif kind == _CUT_RANGE:
        for k in range(out.shape[0]):
            out[k] = cpa_point(vx[k], vy[k], cwx, cwy, dx, dy, r2, horizon, _CUT_RANGE, p0, p1)
    else:
        for k in range(out.shape[0]):
            out[k] = cpa_point(vx[k], vy[k], cwx, cwy, dx, dy, r2, horizon, _DISTANCE, p0, p1)


def cpa_point(vx, vy, cwx, cwy, dx, dy, r2, horizon, kind, p0, p1):  # type: ignore[no-untyped-def]
    """One grid point of :meth:`CpaGrid.distance` for own velocity (``vx``, ``vy``) m/s:
    the CPA distance, then the utility ``kind`` makes of it (``_AVOID``:
    :func:`avoid_utility_inplace` with ``p0`` = min_util, ``p1`` = 75 / span;
    ``_CUT_RANGE``: :func:`cut_range_utility_inplace` with ``p0`` = range). The same
    operations in the same order as the numpy path; compiled kernels call it."""
    wx, wy = vx - cwx, vy - cwy
    a = wx * wx + wy * wy
    nb = wx * -dx + wy * -dy
    t = nb / (a + 1e-300)
    t = min(max(t, 0.0), horizon)
    a = ((a * t) - nb * 2.0) * t + r2
    cpa = np.sqrt(max(a, 0.0))
    if kind == _AVOID:
        u = min(max((cpa - p0) * p1 + 25.0, 25.0), 100.0)
        return u if cpa >= p0 else 0.0
    if kind == _CUT_RANGE:
        return min(max(100.0 - (cpa * 100.0) / p0, 0.0), 100.0)
    return cpa


@cache
def _compiled_points():  # type: ignore[no-untyped-def]
    callable_compiled(cpa_point)
    callable_compiled(cpa_points_into)
    return jit(_cpa_points, numpy_errors=True)


def cpa_distance_reference(
    osx: float,
    osy: float,
    course_deg: float,
    speed: float,
    cnx: float,
    cny: float,
    cnh_deg: float,
    cnv: float,
    horizon: float,
    n_samples: int = 20001,
) -> float:
    """Slow reference: minimum range over ``n_samples`` equally spaced times in [0, horizon]."""
    t = np.linspace(0.0, horizon, n_samples)
    vx, vy = velocity_xy(course_deg, speed)
    cvx, cvy = velocity_xy(cnh_deg, cnv)
    r = np.hypot(osx + vx * t - (cnx + cvx * t), osy + vy * t - (cny + cvy * t))
    return float(r.min())
