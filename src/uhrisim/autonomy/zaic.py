"""ZAIC 1-D utility functions (IvP ``ZAIC_PEAK``, ``ZAIC_LEQ``, ``ZAIC_HEQ``).

Semantics from reference/helm.md ("ZAIC peak"). With d the distance of x to the summit s
(circular when ``wrap_period`` is given, e.g. course: summit 350, x = 10 -> d = 20):

* d <= pw:             U = max - (delta/pw) * d      (U = max when pw <= 0 or delta <= 0)
* pw < d <= pw + bw:   U falls linearly from (max - delta_eff) to min at d = pw + bw
* otherwise:           U = min

``delta_eff`` is the summit delta when pw > 0 and 0 otherwise (with no peak plateau the
base starts at the summit value, so the function stays continuous); delta is clipped to
``max - min``. On a grid, if every point is at ``min`` (the peak falls between grid
points), the grid point nearest the summit gets ``max`` ("insist summit").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.autonomy.domain import DomainAxis

__all__ = ["zaic_heq", "zaic_leq", "zaic_peak", "zaic_peak_on_axis"]


def _distance(x: NDArray, summit: float, wrap_period: float | None) -> NDArray:
    d = np.abs(x - summit)
    if wrap_period:
        d = d % wrap_period
        d = np.minimum(d, wrap_period - d)
    return d


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
    """ZAIC peak utility at points ``x`` (same unit as the summit); see module docstring."""
    xa = np.asarray(x, dtype=float)
    d = _distance(xa, float(summit), wrap_period)
    # widths below 1e-9 (of the axis unit) are zero: avoids overflow on subnormal widths
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
        # linear from edge at d = pw to min at d = pw + bw, clamped at min beyond
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
    """ZAIC peak over a domain axis (wraps when the axis wraps), with insist-summit."""
    u = zaic_peak(
        axis.values,
        summit,
        peakwidth,
        basewidth,
        summitdelta,
        minutil,
        maxutil,
        wrap_period=axis.period if axis.wrap else None,
    )
    if insist_summit and np.all(u <= minutil):
        u[axis.index_of(summit)] = maxutil
    return u


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
