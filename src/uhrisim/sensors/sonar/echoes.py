"""The echo of each ray and the raw echo image: echoes summed into (range bin, beam) cells.

A ray that hits at slant range R with incidence β on a surface of Lambert coefficient μ
returns, relative to the source level (``docs/reference/sonar.md``),
``b_v(φ)²·D(θ)·ΔΩ·μ·cos β·R⁻²·10^(−2αR/10)`` (two-way spreading and absorption, Lambert
scattering off the patch R²ΔΩ/cos β the ray stands for, the element directivity D across
the fan; the weight b_v(φ)²·D(θ)·ΔΩ is precomputed, :mod:`uhrisim.sensors.sonar.geometry`).
Each echo is spread evenly over the range footprint of its elevation slice, R·δφ·tan β,
so a floor stays continuous however few rays are cast, and summed into the cells; rays
stop at the first hit, so shadows come only from the geometry. The raw image then goes
through the stages of :mod:`uhrisim.sensors.sonar.polar`.
"""

from __future__ import annotations

import math
from functools import cache

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.compiled import jit, jit_with
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.geometry import SonarGeometry
from uhrisim.sensors.sonar.labels import CellLabeller, unlabelled

#: Cap on tan β when spreading a ray's echo over its range footprint (β ≈ 85°).
MAX_FOOTPRINT_TAN = 12.0

#: The smallest positive normal float32 (the raw image's zero floor adds it).
_FLOAT32_TINY = float(np.finfo(np.float32).tiny)
#: Echo-free row gaps shorter than this (range bins) are filtered with their neighbours
#: rather than split into a separate OpenCV call (exact either way; fewer calls).
_ROW_RUN_MERGE_GAP = 16


def ray_echo(
    weight: NDArray[np.float64],
    r: NDArray[np.float64],
    cos_inc: NDArray[np.float64],
    mu: NDArray[np.float64],
    two_alpha_ln: float,
) -> NDArray[np.float64]:
    """Echo intensity of each hit ray relative to the source level (linear):
    ``weight·μ·cosβ·R⁻²·exp(−two_alpha_ln·R)``, with the ray weights b_v(φ)²·ΔΩ, slant
    ranges ``r`` (m), |cos incidence| ``cos_inc``, Lambert μ ``mu`` and the two-way
    absorption ``two_alpha_ln`` (natural-log units per metre)."""
    rr = np.maximum(r, 1e-3)
    return weight * mu * cos_inc * np.exp(-two_alpha_ln * rr) / (rr * rr)


def footprint(
    r: NDArray[np.float64], cos_inc: NDArray[np.float64], dphi: float, cfg: SonarConfig
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Range footprint of each ray in bin units: (start, length).

    A ray stands for an elevation slice ``dphi`` (rad); on a surface seen at incidence β
    that slice spans ΔR = R·δφ·tan β in range, centred on the ray's hit (a flat floor at
    height h: ΔR ≈ R²δφ/h). Spreading each echo evenly over its footprint keeps the sea
    floor continuous however few rays are cast (tan β is capped at
    :data:`MAX_FOOTPRINT_TAN`). Returned in fractional bins from ``range_min_m``.
    """
    c = np.clip(cos_inc, 1.0 / math.sqrt(1.0 + MAX_FOOTPRINT_TAN**2), 1.0)
    length = r * (dphi / cfg.bin_m) * (np.sqrt(1.0 - c * c) / c)
    start = (r - cfg.range_min_m) / cfg.bin_m - 0.5 * length
    return start, length


def _row_runs(cover: NDArray[np.bool_], pad: int, gap: int) -> list[tuple[int, int]]:
    """Half-open row ranges [start, stop) that hold every True row of ``cover`` widened by
    ``pad`` rows each side (clipped to the image); ranges closer than ``gap`` rows are
    merged. Rows outside the ranges are at least ``pad`` rows from any True row."""
    rows = np.flatnonzero(cover)
    if rows.size == 0:
        return []
    cut = np.flatnonzero(np.diff(rows) > 2 * pad + gap)
    starts = np.maximum(np.concatenate([rows[:1], rows[cut + 1]]) - pad, 0)
    stops = np.minimum(np.concatenate([rows[cut], rows[-1:]]) + pad + 1, cover.size)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def footprint_image(a: NDArray[np.float64], b: NDArray[np.float64], lo: NDArray[np.int64],
                    hi: NDArray[np.int64], dens: NDArray[np.float64], one: NDArray[np.float64],
                    beam: NDArray[np.int64], r0: int, diff: NDArray[np.float64],
                    out: NDArray[np.float32], floor: np.float32,
                    integ: NDArray[np.float64] | None = None) -> None:
    """Footprints [a, b) (fractional bins; first and last bin ``lo``, ``hi``; echo per bin
    ``dens``; ``one``: the echo of a footprint inside one bin) of rays in beams ``beam``
    summed into ``out``, rows ``r0`` … of the raw image (rows, beams; float32); every
    cell not above ``floor`` then zeroed (OpenCV's THRESH_TOZERO, a float32 comparison).

    Each footprint becomes four steps along range of a difference image: its first bin
    gets its overlap w_first, the bins between the density each, its last bin its overlap
    w_last (a footprint inside one bin: steps +one, −one). The steps are added, all first
    steps then all second …, in ray order, into the zeroed flat scratch ``diff`` ((rows +
    1) × beams, float64; zeroed again on return); the cumulative sum down each column is
    the column differences of the float64 integral image (OpenCV's), cast to float32.
    ``integ``: scratch for the integral image (at least (rows + 2) × (beams + 1)). The
    reference for :func:`_footprint_image_loops` (numba), which gives the same bits."""
    n_rows, n_beams = out.shape
    same = lo == hi
    w_first = np.where(same, one, dens * (lo + 1 - a))
    w_last = np.where(same, 0.0, dens * (b - hi))
    inner = np.where(same, 0.0, dens)
    rows_first = (lo - r0) * n_beams + beam
    rows_last = (hi - r0) * n_beams + beam
    cells = np.concatenate([rows_first, rows_first + n_beams, rows_last, rows_last + n_beams])
    steps = np.concatenate([w_first, inner - w_first, w_last - inner, -w_last])
    np.add.at(diff, cells, steps)
    integ = cv2.integral(diff.reshape(n_rows + 1, n_beams),
                         sum=None if integ is None else integ[: n_rows + 2],
                         sdepth=cv2.CV_64F)  # fmt: skip
    diff.fill(0.0)
    cv2.subtract(integ[1:-1, 1:], integ[1:-1, :-1], dst=out, dtype=cv2.CV_32F)
    cv2.threshold(out, float(floor), 0.0, cv2.THRESH_TOZERO, dst=out)


def _footprint_image_loops(a, b, lo, hi, dens, one, beam, r0, diff, out, floor):  # type: ignore[no-untyped-def]
    """:func:`footprint_image` as loops for numba: the same float64 operations in the same
    order (the four steps of every footprint, in the same order; OpenCV's integral image:
    a running sum s along each row, each row's integral the row above plus s; then float32
    of neighbouring columns' difference, zeroed unless above ``floor``), without the step
    arrays or the integral image in memory; each scratch row zeroed as it is read. Four
    rows at a time, their running sums side by side (the same operations, in an order the
    processor can overlap)."""
    n_rows, n_beams = out.shape
    m = a.shape[0]
    for step in range(4):
        for k in range(m):
            same = lo[k] == hi[k]
            w_first = one[k] if same else dens[k] * ((lo[k] + 1) - a[k])
            w_last = 0.0 if same else dens[k] * (b[k] - hi[k])
            inner = 0.0 if same else dens[k]
            if step == 0:
                diff[(lo[k] - r0) * n_beams + beam[k]] += w_first
            elif step == 1:
                diff[(lo[k] - r0 + 1) * n_beams + beam[k]] += inner - w_first
            elif step == 2:
                diff[(hi[k] - r0) * n_beams + beam[k]] += w_last - inner
            else:
                diff[(hi[k] - r0 + 1) * n_beams + beam[k]] += -w_last
    above = np.zeros(n_beams + 1)  # the integral image's row above the current rows
    i = 0
    while i < n_rows:
        if i + 4 <= n_rows:
            b0, b1, b2, b3 = i * n_beams, (i + 1) * n_beams, (i + 2) * n_beams, (i + 3) * n_beams
            s0 = s1 = s2 = s3 = 0.0
            v0 = v1 = v2 = v3 = 0.0  # each row's integral at the previous column
            for x in range(n_beams):
                s0 += diff[b0 + x]
                s1 += diff[b1 + x]
                s2 += diff[b2 + x]
                s3 += diff[b3 + x]
                diff[b0 + x] = diff[b1 + x] = diff[b2 + x] = diff[b3 + x] = 0.0
                n0 = above[x + 1] + s0
                n1 = n0 + s1
                n2 = n1 + s2
                n3 = n2 + s3
                out[i, x] = _above_or_zero(n0 - v0, floor)
                out[i + 1, x] = _above_or_zero(n1 - v1, floor)
                out[i + 2, x] = _above_or_zero(n2 - v2, floor)
                out[i + 3, x] = _above_or_zero(n3 - v3, floor)
                v0, v1, v2, v3 = n0, n1, n2, n3
                above[x + 1] = n3
            i += 4
        else:
            b0 = i * n_beams
            s0 = v0 = 0.0
            for x in range(n_beams):
                s0 += diff[b0 + x]
                diff[b0 + x] = 0.0
                n0 = above[x + 1] + s0
                out[i, x] = _above_or_zero(n0 - v0, floor)
                v0 = n0
                above[x + 1] = n0
            i += 1
    diff[n_rows * n_beams :] = 0.0  # the last row: steps past the image's end


def _above_or_zero(value, floor):  # type: ignore[no-untyped-def]
    """``value`` as float32 where above ``floor`` (float32), else 0 (THRESH_TOZERO's)."""
    v = np.float32(value)
    return v if v > floor else np.float32(0.0)


def _row_runs_loops(lo, hi, n_bins, pad, gap):  # type: ignore[no-untyped-def]
    """:func:`_row_runs` of the range bins the footprints [``lo``, ``hi``] reach, as
    loops for numba: (k, 2) rows [start, stop)."""
    reach = np.zeros(n_bins + 1, np.int64)  # footprints open at a bin, less those closed
    for k in range(lo.shape[0]):
        reach[lo[k]] += 1
        reach[hi[k] + 1] -= 1
    runs = np.empty((n_bins, 2), np.int64)
    n_runs = 0
    depth = 0
    first = last = -1  # the current run's first and last covered bin
    for i in range(n_bins):
        depth += reach[i]
        if depth > 0:
            if last >= 0 and i - last > 2 * pad + gap:
                runs[n_runs, 0], runs[n_runs, 1] = max(first - pad, 0), min(last + pad + 1, n_bins)
                n_runs += 1
                last = -1
            if last < 0:
                first = i
            last = i
    if last >= 0:
        runs[n_runs, 0], runs[n_runs, 1] = max(first - pad, 0), min(last + pad + 1, n_bins)
        n_runs += 1
    return runs[:n_runs]


def footprint_bins(r: NDArray[np.float64], cos_inc: NDArray[np.float64],
                   e: NDArray[np.float64], dphi: float, cfg: SonarConfig
                   ) -> tuple[NDArray[np.float64], ...]:
    """Footprints (:func:`footprint`) of rays at slant ranges ``r`` (m) with |cos
    incidence| ``cos_inc`` and echoes ``e``, clipped to the window, in fractional bins, for
    the rays whose footprint overlaps the window (``keep``): start ``a``, end ``b``, first
    and last bin ``lo``, ``hi``, echo per bin ``dens`` and ``one``, the echo of a footprint
    inside a single bin (all of it, or the part inside the window). The reference for
    :func:`_footprint_bins_loops` (numba), which gives the same bits."""
    n_bins = cfg.n_bins
    a, length = footprint(r, cos_inc, dphi, cfg)
    length = np.maximum(length, 1e-9)
    b = a + length
    keep = (b > 0.0) & (a < n_bins)
    if not keep.all():
        a, b, length, e = a[keep], b[keep], length[keep], e[keep]
    dens = e / length
    top = n_bins * (1.0 - 1e-12)
    whole = (a >= 0.0) & (b <= top)
    b = np.clip(b, 0.0, top)
    a = np.clip(a, 0.0, top)
    one = np.where(whole, e, dens * (b - a))
    return keep, a, b, a.astype(np.int64), b.astype(np.int64), dens, one


def _footprint_bins_loops(r, cos_inc, e, per_bin, range_min_m, bin_m, n_bins):  # type: ignore[no-untyped-def]
    """:func:`footprint_bins` as one loop for numba, the same float64 operations in the
    same order (``per_bin`` = δφ / bin size, as :func:`footprint` forms it)."""
    n = r.shape[0]
    keep = np.empty(n, np.bool_)
    a_out, b_out, dens_out, one_out = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    lo_out, hi_out = np.empty(n, np.int64), np.empty(n, np.int64)
    c_min = 1.0 / math.sqrt(1.0 + MAX_FOOTPRINT_TAN**2)
    top = n_bins * (1.0 - 1e-12)
    m = 0
    for k in range(n):
        c = min(max(cos_inc[k], c_min), 1.0)
        length = r[k] * per_bin * (math.sqrt(1.0 - c * c) / c)
        a = (r[k] - range_min_m) / bin_m - 0.5 * length
        length = max(length, 1e-9)
        b = a + length
        keep[k] = (b > 0.0) and (a < n_bins)
        if not keep[k]:
            continue
        dens = e[k] / length
        whole = (a >= 0.0) and (b <= top)
        b = min(max(b, 0.0), top)
        a = min(max(a, 0.0), top)
        a_out[m], b_out[m], dens_out[m] = a, b, dens
        one_out[m] = e[k] if whole else dens * (b - a)
        lo_out[m], hi_out[m] = int(a), int(b)
        m += 1
    return (keep, a_out[:m], b_out[:m], lo_out[:m], hi_out[:m], dens_out[:m],
            one_out[:m])  # fmt: skip


@cache
def _compiled_kernels():  # type: ignore[no-untyped-def]
    """(:func:`_footprint_bins_loops`, :func:`_footprint_image_loops`,
    :func:`_row_runs_loops`) compiled (numba), or None without numba."""
    bins, image, runs = (jit(_footprint_bins_loops),
                         jit_with(_footprint_image_loops, (_above_or_zero,)),
                         jit(_row_runs_loops))  # fmt: skip
    return None if bins is None else (bins, image, runs)


class EchoAccumulator:
    """Sums ray echoes into the raw echo image of ``geometry``/``config`` and labels its
    cells; keeps its scratch images between pings (not re-entrant: one per sonar)."""

    def __init__(self, geometry: SonarGeometry, config: SonarConfig) -> None:
        self.geometry = geometry
        self.config = config
        n_bins, n_beams = config.n_bins, config.sonar_spec.n_beams
        self._raw = np.zeros((n_bins, n_beams), np.float32)
        #: Rows [start, stop) of the raw image that may hold echo; zero outside them.
        self._written = (0, 0)
        self._diff = np.zeros((n_bins + 1) * n_beams, np.float64)  # all zero between pings
        self._integ = np.zeros((n_bins + 2, n_beams + 1), np.float64)
        self._labeller = CellLabeller(n_bins * n_beams)
        #: The polar labels of every ping formed without labels.
        self.unlabelled = unlabelled((n_bins, n_beams))

    def accumulate(
        self,
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        cos_inc: NDArray[np.float64],
        e: NDArray[np.float64],
        labels: NDArray[np.int32] | None = None,
    ) -> tuple[NDArray[np.float32], NDArray[np.int16], list[tuple[int, int]]]:
        """Sum ray echoes into (bin, beam) cells, each spread evenly over its range
        footprint [a, b) (fractional bins: the end bins get their overlap, the bins in
        between e/(b − a) each), and label each cell (−1: none; all −1 when ``labels`` is
        None) with the scene label that put the most echo into it. Also returns the row
        ranges [start, stop) outside which the raw image is zero by construction (no
        footprint reaches those range bins), widened by the range-blur half-width.

        O(rays + cells of the rows the footprints reach): every footprint becomes four steps
        of a difference image whose cumulative sum along range is the raw image
        (:func:`footprint_image`), over
        the slab of rows between the nearest and the farthest footprint only. Labels: the most
        frequent label of the ping (usually the sea floor) is the background; the rays of
        every other label are expanded into their footprint cells and their echo summed per
        label; a cell takes the label with the most echo, the background's being the rest
        of the cell's sum.
        The returned raw image is a scratch buffer of this instance (valid until the next
        ping); the labels are a new array (with ``labels`` None: the shared read-only
        :attr:`unlabelled` image).
        """
        g = self.geometry
        n_bins, n_beams = self._raw.shape
        if labels is None:
            label_polar = self.unlabelled
        else:
            label_polar = np.full((n_bins, n_beams), -1, dtype=np.int16)
        raw = self._raw
        if idx.size == 0:
            self._zero_outside(0, 0)
            return raw, label_polar, []
        compiled = _compiled_kernels()
        if compiled is not None:
            cfg = self.config
            keep, a, b, lo, hi, dens, one = compiled[0](
                r, cos_inc, e, g.dphi / cfg.bin_m, cfg.range_min_m, cfg.bin_m, cfg.n_bins)
        else:
            keep, a, b, lo, hi, dens, one = footprint_bins(r, cos_inc, e, g.dphi, self.config)
        if not keep.all():
            idx, e = idx[keep], e[keep]
            labels = labels[keep] if labels is not None else None
            if idx.size == 0:
                self._zero_outside(0, 0)
                return raw, label_polar, []
        beam = g.ray_beam[idx]
        # Rows [r0, r1) hold every footprint; the rest of the image gets no echo.
        r0, r1 = int(lo.min()), int(hi.max()) + 1
        self._zero_outside(r0, r1)
        slab = raw[r0:r1]
        # Summed into the zeroed scratch (a fresh megabyte-sized array per ping would cost
        # page faults), which is zeroed again once read.
        diff = self._diff[: (r1 - r0 + 1) * n_beams]
        # Round-off of the integral image (~1e-16 of a row sum, itself ≤ the ping's total
        # echo) must not count as echo (it would label shadows): zero everything below
        # 1e-12 of the total echo (−120 dB: far below any noise floor).
        floor = np.float32(1e-12 * float(e.sum()) + _FLOAT32_TINY)
        pad = g.range_kernel.size // 2
        if compiled is not None:
            compiled[1](a, b, lo, hi, dens, one, beam, r0, diff, slab, floor)
            rows = [(int(start), int(stop))
                    for start, stop in compiled[2](lo, hi, n_bins, pad, _ROW_RUN_MERGE_GAP)]
        else:
            footprint_image(a, b, lo, hi, dens, one, beam, r0, diff, slab, floor, self._integ)
            # Range bins some footprint reaches (a difference count over [lo, hi]).
            reach = (np.bincount(lo, minlength=n_bins + 1)
                     - np.bincount(hi + 1, minlength=n_bins + 1))  # fmt: skip
            rows = _row_runs(np.cumsum(reach[:n_bins]) > 0, pad, _ROW_RUN_MERGE_GAP)
        if labels is not None:
            self._labeller.label(raw, label_polar, labels, a, b, lo, hi, dens, one, beam)
        return raw, label_polar, rows

    def _zero_outside(self, start: int, stop: int) -> None:
        """Zero the raw image outside rows [start, stop), which the caller then writes:
        only the rows the previous ping wrote need it."""
        raw = self._raw
        w0, w1 = self._written
        raw[w0 : min(w1, start)].fill(0.0)
        raw[max(w0, stop) : w1].fill(0.0)
        self._written = (start, stop)

    def add_echoes(self, bins: NDArray[np.int64], beams: NDArray[np.int64],
                   echoes: NDArray[np.float64]) -> None:
        """Add ``echoes`` (re SL) into cells (``bins``, ``beams``) of the raw image of the
        last :meth:`accumulate` (volume echoes; any row)."""
        np.add.at(self._raw, (bins, beams), echoes.astype(np.float32))
        self._written = (0, self._raw.shape[0])
