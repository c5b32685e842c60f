"""Sea floors as depth grids, meshed in world NED metres.

A :class:`SeaFloor` is a regular grid of depths ``depth[i, j]`` (metres, positive down)
at ``north[i]``, ``east[j]``. Each grid cell is split into two triangles along its
(i, j)→(i+1, j+1) diagonal; :meth:`SeaFloor.depth_at` interpolates linearly on **the same
triangles**, so a ray hit and a depth query agree to rounding. Outside the grid
``depth_at`` returns NaN.

Constructors: :func:`flat`, :func:`sloped`, :func:`from_height_grid` (.npy / .csv files)
and :func:`procedural` (Gaussian-correlated random relief, deterministic from a seed).
``extent`` is either a half-width ``h`` (square from −h to +h in north and east) or
``(north_min, north_max, east_min, east_max)``, metres.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import AssetError, ConfigError, first_line
from uhrisim.core.rng import component_rng
from uhrisim.world.primitives import positive_length

Extent = float | tuple[float, float, float, float]


@dataclass(frozen=True)
class SeaFloor:
    """Depth grid (metres, positive down) over north × east coordinates (metres, increasing)."""

    north: NDArray[np.float64]
    east: NDArray[np.float64]
    depth: NDArray[np.float64]
    _mesh: trimesh.Trimesh | None = field(default=None, init=False, repr=False, compare=False)
    #: the grid as lists, for one point at a time (:meth:`_depth_at_point`)
    _lists: tuple[list, list, list] = field(init=False, repr=False, compare=False)
    #: a flat floor's depth (its one value + 0.0, as the interpolation gives it), else None
    _flat: float | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = np.array(self.north, dtype=float)
        e = np.array(self.east, dtype=float)
        z = np.array(self.depth, dtype=float)
        if n.ndim != 1 or e.ndim != 1 or len(n) < 2 or len(e) < 2:
            raise ConfigError("needs at least a 2 x 2 grid of depths", where="SeaFloor")
        if z.shape != (len(n), len(e)):
            raise ConfigError(
                f"depth grid shape {z.shape} != (len(north), len(east)) = {(len(n), len(e))}",
                where="SeaFloor.depth",
            )
        if not (np.all(np.diff(n) > 0) and np.all(np.diff(e) > 0)):
            raise ConfigError("north and east coordinates must increase", where="SeaFloor")
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(n)) and np.all(np.isfinite(e))):
            raise ConfigError("grid contains NaN or inf", where="SeaFloor.depth")
        for a in (n, e, z):
            a.setflags(write=False)
        object.__setattr__(self, "north", n)
        object.__setattr__(self, "east", e)
        object.__setattr__(self, "depth", z)
        object.__setattr__(self, "_lists", (n.tolist(), e.tolist(), z.tolist()))
        object.__setattr__(self, "_flat", float(z.flat[0]) + 0.0 if np.all(z == z.flat[0])
                           else None)

    @property
    def max_slope(self) -> float:
        """The steepest slope of the floor's triangles, |∇depth| (m/m): a point lies at
        most this times its horizontal distance higher than the floor under another."""
        dn, de = np.diff(self.north)[:, None], np.diff(self.east)[None, :]
        z = self.depth
        z00, z10, z11, z01 = z[:-1, :-1], z[1:, :-1], z[1:, 1:], z[:-1, 1:]
        lower = np.hypot((z10 - z00) / dn, (z11 - z10) / de)  # as in _interpolate
        upper = np.hypot((z11 - z01) / dn, (z01 - z00) / de)
        return float(max(lower.max(), upper.max()))

    @property
    def mesh(self) -> trimesh.Trimesh:
        """Triangle mesh of the floor in NED (cached; two triangles per grid cell)."""
        if self._mesh is None:
            ni, nj = self.depth.shape
            nn, ee = np.meshgrid(self.north, self.east, indexing="ij")
            verts = np.column_stack([nn.ravel(), ee.ravel(), self.depth.ravel()])
            i, j = np.meshgrid(np.arange(ni - 1), np.arange(nj - 1), indexing="ij")
            a = (i * nj + j).ravel()  # (i, j)
            b = a + nj  # (i+1, j)
            c = b + 1  # (i+1, j+1)
            d = a + 1  # (i, j+1)
            faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
            object.__setattr__(
                self, "_mesh", trimesh.Trimesh(verts, faces, process=False, validate=False)
            )
        assert self._mesh is not None
        return self._mesh

    @property
    def bounds(self) -> NDArray[np.float64]:
        """(2, 3) axis-aligned bounds in NED."""
        return np.array(
            [
                [self.north[0], self.east[0], self.depth.min()],
                [self.north[-1], self.east[-1], self.depth.max()],
            ]
        )

    def depth_at(self, x_north: ArrayLike, y_east: ArrayLike) -> NDArray[np.float64] | float:
        """Floor depth (m, positive down) at NED (north, east); NaN outside the grid.

        Vectorized over broadcastable inputs; linear on the mesh's own triangles. Two plain
        numbers take a scalar path (a sensor asks once per ping; numpy's per-call cost on
        0-d arrays would dominate).
        """
        if isinstance(x_north, float) and isinstance(y_east, float):  # (np.float64 too)
            return self._depth_at_point(float(x_north), float(y_east))
        n, e = self.north, self.east
        if np.ndim(x_north) == 0 and np.ndim(y_east) == 0:
            return self._depth_at_point(float(x_north), float(y_east))  # type: ignore[arg-type]
        x, y = np.broadcast_arrays(np.asarray(x_north, dtype=float), np.asarray(y_east, float))
        inside = (x >= n[0]) & (x <= n[-1]) & (y >= e[0]) & (y <= e[-1])
        i = np.clip(np.searchsorted(n, x, side="right") - 1, 0, len(n) - 2)
        j = np.clip(np.searchsorted(e, y, side="right") - 1, 0, len(e) - 2)
        out = np.where(inside, self._interpolate(i, j, x, y), np.nan)
        return float(out) if out.ndim == 0 else out

    def _depth_at_point(self, x: float, y: float) -> float:
        """:meth:`depth_at` of one point, in plain floats."""
        n, e, z = self._lists
        if not (n[0] <= x <= n[-1] and e[0] <= y <= e[-1]):
            return math.nan
        if self._flat is not None:  # what the interpolation below gives, bit for bit
            return self._flat
        i = min(max(bisect.bisect_right(n, x) - 1, 0), len(n) - 2)
        j = min(max(bisect.bisect_right(e, y) - 1, 0), len(e) - 2)
        s = (x - n[i]) / (n[i + 1] - n[i])  # along north, 0..1
        t = (y - e[j]) / (e[j + 1] - e[j])  # along east, 0..1
        z00, z10, z11, z01 = z[i][j], z[i + 1][j], z[i + 1][j + 1], z[i][j + 1]
        if s >= t:  # the cell's triangles as in _interpolate
            return z00 + s * (z10 - z00) + t * (z11 - z10)
        return z00 + t * (z01 - z00) + s * (z11 - z01)

    def _interpolate(self, i: Any, j: Any, x: Any, y: Any) -> Any:
        """Depth at (x, y) inside grid cell (i, j) (arrays or numbers), on the cell's two
        mesh triangles (i,j),(i+1,j),(i+1,j+1) and (i,j),(i+1,j+1),(i,j+1)."""
        n, e, z = self.north, self.east, self.depth
        s = (x - n[i]) / (n[i + 1] - n[i])  # along north, 0..1
        t = (y - e[j]) / (e[j + 1] - e[j])  # along east, 0..1
        z00, z10, z11, z01 = z[i, j], z[i + 1, j], z[i + 1, j + 1], z[i, j + 1]
        lower = z00 + s * (z10 - z00) + t * (z11 - z10)
        upper = z00 + t * (z01 - z00) + s * (z11 - z01)
        return np.where(s >= t, lower, upper)


def _extent(extent: Extent) -> tuple[float, float, float, float]:
    if np.ndim(extent) == 0:
        h = float(extent)  # type: ignore[arg-type]
        box = (-h, h, -h, h)
    else:
        vals = tuple(float(v) for v in extent)  # type: ignore[union-attr]
        if len(vals) != 4:
            raise ConfigError(
                "must be a half-width or (north_min, north_max, east_min, east_max), "
                f"got {extent!r}",
                where="seafloor.extent",
            )
        box = vals  # type: ignore[assignment]
    if not (np.all(np.isfinite(box)) and box[1] > box[0] and box[3] > box[2]):
        raise ConfigError(
            f"must describe a non-empty rectangle, got {extent!r}", where="seafloor.extent"
        )
    return box


def flat(depth: float, extent: Extent = 100.0) -> SeaFloor:
    """Horizontal floor at ``depth`` metres (two triangles)."""
    n0, n1, e0, e1 = _extent(extent)
    return SeaFloor(np.array([n0, n1]), np.array([e0, e1]), np.full((2, 2), float(depth)))


def sloped(
    depth_at_origin: float,
    slope: float,
    direction_deg: float = 0.0,
    extent: Extent = 100.0,
) -> SeaFloor:
    """Planar floor: depth = d0 + slope · (distance along compass ``direction_deg``).

    ``slope`` is dz/ds (metres of depth per metre horizontal, e.g. 0.05 = 5 %) and the floor
    gets deeper towards ``direction_deg`` (compass degrees: 0 north, 90 east).
    """
    n0, n1, e0, e1 = _extent(extent)
    h = np.radians(direction_deg)
    n, e = np.array([n0, n1]), np.array([e0, e1])
    nn, ee = np.meshgrid(n, e, indexing="ij")
    return SeaFloor(n, e, depth_at_origin + slope * (nn * np.cos(h) + ee * np.sin(h)))


def from_height_grid(
    path: str | Path,
    spacing: float | tuple[float, float],
    origin_ned: tuple[float, float] = (0.0, 0.0),
) -> SeaFloor:
    """Floor from a file of depths (metres, positive down): ``.npy`` or ``.csv``.

    Row ``i`` is north = ``origin_ned[0] + i * spacing_north``, column ``j`` is east =
    ``origin_ned[1] + j * spacing_east``. ``spacing`` is one value or (north, east) metres.

    Raises:
        AssetError: missing/unreadable file, wrong shape, NaN in the grid.
    """
    p = Path(path)
    if not p.is_file():
        raise AssetError(f"{p}: height grid file not found")
    try:
        if p.suffix.lower() == ".npy":
            grid = np.load(p, allow_pickle=False)
        elif p.suffix.lower() == ".csv":
            grid = np.loadtxt(p, delimiter=",", ndmin=2)
        else:
            raise AssetError(f"{p}: unsupported height grid format (use .npy or .csv)")
    except AssetError:
        raise
    except Exception as exc:
        raise AssetError(f"{p}: cannot read height grid ({first_line(exc)})") from None
    grid = np.asarray(grid)
    if grid.ndim != 2 or grid.shape[0] < 2 or grid.shape[1] < 2 or grid.dtype.kind not in "fiu":
        raise AssetError(f"{p}: height grid must be a 2-D numeric array of at least 2 x 2")
    grid = grid.astype(float)
    if not np.all(np.isfinite(grid)):
        raise AssetError(f"{p}: height grid contains NaN or inf")
    dn, de = (spacing, spacing) if np.ndim(spacing) == 0 else spacing  # type: ignore[misc]
    dn = positive_length(dn, "from_height_grid.spacing")
    de = positive_length(de, "from_height_grid.spacing")
    north = origin_ned[0] + dn * np.arange(grid.shape[0])
    east = origin_ned[1] + de * np.arange(grid.shape[1])
    return SeaFloor(north, east, grid)


#: Procedural floors cost ~1.3 kB of memory a grid cell (mesh, noise, FFT): 250 000 cells
#: (an extent of 250 m at 1 m) is ~330 MB.
MAX_PROCEDURAL_CELLS = 250_000


def procedural(
    seed: int,
    extent: Extent = 50.0,
    mean_depth: float = 8.0,
    roughness: float = 0.3,
    correlation_length: float = 5.0,
    resolution: float = 1.0,
) -> SeaFloor:
    """Random, smooth bathymetry; the same ``seed`` gives the same floor, bit for bit.

    White Gaussian noise (``component_rng(seed, "world/seafloor")``) is low-pass filtered
    with a Gaussian kernel of standard deviation ``correlation_length`` metres (in the
    Fourier domain, periodic), then scaled to standard deviation ``roughness`` metres about
    ``mean_depth``. Grid spacing is ``resolution`` metres.
    """
    n0, n1, e0, e1 = _extent(extent)
    res = positive_length(resolution, "procedural.resolution")
    rough = float(roughness)
    if not np.isfinite(rough) or rough < 0.0:
        raise ConfigError(f"must be >= 0, got {roughness!r}", where="procedural.roughness")
    corr = positive_length(correlation_length, "procedural.correlation_length")
    ni = int(np.ceil((n1 - n0) / res)) + 1
    nj = int(np.ceil((e1 - e0) / res)) + 1
    if ni * nj > MAX_PROCEDURAL_CELLS:
        raise ConfigError(
            f"a {n1 - n0:g} x {e1 - e0:g} m floor at {res:g} m is {ni * nj} cells, more than "
            f"{MAX_PROCEDURAL_CELLS} (~1.3 kB each): use a smaller extent or a coarser "
            "resolution", where="procedural.extent")
    north = np.linspace(n0, n1, ni)
    east = np.linspace(e0, e1, nj)
    rng = component_rng(int(seed), "world/seafloor")
    noise = rng.standard_normal((ni, nj))
    kn = np.fft.fftfreq(ni, d=(n1 - n0) / max(ni - 1, 1))
    ke = np.fft.rfftfreq(nj, d=(e1 - e0) / max(nj - 1, 1))
    k2 = kn[:, None] ** 2 + ke[None, :] ** 2
    kernel = np.exp(-2.0 * np.pi**2 * corr**2 * k2)  # FT of a Gaussian of std corr
    field_ = np.fft.irfft2(np.fft.rfft2(noise) * kernel, s=(ni, nj))
    field_ -= field_.mean()
    std = field_.std()
    relief = field_ * (rough / std) if std > 0.0 else field_ * 0.0
    return SeaFloor(north, east, float(mean_depth) + relief)
