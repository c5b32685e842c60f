"""IvP function building as pHelmIvP does it: piecewise-linear fits and normalisation.

Behaviors whose utility is a general function of (course, speed) - AvoidCollision, Trail
beyond ``nm_radius`` - do not hand pHelmIvP the exact table: ``OF_Reflector`` covers the
grid with uniform pieces of ``piece`` grid indices per axis and fits each with a plane
(``Regressor::setWeight1``, strict range), and the helm maximises that piecewise surface.
A grid table reproduces pHelmIvP's decisions only if it reproduces the fit, so this
module computes it (MOOS-IvP source, ivp/src/lib_ivpbuild: BuildUtils.cpp:613-790 piece
layout, Regressor.cpp:177-310 the fit; lib_ivpcore PDMap.cpp:169-183 ``normalize``).

Pieces, per axis: index ranges ``[0, p-1], [p, 2p-1], ...``, the last one cut short by the
axis end. One piece ``[c0, c1] x [s0, s1]`` (grid indices, course first) is fitted from its
four corners, plus its centre ``(c0 + (c1-c0)//2, s0 + (s1-s0)//2)`` when it spans more
than two indices on some axis:

* slopes: mean of the two opposite edge differences per axis, over the run (0 on a
  single-index axis);
* intercept: mean over the samples of ``value - plane``, clamped so that the plane stays
  within the samples' [min, max] at every sample (the upper bound is applied first);
* value at a grid point ``(c, s)`` of the piece: ``b + mc*c + ms*s``.

``normalize(base, range)`` maps [min, max] of the function onto [base, base + range] (the
second argument is a range); a constant function is left as it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np
from numpy.typing import NDArray

from uhrisim.autonomy.cpa import AvoidUtility, CpaGrid, CutRangeUtility, cpa_point, cpa_points_into
from uhrisim.core.compiled import callable_compiled, jit

__all__ = [
    "PiecewisePlanes",
    "fit_pieces",
    "fit_pieces_reference",
    "normalize",
    "reflect",
    "reflect_cpa",
    "reflect_ranged",
]


@dataclass(frozen=True)
class PiecewisePlanes:
    """Planes over uniform pieces of a 2-D grid: ``value = b + mc*c + ms*s`` on piece
    ``(i, j)`` for grid indices ``c`` in ``c_lo[i]..c_hi[i]``, ``s`` in ``s_lo[j]..s_hi[j]``.
    Arrays ``b``, ``mc``, ``ms`` have shape (pieces along course, pieces along speed)."""

    c_lo: NDArray[np.int64]
    c_hi: NDArray[np.int64]
    s_lo: NDArray[np.int64]
    s_hi: NDArray[np.int64]
    b: NDArray[np.float64]
    mc: NDArray[np.float64]
    ms: NDArray[np.float64]

    def corners(self) -> NDArray[np.float64]:
        """Every piece's value at its four corners, shape (4, pieces, pieces)."""
        c = (self.c_lo[:, None], self.c_hi[:, None])
        s = (self.s_lo[None, :], self.s_hi[None, :])
        return np.stack([self.b + self.mc * ci + self.ms * si for si in s for ci in c])

    def table(self) -> NDArray[np.float64]:
        """The function on the whole grid, shape (n course, n speed).

        Every piece is laid out on a padded block of the full piece size (the last, cut
        short, spills past the grid and is sliced off): one broadcast, ``b + mc*c + ms*s``
        in that order at each grid point."""
        n_c, n_s = int(self.c_hi[-1]) + 1, int(self.s_hi[-1]) + 1
        pc = int(self.c_hi[0] - self.c_lo[0]) + 1
        ps = int(self.s_hi[0] - self.s_lo[0]) + 1
        c = (self.c_lo[:, None] + np.arange(pc)).astype(float)[:, :, None, None]
        s = (self.s_lo[:, None] + np.arange(ps)).astype(float)[None, None, :, :]
        b, mc, ms = (a[:, None, :, None] for a in (self.b, self.mc, self.ms))
        padded = b + mc * c + ms * s
        return padded.reshape(len(self.c_lo) * pc, len(self.s_lo) * ps)[:n_c, :n_s]


def _spans(n: int, piece: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    lo = np.arange(0, n, piece)
    return lo, np.minimum(lo + piece - 1, n - 1)


@dataclass(frozen=True)
class _Layout:
    """The pieces of one grid shape and piece size, and the grid indices of their five
    samples (4 corners, then the centre), stacked on axis 0: (5, pieces c, pieces s).
    ``samples`` and ``geometry`` are the same, one column a piece (piece (i, j) in column
    i * pieces s + j), for the compiled fit (:func:`_fit_samples`)."""

    c_lo: NDArray[np.int64]
    c_hi: NDArray[np.int64]
    s_lo: NDArray[np.int64]
    s_hi: NDArray[np.int64]
    flat: NDArray[np.int64]  # flat grid index of each sample
    c: NDArray[np.float64]  # its course index, (5, pieces c, 1)
    s: NDArray[np.float64]  # its speed index, (5, 1, pieces s)
    run_c: NDArray[np.float64]  # c_hi - c_lo, 1 where 0 (its slope is 0 then)
    run_s: NDArray[np.float64]
    flat_c: NDArray[np.bool_]  # single-index pieces along course
    flat_s: NDArray[np.bool_]
    centre: NDArray[np.bool_]  # pieces with a centre sample
    use: NDArray[np.bool_]  # (5, ...): the samples a piece uses
    count: NDArray[np.float64]  # 5.0 or 4.0
    samples: NDArray[np.int64]  # flat grid index of each sample, (5, pieces)
    column_piece: NDArray[np.int64]  # the piece index along speed of each grid column
    geometry: NDArray[np.float64]  # (11, pieces), rows: first, last and centre index along
    # course, then speed; the runs (1 where 0); 1.0 / 0.0: single-index along course, speed;
    # a centre sample


@lru_cache(maxsize=16)
def _layout(n_c: int, n_s: int, pc: int, ps: int) -> _Layout:
    c_lo, c_hi = _spans(n_c, pc)
    s_lo, s_hi = _spans(n_s, ps)
    C0, C1, S0, S1 = c_lo[:, None], c_hi[:, None], s_lo[None, :], s_hi[None, :]
    at = [(C0, S0), (C1, S0), (C0, S1), (C1, S1), (C0 + (C1 - C0) // 2, S0 + (S1 - S0) // 2)]
    flat = np.stack([np.broadcast_to(c * n_s + s, (len(c_lo), len(s_lo))) for c, s in at])
    centre = ((C1 - C0) > 1) | ((S1 - S0) > 1)
    use = np.ones((5, *centre.shape), dtype=bool)
    use[4] = centre
    run_c, run_s = np.maximum(C1 - C0, 1).astype(float), np.maximum(S1 - S0, 1).astype(float)
    shape = centre.shape
    geometry = np.stack([np.broadcast_to(row, shape).astype(float).ravel() for row in (
        C0, C1, at[4][0], S0, S1, at[4][1], run_c, run_s, C1 == C0, S1 == S0, centre)])
    return _Layout(
        c_lo, c_hi, s_lo, s_hi, flat,
        np.stack([np.broadcast_to(c, (len(c_lo), 1)) for c, _ in at]).astype(float),
        np.stack([np.broadcast_to(s, (1, len(s_lo))) for _, s in at]).astype(float),
        run_c, run_s, C1 == C0, S1 == S0, centre, use, np.where(centre, 5.0, 4.0),
        np.ascontiguousarray(flat.reshape(5, -1)), np.arange(n_s) // ps, geometry,
    )  # fmt: skip


def fit_pieces(values: NDArray[np.float64], piece: tuple[int, int]) -> PiecewisePlanes:
    """Fit planes to ``values`` (course x speed grid) over pieces of ``piece`` indices
    (module docstring); the same floating-point operations as :func:`fit_pieces_reference`,
    on all pieces at once (samples stacked: 4 corners, then the centre)."""
    F = np.asarray(values, dtype=float)
    L = _layout(F.shape[0], F.shape[1], piece[0], piece[1])
    v = F.ravel()[L.flat]
    mc = (((v[1] - v[0]) + (v[3] - v[2])) / 2.0) / L.run_c
    ms = (((v[2] - v[0]) + (v[3] - v[1])) / 2.0) / L.run_s
    mc[np.broadcast_to(L.flat_c, mc.shape)] = 0.0
    ms[np.broadcast_to(L.flat_s, ms.shape)] = 0.0
    planes = mc * L.c + ms * L.s
    hi = v.max(axis=0, where=L.use, initial=-np.inf)
    lo = v.min(axis=0, where=L.use, initial=np.inf)
    residual = v - planes
    total = ((residual[0] + residual[1]) + residual[2]) + residual[3]
    total = np.where(L.centre, total + residual[4], total)
    upper = (hi - planes).min(axis=0, where=L.use, initial=np.inf)
    lower = (lo - planes).max(axis=0, where=L.use, initial=-np.inf)
    b = total / L.count
    b = np.where(b > upper, upper, b)
    b = np.where(b < lower, lower, b)
    return PiecewisePlanes(L.c_lo, L.c_hi, L.s_lo, L.s_hi, b, mc, ms)


def fit_pieces_reference(
    values: NDArray[np.float64], piece: tuple[int, int]
) -> PiecewisePlanes:
    """Piece by piece, as the module docstring reads (reference for :func:`fit_pieces`)."""
    F = np.asarray(values, dtype=float)
    c_lo, c_hi = _spans(F.shape[0], piece[0])
    s_lo, s_hi = _spans(F.shape[1], piece[1])
    b, mc, ms = (np.empty((len(c_lo), len(s_lo))) for _ in range(3))
    for i, (c0, c1) in enumerate(zip(c_lo, c_hi, strict=True)):
        for j, (s0, s1) in enumerate(zip(s_lo, s_hi, strict=True)):
            pts = [(c0, s0), (c1, s0), (c0, s1), (c1, s1)]
            if c1 - c0 > 1 or s1 - s0 > 1:
                pts.append((c0 + (c1 - c0) // 2, s0 + (s1 - s0) // 2))
            v = [float(F[p]) for p in pts]
            slope_c = 0.0 if c1 == c0 else (((v[1] - v[0]) + (v[3] - v[2])) / 2.0) / (c1 - c0)
            slope_s = 0.0 if s1 == s0 else (((v[2] - v[0]) + (v[3] - v[1])) / 2.0) / (s1 - s0)
            planes = [slope_c * c + slope_s * s for c, s in pts]
            total = 0.0
            for vk, pk in zip(v, planes, strict=True):
                total += vk - pk
            intercept = total / len(pts)
            intercept = min(intercept, min(max(v) - p for p in planes))
            intercept = max(intercept, max(min(v) - p for p in planes))
            b[i, j], mc[i, j], ms[i, j] = intercept, slope_c, slope_s
    return PiecewisePlanes(c_lo, c_hi, s_lo, s_hi, b, mc, ms)


def normalize(f: PiecewisePlanes, base: float = 0.0, span: float = 100.0) -> PiecewisePlanes:
    """``PDMap::normalize(base, span)``: [min, max] onto [base, base + span]; the intercept
    moves first, then every weight scales. A constant function is returned unchanged."""
    corners = f.corners()
    lo, hi = float(corners.min()), float(corners.max())
    if not hi - lo > 0.0:
        return f
    k = span / (hi - lo)
    return PiecewisePlanes(
        f.c_lo, f.c_hi, f.s_lo, f.s_hi, (f.b + (base - lo)) * k, f.mc * k, f.ms * k
    )


def reflect(values: NDArray[np.float64], piece: tuple[int, int]) -> NDArray[np.float64]:
    """What pHelmIvP's reflector-built behaviors hand the solver: ``values`` fitted over
    pieces of ``piece`` indices, normalised 0..100 by the reflector and again by the
    behavior (OF_Reflector.cpp:112-113, then e.g. BHV_AvoidCollision.cpp:293), as a table.

    With numba (``uhrisim[fast]``) the same operations run compiled, piece by piece
    (:func:`_reflect_pieces`; a test holds the two bit for bit); else numpy, all pieces
    at once."""
    return reflect_ranged(values, piece)[0]


def reflect_ranged(
    values: NDArray[np.float64], piece: tuple[int, int]
) -> tuple[NDArray[np.float64], float, float]:
    """:func:`reflect`'s table and its exact minimum and maximum (the solver's range
    check then needs no pass over the table)."""
    compiled = _compiled_reflect()
    if compiled is None:
        table = normalize(normalize(fit_pieces(values, piece))).table()
        return table, float(table.min()), float(table.max())
    F = np.ascontiguousarray(values, dtype=float)
    L = _layout(F.shape[0], F.shape[1], piece[0], piece[1])
    out = np.empty_like(F)
    lo, hi = compiled(F, L.samples, L.geometry, L.c_lo, L.c_hi, L.column_piece, out)
    return out, lo, hi


def reflect_cpa(grid: CpaGrid, osx: float, osy: float, cnx: float, cny: float, cnh_deg: float,
                cnv: float, horizon: float, utility: AvoidUtility | CutRangeUtility,
                piece: tuple[int, int]) -> tuple[NDArray[np.float64], float, float]:
    """:func:`reflect_ranged` of ``grid.distance(osx, ..., utility)`` (a CPA utility over
    the course x speed grid; :meth:`~uhrisim.autonomy.cpa.CpaGrid.distance`).

    With numba one compiled call that works out the utility only where the fit reads it,
    the pieces' corners and centres (:func:`~uhrisim.autonomy.cpa.cpa_point` at own
    velocities gathered once per grid and piece size, :func:`_sample_velocities`), then
    the fit, both normalisations and the table (:func:`_reflect_samples`) - the same
    values."""
    compiled = _compiled_reflect_cpa()
    if compiled is None:
        return reflect_ranged(grid.distance(osx, osy, cnx, cny, cnh_deg, cnv, horizon, utility),
                              piece)
    n_c, n_s = grid.shape
    L = _layout(n_c, n_s, piece[0], piece[1])
    vx, vy = _sample_velocities(grid, piece)
    out = np.empty((n_c, n_s))
    lo, hi = compiled(vx, vy,
                      *grid.point_args(osx, osy, cnx, cny, cnh_deg, cnv, horizon, utility),
                      L.geometry, L.c_lo, L.c_hi, L.column_piece, out)
    return out, lo, hi


@lru_cache(maxsize=16)
def _sample_velocities(grid: CpaGrid, piece: tuple[int, int]
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Own velocity (east, north) m/s at the samples of ``piece``-sized pieces of ``grid``,
    shape (5, pieces) as :attr:`_Layout.samples`."""
    L = _layout(*grid.shape, *piece)
    return grid.vx.ravel()[L.samples], grid.vy.ravel()[L.samples]


def _reflect_cpa_samples(vx, vy, cwx, cwy, dx, dy, r2, horizon, kind, p0, p1,  # type: ignore[no-untyped-def]
                         geometry, c_lo, c_hi, column_piece, out):
    """:func:`reflect_cpa` compiled: the utility at the samples, then
    :func:`_reflect_samples`."""
    samples = np.empty(vx.shape)
    cpa_points_into(vx.ravel(), vy.ravel(), cwx, cwy, dx, dy, r2, horizon, kind, p0, p1,
                    samples.ravel())
    return _reflect_samples(samples, geometry, c_lo, c_hi, column_piece, out)


def _reflect_pieces(F, samples, geometry, c_lo, c_hi, column_piece, out):  # type: ignore[no-untyped-def]
    """:func:`reflect` compiled: ``F`` at the samples (:attr:`_Layout.samples`), then
    :func:`_reflect_samples`."""
    at, flat = np.empty(samples.shape), F.ravel()
    at_flat, where = at.ravel(), samples.ravel()
    for k in range(where.shape[0]):
        at_flat[k] = flat[where[k]]
    return _reflect_samples(at, geometry, c_lo, c_hi, column_piece, out)


def _reflect_samples(samples, geometry, c_lo, c_hi, column_piece, out):  # type: ignore[no-untyped-def]
    """:func:`reflect` from the function's values at the pieces' samples (compiled by
    numba): the fit of :func:`fit_pieces_reference` (:func:`_fit_samples`, with the
    corners' range of the first :func:`normalize`), the first normalisation (with the
    second's range), the second; then the table into ``out``, row by row. Each value is
    computed by the same floating-point operations as the numpy path; the loops over the
    pieces hold no branches, so they vectorise.

    Returns the table's (min, max), taken at the pieces' corners (:func:`_plane_range`)."""
    coef = np.empty((5, samples.shape[1]))  # b, mc, ms, then each piece's least and greatest
    b, mc, ms, least, greatest = coef[0], coef[1], coef[2], coef[3], coef[4]
    c0s, c1s, s0s, s1s = geometry[0], geometry[1], geometry[3], geometry[4]
    _fit_samples(samples, geometry, coef)
    lo, hi = _least_greatest(least, greatest)
    for _ in range(2):  # normalize(0, 100) twice; the first gives the second's range
        if not hi - lo > 0.0:  # a constant stays
            break
        scale, offset = 100.0 / (hi - lo), 0.0 - lo
        for k in range(b.shape[0]):
            b[k], mc[k], ms[k] = (b[k] + offset) * scale, mc[k] * scale, ms[k] * scale
            least[k], greatest[k] = _plane_range(b[k], mc[k], ms[k], c0s[k], c1s[k], s0s[k],
                                                 s1s[k])
        lo, hi = _least_greatest(least, greatest)
    n_ps, n_s = column_piece[-1] + 1, out.shape[1]
    row_b, row_mc, row_ms = np.empty(n_s), np.empty(n_s), np.empty(n_s)
    s_index = np.arange(n_s).astype(np.float64)
    for i in range(c_lo.shape[0]):
        for s in range(n_s):  # the coefficients of this row of pieces, spread over the columns
            k = i * n_ps + column_piece[s]
            row_b[s], row_mc[s], row_ms[s] = b[k], mc[k], ms[k]
        for c in range(c_lo[i], c_hi[i] + 1):
            fc, row = float(c), out[c]
            for s in range(n_s):
                row[s] = row_b[s] + row_mc[s] * fc + row_ms[s] * s_index[s]
    return lo, hi


def _fit_samples(samples, geometry, coef):  # type: ignore[no-untyped-def]
    """Each piece's plane from its samples (rows: 4 corners, then the centre), as
    :func:`fit_pieces_reference` fits it: into ``coef`` rows 0-2 (b, mc, ms), and rows 3-4
    its least and greatest value (:func:`_plane_range`). Branch-free (a choice is made of
    two values both worked out), so that it vectorises."""
    v0s, v1s, v2s, v3s, v4s = samples[0], samples[1], samples[2], samples[3], samples[4]
    c0s, c1s, cms, s0s, s1s, sms = (geometry[0], geometry[1], geometry[2], geometry[3],
                                    geometry[4], geometry[5])
    run_cs, run_ss, flat_cs, flat_ss, centres = (geometry[6], geometry[7], geometry[8],
                                                 geometry[9], geometry[10])
    for k in range(v0s.shape[0]):
        v0, v1, v2, v3, v4 = v0s[k], v1s[k], v2s[k], v3s[k], v4s[k]
        c0, c1, cm, s0, s1, sm = c0s[k], c1s[k], cms[k], s0s[k], s1s[k], sms[k]
        centre = centres[k] > 0.0
        slope_c = (((v1 - v0) + (v3 - v2)) / 2.0) / run_cs[k]
        slope_c = 0.0 if flat_cs[k] > 0.0 else slope_c
        slope_s = (((v2 - v0) + (v3 - v1)) / 2.0) / run_ss[k]
        slope_s = 0.0 if flat_ss[k] > 0.0 else slope_s
        v_hi = max(max(max(max(-np.inf, v0), v1), v2), v3)
        v_lo = min(min(min(min(np.inf, v0), v1), v2), v3)
        p0 = slope_c * c0 + slope_s * s0
        p1 = slope_c * c1 + slope_s * s0
        p2 = slope_c * c0 + slope_s * s1
        p3 = slope_c * c1 + slope_s * s1
        p4 = slope_c * cm + slope_s * sm
        total = (((v0 - p0) + (v1 - p1)) + (v2 - p2)) + (v3 - p3)
        intercept = (total + (v4 - p4)) / 5.0 if centre else total / 4.0
        v_hi = max(v_hi, v4) if centre else v_hi
        v_lo = min(v_lo, v4) if centre else v_lo
        upper = min(min(min(min(np.inf, v_hi - p0), v_hi - p1), v_hi - p2), v_hi - p3)
        lower = max(max(max(max(-np.inf, v_lo - p0), v_lo - p1), v_lo - p2), v_lo - p3)
        upper = min(upper, v_hi - p4) if centre else upper
        lower = max(lower, v_lo - p4) if centre else lower
        intercept = upper if intercept > upper else intercept
        intercept = lower if intercept < lower else intercept
        coef[0, k], coef[1, k], coef[2, k] = intercept, slope_c, slope_s
        coef[3, k], coef[4, k] = _plane_range(intercept, slope_c, slope_s, c0, c1, s0, s1)


def _plane_range(b, mc, ms, c0, c1, s0, s1):  # type: ignore[no-untyped-def]
    """(least, greatest) value of the plane ``b + mc*c + ms*s`` over the piece ``[c0, c1]
    x [s0, s1]`` (grid indices, as floats). Under rounding the plane is monotone in c and
    in s (each operation is), so its least corner is the one its slopes' signs point away
    from and its greatest the opposite one: the minimum and maximum of all four corners,
    evaluated at two. Which of two equal values is kept does not matter: only a zero's
    sign could differ, and every use of the range is blind to it."""
    c_up, s_up = mc >= 0.0, ms >= 0.0
    return (b + mc * (c0 if c_up else c1) + ms * (s0 if s_up else s1),
            b + mc * (c1 if c_up else c0) + ms * (s1 if s_up else s0))


def _least_greatest(least, greatest):  # type: ignore[no-untyped-def]
    """(min of ``least``, max of ``greatest``), with four of each in flight (the order
    does not matter: only a zero's sign could, see :func:`_plane_range`)."""
    lo = np.full(4, np.inf)
    hi = np.full(4, -np.inf)
    n = least.shape[0]
    for k in range(0, n - n % 4, 4):
        for q in range(4):
            lo[q] = min(lo[q], least[k + q])
            hi[q] = max(hi[q], greatest[k + q])
    for k in range(n - n % 4, n):
        lo[0] = min(lo[0], least[k])
        hi[0] = max(hi[0], greatest[k])
    return min(min(lo[0], lo[1]), min(lo[2], lo[3])), max(max(hi[0], hi[1]), max(hi[2], hi[3]))


@cache
def _compiled_reflect():  # type: ignore[no-untyped-def]
    for helper in (_plane_range, _fit_samples, _least_greatest, _reflect_samples):
        callable_compiled(helper)
    return jit(_reflect_pieces, numpy_errors=True)


@cache
def _compiled_reflect_cpa():  # type: ignore[no-untyped-def]
    if _compiled_reflect() is None:
        return None
    callable_compiled(cpa_point)
    callable_compiled(cpa_points_into)
    return jit(_reflect_cpa_samples, numpy_errors=True)
