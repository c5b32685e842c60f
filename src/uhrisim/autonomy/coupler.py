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
from uhrisim.core.compiled import callable_compiled, jit

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
    final rescale is monotone too). With numba the whole coupling (both rescales, the
    table, its range) is one compiled pass (:func:`_couple_pass`, the same operations)."""
    compiled = _compiled_couple()
    if compiled is not None:
        fc = np.ascontiguousarray(f_course, dtype=float)
        fs = np.ascontiguousarray(f_speed, dtype=float)
        F = np.empty((fc.shape[0], fs.shape[0]))
        lo, hi = compiled(fc, fs, float(course_weight), float(speed_weight), normalize, F)
        return F, lo, hi
    fc, cmin, cmax = _rescale_ranged(f_course, course_weight)
    fs, smin, smax = _rescale_ranged(f_speed, speed_weight)
    fmin = cmin + smin
    fmax = cmax + smax
    scale = normalize and fmax - fmin > 0.0  # both constant: their sum stays
    k = 100.0 / (fmax - fmin) if scale else 1.0
    F = np.add.outer(fc, fs)
    if scale:
        F -= fmin
        F *= k
        return F, (fmin - fmin) * k, (fmax - fmin) * k
    return F, fmin, fmax


def _rescaled_in_place(f, high):  # type: ignore[no-untyped-def]
    """:func:`_rescale_ranged` on ``f``'s own storage, point by point (compiled)."""
    fmin, fmax = f.min(), f.max()
    if fmax - fmin <= 0.0:
        return fmin, fmax
    k = high / (fmax - fmin)
    for i in range(f.shape[0]):
        f[i] = (f[i] - fmin) * k
    return 0.0, (fmax - fmin) * k


def _couple_pass(f_course, f_speed, course_weight, speed_weight, normalize, out):  # type: ignore[no-untyped-def]
    """:func:`_couple`'s numpy path point by point (compiled by numba): both rescales, the
    table ``out[i, j] = fc[i] + fs[j]`` (then ``(. - fmin) * k`` when scaled); returns the
    table's exact (min, max) as the numpy path does."""
    fc, fs = f_course.copy(), f_speed.copy()
    cmin, cmax = _rescaled_in_place(fc, course_weight)
    smin, smax = _rescaled_in_place(fs, speed_weight)
    fmin = cmin + smin
    fmax = cmax + smax
    scale = normalize and fmax - fmin > 0.0
    k = 100.0 / (fmax - fmin) if scale else 1.0
    for i in range(fc.shape[0]):
        a = fc[i]
        if scale:
            for j in range(fs.shape[0]):
                out[i, j] = ((a + fs[j]) - fmin) * k
        else:
            for j in range(fs.shape[0]):
                out[i, j] = a + fs[j]
    if scale:
        return (fmin - fmin) * k, (fmax - fmin) * k
    return fmin, fmax


@cache
def _compiled_couple():  # type: ignore[no-untyped-def]
    callable_compiled(_rescaled_in_place)
    return jit(_couple_pass, numpy_errors=True)


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
