"""Coupling two 1-D functions into one over (course, speed) (IvP ``OF_Coupler``).

docs/reference/helm.md: each function is rescaled to 0..w (w = 50 by default) and the two are
added, F(c, v) = f_c(c) + f_v(v); F is then normalised to 0..100 (OF_Coupler.cpp:74-98).

Rescaling is IvP's ``PDMap::normalize`` (PDMap.cpp:169-183): a constant function (no
preference) keeps its value. Constants never change an argmax; they show in audits.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.autonomy.domain import Domain, Objective
from uhrisim.core.compiled import jit

__all__ = ["couple", "couple_reference", "coupled_objective", "rescale"]


def rescale(f: ArrayLike, low: float, high: float) -> NDArray[np.float64]:
    """Affinely map the range [min f, max f] onto [low, high] (a constant is unchanged)."""
    a = np.asarray(f, dtype=float)
    fmin, fmax = float(a.min()), float(a.max())
    if fmax - fmin <= 0.0:
        return a.copy()
    return low + (a - fmin) * ((high - low) / (fmax - fmin))


def _rescale_ranged(f: ArrayLike, high: float) -> tuple[NDArray[np.float64], float, float]:
    """``rescale(f, 0, high)`` and its exact min and max (taken at f's own extremes: the
    map is monotone, so no second pass over the result is needed)."""
    a = np.asarray(f, dtype=float)
    fmin, fmax = float(a.min()), float(a.max())
    if fmax - fmin <= 0.0:
        return a.copy(), fmin, fmax
    k = high / (fmax - fmin)
    out = np.subtract(a, fmin)
    out *= k  # 0 + x dropped: x >= +0 here
    return out, 0.0, (fmax - fmin) * k


def couple(
    f_course: ArrayLike,
    f_speed: ArrayLike,
    course_weight: float = 50.0,
    speed_weight: float = 50.0,
    normalize: bool = True,
) -> NDArray[np.float64]:
    """F[i, j] = rescale(f_course, 0, wc)[i] + rescale(f_speed, 0, ws)[j], normalised 0..100.

    Shapes: ``f_course`` (n_course,), ``f_speed`` (n_speed,) -> (n_course, n_speed).
    Bit-identical to :func:`couple_reference`: the grid's min and max are taken from the
    1-D pieces (rounding is monotone, so min_ij fl(a_i + b_j) = fl(min a + min b)) and the
    final rescale is applied as each sum is made (``0 + x`` is dropped: x >= +0 here).
    """
    return _couple(f_course, f_speed, course_weight, speed_weight, normalize)[0]


def coupled_objective(
    domain: Domain,
    f_course: ArrayLike,
    f_speed: ArrayLike,
    weights: tuple[float, float] = (50.0, 50.0),
) -> Objective:
    """:func:`couple` (normalised) as the objective over (course, speed) a behavior hands
    the helm, with its exact range (the solver's range check then reads no table)."""
    table, lo, hi = _couple(f_course, f_speed, weights[0], weights[1], True)
    return Objective.over(domain, ("course", "speed"), table, (lo, hi))


def _couple(f_course, f_speed, course_weight, speed_weight, normalize):  # type: ignore[no-untyped-def]
    """:func:`couple`'s table and its exact (min, max), known from the 1-D pieces (the
    final rescale is monotone too). With numba the table is made in one compiled pass."""
    fc, cmin, cmax = _rescale_ranged(f_course, course_weight)
    fs, smin, smax = _rescale_ranged(f_speed, speed_weight)
    fmin = cmin + smin
    fmax = cmax + smax
    scale = normalize and fmax - fmin > 0.0  # both constant: their sum stays
    k = 100.0 / (fmax - fmin) if scale else 1.0
    compiled = _compiled_table()
    if compiled is not None:
        F = np.empty((fc.shape[0], fs.shape[0]))
        compiled(fc, fs, fmin, k, scale, F)
    else:
        F = np.add.outer(fc, fs)
        if scale:
            F -= fmin
            F *= k
    if scale:
        return F, (fmin - fmin) * k, (fmax - fmin) * k
    return F, fmin, fmax


def _table(fc, fs, fmin, k, scale, out):  # type: ignore[no-untyped-def]
    """``out[i, j] = fc[i] + fs[j]``, then ``(. - fmin) * k`` when ``scale``: the numpy
    path's operations point by point (compiled by numba)."""
    for i in range(fc.shape[0]):
        a = fc[i]
        if scale:
            for j in range(fs.shape[0]):
                out[i, j] = ((a + fs[j]) - fmin) * k
        else:
            for j in range(fs.shape[0]):
                out[i, j] = a + fs[j]


@cache
def _compiled_table():  # type: ignore[no-untyped-def]
    return jit(_table, numpy_errors=True)


def couple_reference(
    f_course: ArrayLike,
    f_speed: ArrayLike,
    course_weight: float = 50.0,
    speed_weight: float = 50.0,
    normalize: bool = True,
) -> NDArray[np.float64]:
    """Plain transcription of the module docstring (reference for :func:`couple`)."""
    fc = rescale(f_course, 0.0, course_weight)
    fs = rescale(f_speed, 0.0, speed_weight)
    F = fc[:, None] + fs[None, :]
    return rescale(F, 0.0, 100.0) if normalize else F
