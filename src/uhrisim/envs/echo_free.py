"""The sonar vector env's echo-free images, formed in one compiled pass.

Most of the vector env's pings see nothing inside their window (the diver out of the fan
or out of range): their polar image
(:meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar.polar_bytes`) is the diffuse level of
each range row (noise, volume and surface reverberation) plus the ping's window of the
product speckle field, through the display curve. OpenCV forms it in seven passes over
the image (add, clip, floor, log, scale, exp, bytes); here one compiled loop adds,
clips and maps each level to its byte by the display curve's thresholds
(:class:`DisplayThresholds`), the same bytes. The Generator draws what it draws in
:meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar._physical_polar` (the speckle window's
offset), so the next pings are unchanged too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.compiled import jit
from uhrisim.sensors.sonar.geometry import surface_rows
from uhrisim.sensors.sonar.polar import diffuse_rows, display_bytes
from uhrisim.sensors.sonar.sonar import ImagingSonar

#: Cells of :class:`DisplayThresholds`' table over the display level 0…1 (a power of
#: two: x·CELLS is exact, so a level's cell is exactly the one that holds it).
CELLS = 1 << 16
#: Float32 steps (ulps) either side of each threshold where :meth:`DisplayThresholds.make`
#: checks its bytes against OpenCV's chain.
_CHECK_ULPS = 256
#: Levels evaluated per OpenCV call: a multiple of any SIMD width, so every element
#: takes the vectorised path an image's cells take.
_CHUNK = 1 << 12


def _chain_bytes(levels: NDArray[np.float32], gamma: float, black: int) -> NDArray[np.uint8]:
    """:func:`~uhrisim.sensors.sonar.polar.display_bytes` (``clipped=False``) of float32
    ``levels``, evaluated in padded chunks (so every level takes OpenCV's SIMD path)."""
    n = levels.size
    padded = np.zeros(-(-n // _CHUNK) * _CHUNK, np.float32)
    padded[:n] = levels
    out = np.concatenate([display_bytes(chunk.copy(), gamma, black, clipped=False)
                          for chunk in padded.reshape(-1, _CHUNK)])
    return out[:n]


@dataclass(frozen=True)
class DisplayThresholds:
    """The display curve of :func:`~uhrisim.sensors.sonar.polar.display_bytes` (OpenCV's
    float32 chain, ``clipped=False``) as thresholds on the display level x: the byte of
    x is ``base`` plus the number of thresholds ≤ min(x, 1) (x ≤ 0: ``base``), as the
    curve is non-decreasing in x. Tabled over :data:`CELLS` equal cells of 0…1 (cell i
    holds [i, i + 1)/CELLS; the last, 1 alone), each with that count at its start
    (``counts``) and the next threshold (``next``; +inf: none), at most one threshold
    inside a cell: the byte of x in cell i is ``base + counts[i] + (x >= next[i])``.
    Exact where the curve is non-decreasing: :meth:`make` checks it against the chain
    around every threshold."""

    base: int
    thresholds: NDArray[np.float32]  # increasing
    counts: NDArray[np.uint8]  # (CELLS + 1,)
    next: NDArray[np.float32]  # (CELLS + 1,)

    @staticmethod
    def make(gamma: float, black: int) -> DisplayThresholds | None:
        """The thresholds of the curve (γ ``gamma``, black level ``black``): for each
        byte above ``base`` the least float32 level in (0, 1] that reaches it (bisection
        over the float32 bit patterns); None where a cell holds two thresholds or the
        chain is not non-decreasing within :data:`_CHECK_ULPS` of a threshold (the images
        then formed by OpenCV)."""
        one = int(np.float32(1.0).view(np.int32))
        base = int(_chain_bytes(np.zeros(1, np.float32), gamma, black)[0])
        top = int(_chain_bytes(np.ones(1, np.float32), gamma, black)[0])
        wanted = np.arange(base + 1, top + 1)
        lo = np.zeros(wanted.size, np.int64)  # bits whose byte is below the wanted one
        hi = np.full(wanted.size, one, np.int64)  # bits whose byte reaches it
        while np.any(hi - lo > 1):
            mid = (lo + hi) // 2
            reached = _chain_bytes(mid.astype(np.int32).view(np.float32), gamma, black) >= wanted
            hi, lo = np.where(reached, mid, hi), np.where(reached, lo, mid)
        thresholds = hi.astype(np.int32).view(np.float32)
        starts = (np.arange(CELLS + 1) / CELLS).astype(np.float32)
        counts = np.searchsorted(thresholds, starts, side="right")
        ahead = np.append(thresholds, np.float32(np.inf))
        ends = np.append(starts[1:], np.float32(np.inf))
        if np.any(ahead[np.minimum(counts + 1, thresholds.size)] < ends) or top - base > 255:
            return None  # a cell with two thresholds
        table = DisplayThresholds(base, thresholds, counts.astype(np.uint8), ahead[counts])
        near = (hi[:, None] + np.arange(-_CHECK_ULPS, _CHECK_ULPS + 1)).ravel()
        near = near[(near > 0) & (near <= one)].astype(np.int32).view(np.float32)
        check = np.concatenate([near, starts, np.float32([0.0, -1.0, 2.0, 1e-30, 1e-45])])
        return table if np.array_equal(table.bytes_of(check),
                                       _chain_bytes(check, gamma, black)) else None

    def bytes_of(self, levels: NDArray[np.float32]) -> NDArray[np.uint8]:
        """The bytes of float32 display ``levels`` by the table (numpy; the compiled
        loop's rule)."""
        x = np.minimum(levels, np.float32(1.0))
        cell = np.maximum((x * np.float32(CELLS)).astype(np.int64), 0)
        return (self.base + self.counts[cell] + (x >= self.next[cell])).astype(np.uint8)


def _echo_free_bytes_loops(free, window, base, counts, next_threshold, out):  # type: ignore[no-untyped-def]
    """The bytes ``out`` (H, W) uint8 of the display level ``free[r] + window[r, c]``
    (float32, as OpenCV adds them) clipped at 1, by :class:`DisplayThresholds`' table."""
    cells = np.float32(counts.size - 1)
    for r in range(out.shape[0]):
        level_r = free[r]
        for c in range(out.shape[1]):
            x = min(level_r + window[r, c], np.float32(1.0))
            cell = max(np.int64(x * cells), 0)
            out[r, c] = base + counts[cell] + (x >= next_threshold[cell])


@cache
def _echo_free_bytes_compiled():  # type: ignore[no-untyped-def]
    """:func:`_echo_free_bytes_loops` compiled (numba), or None without numba."""
    return jit(_echo_free_bytes_loops)


def echo_free_supported(sonar: ImagingSonar) -> bool:
    """Whether :func:`echo_free_bytes` forms this sonar's echo-free images: with numba,
    physical mode without multipath, product speckle or none (the coherent model draws
    more)."""
    cfg = sonar.config
    bank = sonar._bank
    return (_echo_free_bytes_compiled() is not None and cfg.mode == "physical"
            and not cfg.multipath and (bank is None or bank.z_re is None))


def echo_free_bytes(sonar: ImagingSonar, position_ned: NDArray[np.float64],
                    rotation_ned_from_sonar: NDArray[np.float64], table: DisplayThresholds,
                    out: NDArray[np.uint8]) -> None:
    """``sonar.polar_bytes`` of a ping with no hit (its pose: sonar origin NED m, rotation
    sonar → NED) into ``out`` (n_bins, n_beams) uint8, bit for bit, drawing the same
    speckle offset (:func:`echo_free_supported` sonars; numba required). The diffuse
    level per row as :meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar._physical_image`
    and ``_physical_polar`` form it with no echo (zero far side lobes)."""
    cfg, g = sonar.config, sonar.geometry
    depression = math.asin(max(-1.0, min(1.0, float(rotation_ned_from_sonar[2, 0]))))
    surface = surface_rows(cfg, g.bin_centres, float(position_ned[2]), depression,
                           g.beam_spacing, float(g.beam_kernel.sum()))
    d = diffuse_rows(g.diffuse_static, out, g.leak, surface, [])  # (no row reads ``out``)
    free = (g.row_offset[:, 0] + g.k_ln * np.log(np.maximum(d, 1e-300))).astype(np.float32)
    bank = sonar._bank
    window = (np.zeros(out.shape, np.float32) if bank is None
              else bank.log_w(*bank.w_offset(sonar.rng)))
    _echo_free_bytes_compiled()(free, window, table.base, table.counts, table.next, out)
