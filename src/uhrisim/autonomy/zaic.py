"""ZAIC 1-D utility functions (IvP ``ZAIC_PEAK``, ``ZAIC_LEQ``, ``ZAIC_HEQ``).

Semantics from docs/reference/helm.md ("ZAIC peak"). With d the distance of x to the summit s
(circular when ``wrap_period`` is given, e.g. course: summit 350, x = 10 -> d = 20):

* d <= pw:             U = max - (delta/pw) * d      (U = max when pw <= 0 or delta <= 0)
* pw < d <= pw + bw:   U falls linearly from (max - delta_eff) to min at d = pw + bw
* otherwise:           U = min

``delta_eff`` is the summit delta when pw > 0 and 0 otherwise (with no peak plateau the
base starts at the summit value, so the function stays continuous); delta is clipped to
``max - min``. On a grid, if every point is at ``min`` (the peak falls between grid
points), one grid point gets ``max`` ("insist summit", ZAIC_PEAK.cpp:378-428): the first
index for a summit below the axis, the last for one above it (wrapping axes too), else
the grid point nearest the summit along the axis (not around it), the lower on a tie.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.autonomy.domain import DomainAxis
from uhrisim.core.compiled import jit

__all__ = [
    "ZaicMemo",
    "insist_index",
    "zaic_heq",
    "zaic_leq",
    "zaic_peak",
    "zaic_peak_on_axis",
    "zaic_peak_reference",
]


def _distance(x: NDArray, summit: float, wrap_period: float | None) -> NDArray:
    """|x - summit| (circular when ``wrap_period``), as a new array."""
    d = np.subtract(x, summit, out=np.empty_like(x))  # a real array for 0-d x too
    np.abs(d, out=d)
    if wrap_period:  # d >= 0 and period > 0: fmod is the remainder (% in the reference)
        np.fmod(d, wrap_period, out=d)
        np.minimum(d, wrap_period - d, out=d)
    return d


def _peak_shape(peakwidth: float, basewidth: float, summitdelta: float, minutil: float,
                maxutil: float) -> tuple[float, float, float]:
    """(peak width, base width, summit delta) as the peak uses them: widths below 1e-9 (of
    the axis unit) are zero (no overflow on subnormal widths), delta within 0..max-min."""
    pw = float(peakwidth) if peakwidth > 1e-9 else 0.0
    bw = float(basewidth) if basewidth > 1e-9 else 0.0
    return pw, bw, min(max(float(summitdelta), 0.0), maxutil - minutil)


def zaic_peak(
    x: ArrayLike,
    summit: float,
    peakwidth: float,
    basewidth: float,
    summitdelta: float,
    minutil: float = 0.0,
    maxutil: float = 100.0,
    wrap_period: float | None = None,
) -> NDArray[np.float64]:
    """ZAIC peak utility at points ``x`` (same unit as the summit); see module docstring.

    Evaluated in place (one working array): in the peak ``max - (delta/pw) * d``, in the
    base ``max(edge - ((edge - min)/bw) * (d - pw), min)`` - the same floating-point
    operations as :func:`zaic_peak_reference`, so the values are bit-identical.
    """
    xa = np.asarray(x, dtype=float)
    pw, bw, delta = _peak_shape(peakwidth, basewidth, summitdelta, minutil, maxutil)
    sloped = pw > 0.0 and delta > 0.0
    edge = maxutil - delta if sloped else maxutil
    d = _distance(xa, float(summit), wrap_period)
    in_peak = d <= pw
    if bw > 0.0:
        # linear from edge at d = pw to min at d = pw + bw, clamped at min beyond
        u = np.subtract(d, pw, out=np.empty_like(d))
        u *= (edge - minutil) / bw
        np.subtract(edge, u, out=u)
        np.maximum(u, minutil, out=u)
    else:
        u = np.full_like(d, minutil)
    if sloped:
        d *= delta / pw
        np.subtract(maxutil, d, out=d)
        np.copyto(u, d, where=in_peak)
    else:
        u[in_peak] = maxutil
    return u


def zaic_peak_reference(
    x: ArrayLike,
    summit: float,
    peakwidth: float,
    basewidth: float,
    summitdelta: float,
    minutil: float = 0.0,
    maxutil: float = 100.0,
    wrap_period: float | None = None,
) -> NDArray[np.float64]:
    """Plain transcription of the module docstring (reference for :func:`zaic_peak`)."""
    xa = np.asarray(x, dtype=float)
    d = np.abs(xa - float(summit))
    if wrap_period:
        d = d % wrap_period
        d = np.minimum(d, wrap_period - d)
    pw = float(peakwidth) if peakwidth > 1e-9 else 0.0
    bw = float(basewidth) if basewidth > 1e-9 else 0.0
    delta = float(np.clip(summitdelta, 0.0, maxutil - minutil))
    if pw > 0.0 and delta > 0.0:
        in_peak = maxutil - (delta / pw) * d
        edge = maxutil - delta
    else:
        in_peak = np.full_like(d, maxutil)
        edge = maxutil
    if bw > 0.0:
        base = np.maximum(edge - (edge - minutil) / bw * (d - pw), minutil)
    else:
        base = np.full_like(d, minutil)
    return np.where(d <= pw, in_peak, base)


def zaic_peak_on_axis(
    axis: DomainAxis,
    summit: float,
    peakwidth: float,
    basewidth: float,
    summitdelta: float,
    minutil: float = 0.0,
    maxutil: float = 100.0,
    insist_summit: bool = True,
) -> NDArray[np.float64]:
    """ZAIC peak over a domain axis (wraps when the axis wraps), with insist-summit.
    With numba, :func:`zaic_peak`'s operations run compiled, point by point
    (:func:`_peak_points`; a test holds the two bit for bit)."""
    compiled = _compiled_peak()
    if compiled is None:
        u = zaic_peak(axis.values, summit, peakwidth, basewidth, summitdelta, minutil,
                      maxutil, wrap_period=axis.period if axis.wrap else None)
        top = u.max()
    else:
        u = np.empty(axis.npts)
        top = compiled(axis.values, float(summit),
                       *_peak_shape(peakwidth, basewidth, summitdelta, minutil, maxutil),
                       float(minutil), float(maxutil),
                       float(axis.period) if axis.wrap else 0.0, u)
    if insist_summit and not top > minutil:
        u[insist_index(axis, summit)] = maxutil
    return u



def _peak_points(x, summit, pw, bw, delta, minutil, maxutil, period, out):  # type: ignore[no-untyped-def]
    """:func:`zaic_peak` point by point (compiled by numba; ``period`` 0: no wrap), the
    same operations in the same order at every point; returns the maximum (NaN if any)."""
    sloped = pw > 0.0 and delta > 0.0
    edge = maxutil - delta if sloped else maxutil
    base_slope = (edge - minutil) / bw if bw > 0.0 else 0.0
    peak_slope = delta / pw if sloped else 0.0
    top = -np.inf
    for k in range(x.shape[0]):
        d = abs(x[k] - summit)
        if period > 0.0:
            if d >= period:  # fmod(d, period) is d itself below the period
                d = np.fmod(d, period)
            d = min(d, period - d)
        u = max(edge - (d - pw) * base_slope, minutil) if bw > 0.0 else minutil
        if d <= pw:
            u = maxutil - d * peak_slope if sloped else maxutil
        out[k] = u
        if u > top or u != u:
            top = u
    return top


@cache
def _compiled_peak():  # type: ignore[no-untyped-def]
    return jit(_peak_points, numpy_errors=True)

def insist_index(axis: DomainAxis, summit: float) -> int:
    """The grid index an insisted summit lands on (module docstring)."""
    if summit < axis.low:
        return 0
    if summit > axis.high:
        return axis.npts - 1
    return int(np.argmin(np.abs(axis.values - summit)))  # first minimum: the lower index


class ZaicMemo:
    """:func:`zaic_peak_on_axis` remembering its last call (one per behavior instance).

    The function is pure, so when the arguments repeat (ConstantDepth's depth, Loiter's
    speed) the previous result is returned - the same read-only array.
    """

    __slots__ = ("_key", "_value")

    def __init__(self) -> None:
        self._key: tuple | None = None
        self._value: NDArray[np.float64] | None = None

    def __call__(
        self,
        axis: DomainAxis,
        summit: float,
        peakwidth: float,
        basewidth: float,
        summitdelta: float,
        minutil: float = 0.0,
        maxutil: float = 100.0,
        insist_summit: bool = True,
    ) -> NDArray[np.float64]:
        key = (axis, summit, peakwidth, basewidth, summitdelta, minutil, maxutil, insist_summit)
        if self._value is None or key != self._key:
            u = zaic_peak_on_axis(axis, *key[1:])
            u.flags.writeable = False
            self._key, self._value = key, u
        return self._value


def zaic_leq(
    x: ArrayLike, summit: float, basewidth: float, minutil: float = 0.0, maxutil: float = 100.0
) -> NDArray[np.float64]:
    """ZAIC_LEQ: ``max`` for x <= summit, falling linearly to ``min`` at summit + basewidth."""
    xa = np.asarray(x, dtype=float)
    if basewidth <= 0.0:
        return np.where(xa <= summit, maxutil, minutil).astype(float)
    frac = np.clip((xa - summit) / basewidth, 0.0, 1.0)
    return maxutil - (maxutil - minutil) * frac


def zaic_heq(
    x: ArrayLike, summit: float, basewidth: float, minutil: float = 0.0, maxutil: float = 100.0
) -> NDArray[np.float64]:
    """ZAIC_HEQ: ``max`` for x >= summit, falling linearly to ``min`` at summit - basewidth."""
    xa = np.asarray(x, dtype=float)
    return zaic_leq(-xa, -summit, basewidth, minutil, maxutil)
