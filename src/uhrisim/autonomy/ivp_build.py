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

from uhrisim.autonomy.cpa import AvoidUtility, CpaGrid, CutRangeUtility, cpa_point
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
    samples (4 corners, then the centre), stacked on axis 0: (5, pieces c, pieces s)."""

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
    return _Layout(
        c_lo, c_hi, s_lo, s_hi, flat,
        np.stack([np.broadcast_to(c, (len(c_lo), 1)) for c, _ in at]).astype(float),
        np.stack([np.broadcast_to(s, (1, len(s_lo))) for _, s in at]).astype(float),
        np.maximum(C1 - C0, 1).astype(float), np.maximum(S1 - S0, 1).astype(float),
        C1 == C0, S1 == S0, centre, use, np.where(centre, 5.0, 4.0),
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
    lo, hi = compiled(F, L.c_lo, L.c_hi, L.s_lo, L.s_hi, out)
    return out, lo, hi


def reflect_cpa(grid: CpaGrid, osx: float, osy: float, cnx: float, cny: float, cnh_deg: float,
                cnv: float, horizon: float, utility: AvoidUtility | CutRangeUtility,
                piece: tuple[int, int]) -> tuple[NDArray[np.float64], float, float]:
    """:func:`reflect_ranged` of ``grid.distance(osx, ..., utility)`` (a CPA utility over
    the course x speed grid; :meth:`~uhrisim.autonomy.cpa.CpaGrid.distance`).

    With numba one compiled call: the utility at every grid point
    (:func:`~uhrisim.autonomy.cpa.cpa_point`), then the fit, both normalisations and the
    table (:func:`_reflect_pieces`) in the same array - the same values. (The utility at
    just the points the fit reads, 4 corners and a centre a piece, costs more: a loop
    over scattered points does not vectorise.)"""
    compiled = _compiled_reflect_cpa()
    if compiled is None:
        return reflect_ranged(grid.distance(osx, osy, cnx, cny, cnh_deg, cnv, horizon, utility),
                              piece)
    n_c, n_s = grid.shape
    L = _layout(n_c, n_s, piece[0], piece[1])
    out = np.empty((n_c, n_s))
    lo, hi = compiled(grid.vx, grid.vy,
                      *grid.point_args(osx, osy, cnx, cny, cnh_deg, cnv, horizon, utility),
                      L.c_lo, L.c_hi, L.s_lo, L.s_hi, out)
    return out, lo, hi


def _reflect_cpa_pieces(vx, vy, cwx, cwy, dx, dy, r2, horizon, kind, p0, p1,  # type: ignore[no-untyped-def]
                        c_lo, c_hi, s_lo, s_hi, out):
    """:func:`reflect_cpa` compiled: the utility into ``out``, which the fit reads before
    the table overwrites it."""
    vxf, vyf, outf = vx.ravel(), vy.ravel(), out.ravel()
    for k in range(outf.shape[0]):
        outf[k] = cpa_point(vxf[k], vyf[k], cwx, cwy, dx, dy, r2, horizon, kind, p0, p1)
    return _reflect_pieces(out, c_lo, c_hi, s_lo, s_hi, out)


def _reflect_pieces(F, c_lo, c_hi, s_lo, s_hi, out):  # type: ignore[no-untyped-def]
    """:func:`reflect` piece by piece in loops (compiled by numba): the fit of
    :func:`fit_pieces_reference` (with the corners' range of the first :func:`normalize`),
    the first normalisation (with the second's range), the second; then the table, row by
    row. Each value is computed by the same floating-point operations as the numpy path.

    Returns the table's (min, max), taken at the pieces' corners: ``b + mc*c + ms*s`` is
    monotone in c and in s under rounding, so no grid point of a piece lies outside the
    range of its corners."""
    n_pc, n_ps = c_lo.shape[0], s_lo.shape[0]
    b = np.empty((n_pc, n_ps))
    mc = np.empty((n_pc, n_ps))
    ms = np.empty((n_pc, n_ps))
    lo, hi = np.inf, -np.inf
    for i in range(n_pc):
        c0, c1 = c_lo[i], c_hi[i]
        cm = c0 + (c1 - c0) // 2
        for j in range(n_ps):
            s0, s1 = s_lo[j], s_hi[j]
            centre = c1 - c0 > 1 or s1 - s0 > 1
            v0, v1, v2, v3 = F[c0, s0], F[c1, s0], F[c0, s1], F[c1, s1]
            slope_c = 0.0 if c1 == c0 else (((v1 - v0) + (v3 - v2)) / 2.0) / (c1 - c0)
            slope_s = 0.0 if s1 == s0 else (((v2 - v0) + (v3 - v1)) / 2.0) / (s1 - s0)
            v_hi = max(max(max(max(-np.inf, v0), v1), v2), v3)
            v_lo = min(min(min(min(np.inf, v0), v1), v2), v3)
            p0 = slope_c * float(c0) + slope_s * float(s0)
            p1 = slope_c * float(c1) + slope_s * float(s0)
            p2 = slope_c * float(c0) + slope_s * float(s1)
            p3 = slope_c * float(c1) + slope_s * float(s1)
            total = (((v0 - p0) + (v1 - p1)) + (v2 - p2)) + (v3 - p3)
            if centre:
                v4 = F[cm, s0 + (s1 - s0) // 2]
                p4 = slope_c * float(cm) + slope_s * float(s0 + (s1 - s0) // 2)
                v_hi, v_lo = max(v_hi, v4), min(v_lo, v4)
                total = total + (v4 - p4)
                intercept = total / 5
            else:
                intercept = total / 4
            upper = min(min(min(min(np.inf, v_hi - p0), v_hi - p1), v_hi - p2), v_hi - p3)
            lower = max(max(max(max(-np.inf, v_lo - p0), v_lo - p1), v_lo - p2), v_lo - p3)
            if centre:
                upper, lower = min(upper, v_hi - p4), max(lower, v_lo - p4)
            if intercept > upper:
                intercept = upper
            if intercept < lower:
                intercept = lower
            b[i, j], mc[i, j], ms[i, j] = intercept, slope_c, slope_s
            lo, hi = _corners_range(intercept, slope_c, slope_s, c0, c1, s0, s1, lo, hi)
    for _ in range(2):  # normalize(0, 100) twice; the first gives the second's range
        if not hi - lo > 0.0:  # a constant stays
            break
        scale, lo_k = 100.0 / (hi - lo), lo
        lo, hi = np.inf, -np.inf
        for i in range(n_pc):
            for j in range(n_ps):
                bij = (b[i, j] + (0.0 - lo_k)) * scale
                mcij, msij = mc[i, j] * scale, ms[i, j] * scale
                b[i, j], mc[i, j], ms[i, j] = bij, mcij, msij
                lo, hi = _corners_range(bij, mcij, msij, c_lo[i], c_hi[i], s_lo[j], s_hi[j],
                                        lo, hi)  # fmt: skip
    n_s = out.shape[1]
    row_b, row_mc, row_ms = np.empty(n_s), np.empty(n_s), np.empty(n_s)
    s_index = np.arange(n_s).astype(np.float64)
    for i in range(n_pc):  # the coefficients of this row of pieces, spread over the columns
        for j in range(n_ps):
            for s in range(s_lo[j], s_hi[j] + 1):
                row_b[s], row_mc[s], row_ms[s] = b[i, j], mc[i, j], ms[i, j]
        for c in range(c_lo[i], c_hi[i] + 1):
            fc = float(c)
            for s in range(n_s):
                out[c, s] = row_b[s] + row_mc[s] * fc + row_ms[s] * s_index[s]
    return lo, hi


def _corners_range(b, mc, ms, c0, c1, s0, s1, lo, hi):  # type: ignore[no-untyped-def]
    """(lo, hi) widened by the plane ``b + mc*c + ms*s`` over the piece ``[c0, c1] x
    [s0, s1]`` (grid indices). Under rounding the plane is monotone in c and in s (each
    operation is), so its least corner is the one its slopes' signs point away from and its
    greatest the opposite one: the minimum and maximum of all four corners, evaluated at
    two. Which of two equal values is kept does not matter: only a zero's sign could
    differ, and every use of the range is blind to it."""
    c_lo, c_hi = (c0, c1) if mc >= 0.0 else (c1, c0)
    s_lo, s_hi = (s0, s1) if ms >= 0.0 else (s1, s0)
    return (min(lo, b + mc * float(c_lo) + ms * float(s_lo)),
            max(hi, b + mc * float(c_hi) + ms * float(s_hi)))


@cache
def _compiled_reflect():  # type: ignore[no-untyped-def]
    callable_compiled(_corners_range)
    return jit(_reflect_pieces, numpy_errors=True)


@cache
def _compiled_reflect_cpa():  # type: ignore[no-untyped-def]
    if _compiled_reflect() is None:
        return None
    callable_compiled(cpa_point)
    callable_compiled(_reflect_pieces)
    return jit(_reflect_cpa_pieces, numpy_errors=True)
