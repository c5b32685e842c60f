"""Blobs: connected detected cells, grouped into objects, with their range, bearing,
extent and intensity.

Connected components (8-connectivity) of the CFAR mask are the *parts*; parts whose
intensity-weighted centres lie within ``merge_radius_m`` of each other (single linkage, in
the sonar's horizontal plane) are one *blob* — a diver is "a cluster of a few bright
blobs about 1 m across (tank, head, fins)" (``docs/reference/sonar.md``). Positions
are in the sonar plane (x forward, y starboard, m: an imaging sonar measures no
elevation, so z = 0) and in local NED (north, east, m) through the ping's pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError


@dataclass(frozen=True)
class BlobParams:
    """Settings of blob extraction.

    Attributes:
        min_cells: parts with fewer detected cells are dropped (speckle false alarms).
        merge_radius_m: parts whose centres are closer than this are one blob, m.
        max_parts: at most this many parts (the heaviest) are grouped per ping.
        max_blobs: at most this many blobs (the heaviest) are returned per ping.
        dynamic_range_db: the display's dynamic range: centres are weighted by intensity,
            ``10^((level − 1)·dynamic_range_db/10)``, not by the log level, so side lobes
            and speckle around a strong echo do not pull its centre.
    """

    min_cells: int = 12
    merge_radius_m: float = 1.5
    max_parts: int = 64
    max_blobs: int = 24
    dynamic_range_db: float = 50.0

    def __post_init__(self) -> None:
        for name in ("min_cells", "max_parts", "max_blobs"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise ConfigError(f"must be an integer >= 1, got {v!r}", f"BlobParams.{name}")
        if not (math.isfinite(self.dynamic_range_db) and self.dynamic_range_db > 0):
            raise ConfigError(f"must be a finite number > 0, got {self.dynamic_range_db!r}",
                              "BlobParams.dynamic_range_db")
        if not (math.isfinite(self.merge_radius_m) and self.merge_radius_m >= 0):
            raise ConfigError(f"must be a finite number >= 0, got {self.merge_radius_m!r}",
                              "BlobParams.merge_radius_m")


@dataclass(frozen=True)
class Blob:
    """One detected object in one ping.

    Attributes:
        range_m, bearing_rad: intensity-weighted centre (bearing > 0 starboard).
        x_m, y_m: the same centre in the sonar plane (forward, starboard), m.
        north_m, east_m: the centre in local NED through the ping's pose, m.
        range_extent_m, cross_extent_m: extent along range and across (r·Δθ), m.
        cells: detected cells; parts: connected parts merged into it.
        peak_level: largest smoothed display level (0…1).
        excess_level: mean level above the local background (display units: a gain or
            noise-floor change shifts levels, not this).
        contrast: mean motion contrast (level − ego-compensated background).
        touches_edge: whether it reaches the first or last usable beam.
    """

    range_m: float
    bearing_rad: float
    x_m: float
    y_m: float
    north_m: float
    east_m: float
    range_extent_m: float
    cross_extent_m: float
    cells: int
    parts: int
    peak_level: float
    excess_level: float
    contrast: float
    touches_edge: bool


@dataclass(frozen=True)
class BlobImage:
    """The blobs of a ping and the image that says which cells make each one.

    ``components``: (n_bins, n_beams) int32 connected-component ids (0 = not detected);
    ``blob_of_component``: component id → index into ``blobs`` (−1: dropped).
    """

    blobs: tuple[Blob, ...]
    components: NDArray[np.int32]
    blob_of_component: NDArray[np.int64]

    def blob_cells(self, index: int) -> NDArray[np.bool_]:
        """Mask (n_bins, n_beams) of the cells of blob ``index``."""
        return (self.blob_of_component[self.components] == index) & (self.components > 0)


def _groups(x: NDArray, y: NDArray, radius: float) -> NDArray[np.int64]:
    """Single-linkage groups of points closer than ``radius``: a group id per point."""
    n = x.size
    parent = np.arange(n)

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = int(parent[i])
        return i

    if n > 1 and radius > 0:
        close = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :]) < radius
        for i, j in zip(*np.nonzero(np.triu(close, 1)), strict=True):
            ri, rj = root(int(i)), root(int(j))
            if ri != rj:
                parent[max(ri, rj)] = min(ri, rj)
    roots = np.array([root(i) for i in range(n)], dtype=np.int64)
    return np.unique(roots, return_inverse=True)[1]


def _on_blocks(blocks: NDArray, rows: NDArray, cols: NDArray, shape: tuple[int, ...]
               ) -> NDArray:
    """Values of a block grid ``blocks`` at cells (rows, cols) of an image of ``shape``."""
    gh, gw = blocks.shape
    return blocks[rows * gh // shape[0], cols * gw // shape[1]]


def extract_blobs(mask: NDArray[np.uint8], level: NDArray[np.float32],
                  contrast: NDArray[np.float32], background: NDArray[np.float32],
                  bin_ranges_m: NDArray, beam_angles_rad: NDArray, position_ned: NDArray,
                  rotation_ned_from_sonar: NDArray, edge_beams: int,
                  params: BlobParams) -> BlobImage:
    """Blobs of a CFAR ``mask`` (uint8, 255 = detected) weighted by ``level``;
    ``contrast`` (the motion contrast) and ``background`` (the local background level)
    are on grids of blocks over the image (any size: a cell takes its block's value)."""
    comp = np.zeros(mask.shape, np.int32)
    none = BlobImage((), comp, np.full(1, -1, np.int64))
    # Label only the rows that hold detections (labelling costs per cell of the image).
    _, top, _, height = cv2.boundingRect(mask)
    if height == 0:
        return none
    bottom = top + height
    n_comp, comp[top:bottom], stats, _ = cv2.connectedComponentsWithStats(
        mask[top:bottom], connectivity=8, ltype=cv2.CV_32S)
    stats[:, cv2.CC_STAT_TOP] += top
    none = BlobImage((), comp, np.full(max(n_comp, 1), -1, np.int64))
    if n_comp <= 1:
        return none
    area = stats[:, cv2.CC_STAT_AREA]
    keep = np.flatnonzero(area[1:] >= params.min_cells) + 1
    if keep.size == 0:
        return none
    n_beams = mask.shape[1]
    pix = np.flatnonzero(comp[top:bottom]) + top * n_beams
    ids = comp.ravel()[pix]
    rows, cols = np.divmod(pix, n_beams)
    r = np.asarray(bin_ranges_m, float)[rows]
    th = np.asarray(beam_angles_rad, float)[cols]
    lvl = level.ravel()[pix].astype(np.float64)
    w = np.exp((lvl - 1.0) * (params.dynamic_range_db * math.log(10.0) / 10.0))
    weight = np.bincount(ids, w, n_comp)
    level_sum = np.bincount(ids, lvl, n_comp)
    keep = keep[np.argsort(-weight[keep], kind="stable")][: params.max_parts]
    sum_x = np.bincount(ids, w * r * np.cos(th), n_comp)
    sum_y = np.bincount(ids, w * r * np.sin(th), n_comp)
    sum_c = np.bincount(ids, _on_blocks(contrast, rows, cols, mask.shape), n_comp)
    level_sum -= np.bincount(ids, _on_blocks(background, rows, cols, mask.shape), n_comp)
    peak = np.zeros(n_comp)
    np.maximum.at(peak, ids, lvl)
    cx, cy = sum_x[keep] / weight[keep], sum_y[keep] / weight[keep]
    group = _groups(cx, cy, params.merge_radius_m)
    n_groups = int(group.max()) + 1
    g_w = np.bincount(group, weight[keep], n_groups)
    order = np.argsort(-g_w, kind="stable")[: params.max_blobs]
    dr = float(bin_ranges_m[1] - bin_ranges_m[0]) if len(bin_ranges_m) > 1 else 0.0
    dth = float(beam_angles_rad[1] - beam_angles_rad[0]) if len(beam_angles_rad) > 1 else 0.0
    rot = np.asarray(rotation_ned_from_sonar, float)
    pos = np.asarray(position_ned, float)
    blob_of_component = np.full(n_comp, -1, np.int64)
    blobs = []
    for b, g in enumerate(order):
        members = keep[group == g]
        blob_of_component[members] = b
        wsum = weight[members].sum()
        x, y = sum_x[members].sum() / wsum, sum_y[members].sum() / wsum
        top = stats[members, cv2.CC_STAT_TOP]
        left = stats[members, cv2.CC_STAT_LEFT]
        bottom = top + stats[members, cv2.CC_STAT_HEIGHT]
        right = left + stats[members, cv2.CC_STAT_WIDTH]
        rng = math.hypot(x, y)
        cells = int(area[members].sum())
        ned = pos + rot @ np.array([x, y, 0.0])
        blobs.append(Blob(
            range_m=rng, bearing_rad=math.atan2(y, x), x_m=x, y_m=y,
            north_m=float(ned[0]), east_m=float(ned[1]),
            range_extent_m=float(bottom.max() - top.min()) * dr,
            cross_extent_m=float(right.max() - left.min()) * dth * rng,
            cells=cells, parts=int(members.size), peak_level=float(peak[members].max()),
            excess_level=float(level_sum[members].sum() / cells),
            contrast=float(sum_c[members].sum() / cells),
            touches_edge=bool(left.min() <= edge_beams or right.max() >= n_beams - edge_beams)))
    return BlobImage(tuple(blobs), comp, blob_of_component)
