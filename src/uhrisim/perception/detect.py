"""Detection on the polar sonar image: an adaptive (CFAR) threshold and an
ego-motion-compensated background.

Everything here works on the native polar matrix of a ping (rows = range bins, columns =
beams; ``SonarPing.polar``, display level 0…1, log-compressed). Because that level is
logarithmic, the detector is a *log-CFAR*: speckle (Rayleigh amplitude, exponential
intensity) has a level spread that does not depend on the mean, so a threshold of

    level > μ + max(k·σ, min_contrast)      and      level ≥ min_level

with μ, σ the background level and spread around each cell keeps the false-alarm rate
constant whatever the local gain, TVG or reverberation. μ and σ come from block means
(cell averaging) combined by a median and a minimum over neighbouring blocks — an order-
statistic CFAR on sub-blocks (Rohling 1983; Gandhi & Kassam 1988), so a diver that
covers a hundred beams at 2 m does not raise its own threshold as a small guard window
would let it. The image is first averaged over a small window (non-coherent integration
against speckle grain, which spans several beams because each beam is ~1° wide over
~0.18° spacing, ``docs/reference/sonar.md``). On a clean image (no noise floor: σ = 0)
the ``min_contrast``/``min_level`` terms do the work, so the detector works on both.

Ego-motion compensation (:class:`BackgroundModel`): a running mean of the image kept in
the world, not in the sonar: before each update the previous background is resampled
into the new sonar pose (the sonar's horizontal plane: range, bearing → local north/east
→ the previous pose's range, bearing), so a static piling stays on its background cell
while the ROV turns and moves; a moving diver or bubbles do not. It is kept on the
detector's blocks; the difference ``level − background`` is each detection's *motion
contrast* (a classifier feature).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DetectorParams:
    """Settings of the adaptive-threshold (CFAR) detector; cells are range bins × beams.

    Attributes:
        smooth_bins, smooth_beams: pre-averaging window (odd, 1 = none).
        block_bins, block_beams: size of the blocks whose mean levels sample the
            background.
        window_blocks: the background of a block is the median of the block means in a
            ``window_blocks`` × ``window_blocks`` neighbourhood (3 or 5), then the least of
            those over its 3×3 neighbours (a target covering a few blocks does not raise
            its own threshold).
        k_sigma: threshold in background standard deviations above the background.
        min_contrast: least level above the background (display units, 0…1).
        min_level: least absolute level of a detected cell (display units).
        min_range_m: cells nearer than this are ignored (near-field ringing), m.
        edge_beams: beams at each side of the fan that are ignored.
    """

    smooth_bins: int = 3
    smooth_beams: int = 3
    block_bins: int = 16
    block_beams: int = 16
    window_blocks: int = 5
    k_sigma: float = 4.0
    min_contrast: float = 0.12
    min_level: float = 0.25
    min_range_m: float = 0.8
    edge_beams: int = 2

    def __post_init__(self) -> None:
        for name in ("smooth_bins", "smooth_beams"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1 or v % 2 == 0:
                raise ConfigError(f"must be an odd integer >= 1, got {v!r}",
                                  f"DetectorParams.{name}")
        for name in ("block_bins", "block_beams"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise ConfigError(f"must be an integer >= 1, got {v!r}",
                                  f"DetectorParams.{name}")
        if self.window_blocks not in (3, 5):
            raise ConfigError(f"must be 3 or 5, got {self.window_blocks!r}",
                              "DetectorParams.window_blocks")
        if not isinstance(self.edge_beams, int) or self.edge_beams < 0:
            raise ConfigError(f"must be an integer >= 0, got {self.edge_beams!r}",
                              "DetectorParams.edge_beams")
        for name in ("k_sigma", "min_contrast", "min_level", "min_range_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"must be a finite number >= 0, got {v!r}",
                                  f"DetectorParams.{name}")


def clean_level(polar: NDArray, where: str = "ping.polar") -> tuple[NDArray[np.float32], int]:
    """``polar`` as float32 with non-finite cells set to 0 (no echo), and how many there
    were (a damaged ping is used, not refused; the caller logs it)."""
    img = np.asarray(polar, dtype=np.float32)
    bad = ~np.isfinite(img)
    n_bad = int(np.count_nonzero(bad))
    if n_bad:
        img = np.where(bad, np.float32(0.0), img)
        log.debug("%s: %d non-finite cells set to 0", where, n_bad)
    return img, n_bad


def block_grid(shape: tuple[int, int], params: DetectorParams) -> tuple[int, int]:
    """(rows, columns) of the block grid over an image of ``shape``."""
    return max(1, round(shape[0] / params.block_bins)), max(1, round(shape[1] / params.block_beams))


def background_threshold(x: NDArray[np.float32], params: DetectorParams
                         ) -> tuple[NDArray[np.float32], NDArray[np.float32],
                                    NDArray[np.float32]]:
    """(threshold of every cell of ``x``, block means of ``x``, background level μ per
    block) (module docstring): block means of x and x² → median over the block window →
    least of 3×3 neighbours → threshold ``max(μ + max(k·σ, min_contrast), min_level)``
    per block → interpolated to cells."""
    p = params
    h, w = x.shape
    gh, gw = block_grid(x.shape, p)
    means = cv2.resize(x, (gw, gh), interpolation=cv2.INTER_AREA)
    m2 = cv2.resize(x * x, (gw, gh), interpolation=cv2.INTER_AREA)
    m1, var = means, np.maximum(m2 - means * means, 0.0)
    if min(gh, gw) >= p.window_blocks:
        m1 = cv2.medianBlur(m1, p.window_blocks)
        var = cv2.medianBlur(var, p.window_blocks)
    kernel = np.ones((3, 3), np.uint8)
    m1, var = cv2.erode(m1, kernel), cv2.erode(var, kernel)
    margin = np.maximum(np.sqrt(var) * np.float32(p.k_sigma), np.float32(p.min_contrast))
    threshold = np.maximum(m1 + margin, np.float32(p.min_level))
    return cv2.resize(threshold, (w, h), interpolation=cv2.INTER_LINEAR), means, m1


def cfar_mask(level: NDArray[np.float32], bin_ranges_m: NDArray[np.float64],
              params: DetectorParams
              ) -> tuple[NDArray[np.uint8], NDArray[np.float32], NDArray[np.float32],
                         NDArray[np.float32]]:
    """(mask, smoothed level, block means, background level per block): mask is 255
    where a cell is detected, else 0 (uint8, the shape of ``level``); the block means
    (grid :func:`block_grid`) feed the background model, the background level gives each
    blob its level above the background. See the module docstring for the test."""
    p = params
    x = level
    if p.smooth_bins > 1 or p.smooth_beams > 1:
        x = cv2.blur(level, (p.smooth_beams, p.smooth_bins), borderType=cv2.BORDER_REFLECT)
    threshold, means, background = background_threshold(x, p)
    mask = cv2.compare(x, threshold, cv2.CMP_GT)
    near = int(np.searchsorted(bin_ranges_m, p.min_range_m))
    mask[:near] = 0
    if p.edge_beams:
        mask[:, : p.edge_beams] = 0
        mask[:, -p.edge_beams:] = 0
    return mask, x, means, background


def horizontal_pose(position_ned: NDArray, rotation_ned_from_sonar: NDArray
                    ) -> tuple[float, float, float]:
    """(north, east, yaw) of the sonar's horizontal plane: position (m) and the compass
    direction of its axis projected onto the horizontal (rad)."""
    r = np.asarray(rotation_ned_from_sonar, dtype=float)
    return float(position_ned[0]), float(position_ned[1]), math.atan2(r[1, 0], r[0, 0])


class BackgroundModel:
    """A world-stabilised running mean of the polar level (module docstring), kept on a
    ``grid`` of blocks (rows, columns) over the (bins, beams) image — the detector's
    blocks: the motion contrast is a per-blob feature and needs no finer grid.

    ``alpha`` is the update weight per ping (time constant ≈ 1/(alpha·ping rate)).
    """

    def __init__(self, bin_ranges_m: NDArray, beam_angles_rad: NDArray,
                 grid: tuple[int, int], alpha: float = 0.05) -> None:
        if not 0.0 < alpha <= 1.0:
            raise ConfigError(f"must be in (0, 1], got {alpha!r}", "BackgroundModel.alpha")
        self.alpha = float(alpha)
        r = np.asarray(bin_ranges_m, dtype=np.float64)
        th = np.asarray(beam_angles_rad, dtype=np.float64)
        self.shape = (r.size, th.size)
        self.grid = grid
        dr = float(r[1] - r[0]) if r.size > 1 else 1.0
        dth = float(th[1] - th[0]) if th.size > 1 else 1.0
        # Block i covers cells [i·s, (i+1)·s) (s = cells per block, as INTER_AREA averages
        # them): its centre is cell (i + 0.5)·s − 0.5; bins and beams are evenly spaced.
        self._s_r, self._s_t = r.size / self.grid[0], th.size / self.grid[1]
        rows = (np.arange(self.grid[0]) + 0.5) * self._s_r - 0.5
        cols = (np.arange(self.grid[1]) + 0.5) * self._s_t - 0.5
        rr, tt = np.meshgrid(r[0] + dr * rows, th[0] + dth * cols, indexing="ij")
        self._x, self._y = rr * np.cos(tt), rr * np.sin(tt)  # sonar plane, block centres
        self._r0, self._dr, self._t0, self._dt = float(r[0]), dr, float(th[0]), dth
        self.background: NDArray[np.float32] | None = None
        self._pose: tuple[float, float, float] | None = None

    def _maps(self, pose: tuple[float, float, float]) -> tuple[NDArray, NDArray]:
        """Fractional (column, row) block indices in the previous ping of every block."""
        assert self._pose is not None
        n1, e1, y1 = pose
        n0, e0, y0 = self._pose
        c1, s1 = math.cos(y1), math.sin(y1)
        dn = n1 - n0 + c1 * self._x - s1 * self._y
        de = e1 - e0 + s1 * self._x + c1 * self._y
        c0, s0 = math.cos(y0), math.sin(y0)
        xp, yp = c0 * dn + s0 * de, -s0 * dn + c0 * de
        cell_r = (np.hypot(xp, yp) - self._r0) / self._dr
        cell_t = (np.arctan2(yp, xp) - self._t0) / self._dt
        return (((cell_t + 0.5) / self._s_t - 0.5).astype(np.float32),
                ((cell_r + 0.5) / self._s_r - 0.5).astype(np.float32))

    def update(self, blocks: NDArray[np.float32], pose: tuple[float, float, float]
               ) -> NDArray[np.float32]:
        """Warp the background into ``pose`` (north m, east m, yaw rad), return the
        motion contrast ``blocks − background`` per block (0 on the first ping), then
        blend ``blocks`` (the block means of this ping's level) in. Blocks the previous
        ping did not see take the current level."""
        if self.background is None or self._pose is None:
            self.background, self._pose = blocks.copy(), pose
            return np.zeros_like(blocks)
        map_col, map_row = self._maps(pose)
        warped = cv2.remap(self.background, map_col, map_row, cv2.INTER_LINEAR,
                           borderMode=cv2.BORDER_CONSTANT, borderValue=-1.0)
        unseen = warped < 0.0
        warped[unseen] = blocks[unseen]
        contrast = blocks - warped
        cv2.addWeighted(warped, 1.0 - self.alpha, blocks, self.alpha, 0.0, dst=warped)
        self.background, self._pose = warped, pose
        return contrast
