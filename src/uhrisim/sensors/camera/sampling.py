"""Adaptive pixel sampling: one ray per pixel only where the image needs it.

The scene's surfaces carry one albedo each (a textured one aside: the camera casts every
ray on it), so within one surface the image varies smoothly; it changes abruptly only at
the edges of objects and at creases.
``sampling="adaptive"`` therefore casts rays at every second pixel in each direction
(the *coarse grid*, plus the last row and column), and looks at each cell between four
coarse samples: when all four saw the same object (label, body, material, or all open
water) and lie on the tangent plane of the first (within ``PLANARITY_TOL`` of its
range: a flat surface passes exactly, a curved one when it bends little over the cell,
a step between two parallel faces does not), the pixels inside are interpolated
bilinearly (1/z for the depth image — exact on a plane, whose 1/z is affine in the pixel
coordinates — the radiance components for the picture, the corner's label); otherwise
every pixel of the cell gets its own ray. On the pier scene about 30–40 % of the rays
of a full image are cast.

What it can miss: an object thinner than two pixels that falls entirely between coarse
samples of one surface, and steps smaller than ``PLANARITY_TOL`` of the range.
``sampling="full"`` casts one ray per pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.compiled import jit

#: how far (relative to the range) a cell's corner may lie off the first corner's plane
PLANARITY_TOL = 0.005


def _axis(n: int) -> NDArray[np.int64]:
    """Coarse sample positions along an axis of n pixels: every second one and the last."""
    pos = np.arange(0, n, 2)
    return pos if pos[-1] == n - 1 else np.append(pos, n - 1)


def _cells_of(pos: NDArray[np.int64], n: int) -> tuple[NDArray[np.intp], NDArray[np.intp],
                                                          NDArray[np.float32]]:
    """For every pixel along an axis: the cells (intervals between coarse samples) that
    contain it (two for a pixel on a cell boundary, else the same one twice) and its
    fractional coarse coordinate."""
    u = np.arange(n)
    last = len(pos) - 2
    a = np.clip(np.searchsorted(pos, u, side="right") - 1, 0, last)
    b = np.clip(np.searchsorted(pos, u, side="left") - 1, 0, last)
    coord = a + (u - pos[a]) / (pos[a + 1] - pos[a])
    return a, b, coord.astype(np.float32)


@dataclass(frozen=True)
class AdaptiveGrid:
    """The coarse grid of an image of ``height`` × ``width`` pixels and its cell maps."""

    height: int
    width: int
    rows: NDArray[np.int64]  # coarse rows
    cols: NDArray[np.int64]  # coarse columns
    coarse: NDArray[np.intp]  # flat pixel indices of the coarse samples, row-major
    is_coarse: NDArray[np.bool_]  # (H·W,)
    cells_y: tuple[NDArray[np.intp], NDArray[np.intp]]
    cells_x: tuple[NDArray[np.intp], NDArray[np.intp]]
    map_x: NDArray[np.float32]  # (H, W) coarse coordinates for cv2.remap
    map_y: NDArray[np.float32]

    @staticmethod
    def of(height: int, width: int) -> AdaptiveGrid | None:
        """The grid, or None for an image too small to have cells (1 pixel wide or high)."""
        if height < 2 or width < 2:
            return None
        rows, cols = _axis(height), _axis(width)
        ya, yb, y = _cells_of(rows, height)
        xa, xb, x = _cells_of(cols, width)
        coarse = (rows[:, None] * width + cols[None, :]).reshape(-1)
        is_coarse = np.zeros(height * width, bool)
        is_coarse[coarse] = True
        map_x = np.ascontiguousarray(np.broadcast_to(x[None, :], (height, width)))
        map_y = np.ascontiguousarray(np.broadcast_to(y[:, None], (height, width)))
        return AdaptiveGrid(height, width, rows, cols, coarse, is_coarse, (ya, yb), (xa, xb),
                            map_x, map_y)

    @property
    def coarse_shape(self) -> tuple[int, int]:
        return len(self.rows), len(self.cols)

    def smooth_cells(self, points: NDArray, normals: NDArray, range_m: NDArray,
                     same: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """(Hc − 1, Wc − 1) cells whose interior can be interpolated: the four corners
        saw the same object (``same``, from :func:`same_object`) and lie on the tangent
        plane of the first one, within ``PLANARITY_TOL`` of its range. ``points``,
        ``normals``: (Hc, Wc, 3) hit points (relative to the camera) and unit normals in
        one frame, zero for open water; ``range_m`` (Hc, Wc), 0 for open water."""
        p00, n00 = points[:-1, :-1], normals[:-1, :-1]
        limit = PLANARITY_TOL * range_m[:-1, :-1]
        smooth = same.copy()
        for corner in (points[:-1, 1:], points[1:, :-1], points[1:, 1:]):
            off_plane = np.abs(np.einsum("ijk,ijk->ij", n00, corner - p00))
            smooth &= off_plane <= limit
        return smooth

    def exact_pixels(self, smooth: NDArray[np.bool_]) -> NDArray[np.intp]:
        """Flat indices of the pixels that need their own ray: not coarse samples, and in
        (or on the edge of) a cell that is not smooth."""
        rough = ~smooth
        ya, yb = self.cells_y
        xa, xb = self.cells_x
        rows = rough[ya] | rough[yb]  # (H, Wc − 1): a rough cell above or below
        need = rows[:, xa] | rows[:, xb]
        return np.flatnonzero(need.reshape(-1) & ~self.is_coarse)

    def upsample(self, coarse_values: NDArray[np.float32]) -> NDArray[np.float32]:
        """Bilinear interpolation of (Hc, Wc[, C]) coarse values to (H, W[, C])."""
        return cv2.remap(coarse_values, self.map_x, self.map_y, cv2.INTER_LINEAR)

    def nearest_corner(self, coarse_values: NDArray) -> NDArray:
        """(H, W) the value of each pixel's top-left cell corner (for labels)."""
        return coarse_values[np.ix_(self.cells_y[0], self.cells_x[0])]

    def fill(self, light: NDArray[np.float32], fs: NDArray[np.float32],
             inverse_depth: NDArray[np.float32], labels: NDArray[np.int16],
             cos_axis: NDArray[np.float32], compiled: bool
             ) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32],
                        NDArray[np.int16]]:
        """Every pixel from the coarse samples ((Hc, Wc, 3) ``light`` and forward-scatter
        source ``fs``, (Hc, Wc) 1/depth and labels): the first two and 1/depth
        upsampled (:meth:`upsample`), the range 1/(1/depth · ``cos_axis``) ((H·W,), the
        pixels' cos to the optical axis), the labels :meth:`nearest_corner`'s; flat
        ((H·W, 3) and (H·W,)). ``compiled``: light, forward scatter, range and labels in
        one compiled pass (numba) with cv2.remap's weights; cv2 sums them in another order (SIMD
        lanes and a scalar tail), so the light differs from its by a float32 unit in the
        last place here and there; 1/depth is still cv2's (the range stays the same to the
        bit)."""
        kernel = _compiled_fill() if compiled else None
        if kernel is None:
            up_light = self.upsample(light).reshape(-1, 3)
            up_fs = self.upsample(fs).reshape(-1, 3)
            with np.errstate(divide="ignore"):  # open water: 1/0 = inf
                range_m = 1.0 / (self.upsample(inverse_depth).reshape(-1) * cos_axis)
            return up_light, up_fs, range_m, self.nearest_corner(labels).reshape(-1)
        (ya, _), (xa, _) = self.cells_y, self.cells_x
        n = self.height * self.width
        out = (np.empty((n, 3), np.float32), np.empty((n, 3), np.float32),
               np.empty(n, np.float32), np.empty(n, np.int16))
        kernel(ya, self.map_y[:, 0] - ya.astype(np.float32), xa,
               self.map_x[0] - xa.astype(np.float32), light, fs,
               self.upsample(inverse_depth).reshape(-1), labels, cos_axis, *out)
        return out


def smooth_of(label: NDArray, body: NDArray, material: NDArray,
              sharp: NDArray[np.bool_] | None, grid: AdaptiveGrid, points: NDArray,
              normals: NDArray, range_m: NDArray, compiled: bool) -> NDArray[np.bool_]:
    """(Hc − 1, Wc − 1) cells whose interior can be interpolated: :func:`same_object`,
    no corner on a sharp picture (``sharp`` (Hc, Wc), None: no pictures), and
    :meth:`AdaptiveGrid.smooth_cells` (its arguments). ``compiled``: in one compiled pass
    (numba; the same comparisons and float64 sums in numpy's order: the same cells)."""
    kernel = _compiled_smooth() if compiled else None
    if kernel is None:
        same = same_object(label, body, material)
        if sharp is not None:
            same &= ~(sharp[:-1, :-1] | sharp[:-1, 1:] | sharp[1:, :-1] | sharp[1:, 1:])
        return grid.smooth_cells(points, normals, range_m, same)
    smooth = np.empty((label.shape[0] - 1, label.shape[1] - 1), bool)
    kernel(label, body, material, np.zeros((0, 0), bool) if sharp is None else sharp,
           points, normals, range_m, np.float32(PLANARITY_TOL), smooth)
    return smooth


def _smooth_loops(label, body, material, sharp, points, normals, range_m, tol, smooth):  # type: ignore[no-untyped-def]
    """:func:`smooth_of`'s tests per cell, compiled."""
    for i in range(smooth.shape[0]):
        for j in range(smooth.shape[1]):
            ok = True
            for a, b in ((i, j + 1), (i + 1, j), (i + 1, j + 1)):
                ok = ok and label[a, b] == label[i, j] and body[a, b] == body[i, j] \
                    and material[a, b] == material[i, j]
                if sharp.shape[0]:
                    ok = ok and not sharp[a, b]
            if sharp.shape[0]:
                ok = ok and not sharp[i, j]
            limit = float(tol * range_m[i, j])
            for a, b in ((i, j + 1), (i + 1, j), (i + 1, j + 1)):
                off = abs(normals[i, j, 0] * (points[a, b, 0] - points[i, j, 0])
                          + normals[i, j, 1] * (points[a, b, 1] - points[i, j, 1])
                          + normals[i, j, 2] * (points[a, b, 2] - points[i, j, 2]))
                ok = ok and off <= limit
            smooth[i, j] = ok


@cache
def _compiled_smooth():  # type: ignore[no-untyped-def]
    return jit(_smooth_loops)


def _fill_loops(ya, fy, xa, fx, light_c, fs_c, inverse_depth, label_c, cos_axis,  # type: ignore[no-untyped-def]
                light, fs, range_m, labels):
    """:meth:`AdaptiveGrid.fill` per pixel, compiled: the top-left cell corner (``ya``,
    ``xa``) and the fractions (``fy``, ``fx``) along each axis; ``inverse_depth``
    already upsampled ((H·W,))."""
    one = np.float32(1.0)
    width = xa.shape[0]
    for y in range(ya.shape[0]):
        a, ty = ya[y], fy[y]
        for x in range(width):
            b, tx = xa[x], fx[x]
            w00, w01 = (one - ty) * (one - tx), (one - ty) * tx
            w10, w11 = ty * (one - tx), ty * tx
            p = y * width + x
            for k in range(3):
                light[p, k] = (light_c[a, b, k] * w00 + light_c[a, b + 1, k] * w01
                               + light_c[a + 1, b, k] * w10 + light_c[a + 1, b + 1, k] * w11)
                fs[p, k] = (fs_c[a, b, k] * w00 + fs_c[a, b + 1, k] * w01
                            + fs_c[a + 1, b, k] * w10 + fs_c[a + 1, b + 1, k] * w11)
            range_m[p] = one / (inverse_depth[p] * cos_axis[p])
            labels[p] = label_c[a, b]


@cache
def _compiled_fill():  # type: ignore[no-untyped-def]
    return jit(_fill_loops, numpy_errors=True)


def same_object(label: NDArray, body: NDArray, material: NDArray) -> NDArray[np.bool_]:
    """(Hc − 1, Wc − 1) whether the four corners of each cell saw the same thing; the
    arguments are (Hc, Wc) per coarse sample."""
    same = np.ones((label.shape[0] - 1, label.shape[1] - 1), bool)
    for a in (label, body, material):
        corner = a[:-1, :-1]
        same &= (a[:-1, 1:] == corner) & (a[1:, :-1] == corner) & (a[1:, 1:] == corner)
    return same
