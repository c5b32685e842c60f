"""Image formation stages from the raw echo image to the display polar image.

The raw image holds, per (range bin, beam) cell, the echo intensity relative to the source
level SL (linear; :mod:`uhrisim.sensors.sonar.echoes`). The stages, in the log domain where
they take the fewest passes over the image (``shared/reference/sonar.md``):

* beam pattern (convolution along the beams) and pulse length (along range);
* noise floor NL added (re SL);
* TVG (+k·log10 R + 2αR by default), source level and gain;
* Rayleigh speckle: a factor on intensity, drawn per cell from a look-up table;
* display mapping: ``polar = clip(1 + (L − display_top_db)/dynamic_range_db, 0, 1)``.

Each is a pure function of arrays (kernels, curves and tables precomputed once per
configuration, :mod:`uhrisim.sensors.sonar.geometry`); ``ImagingSonar`` composes them.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray


def log_level(
    raw: NDArray[np.float32],
    out: NDArray[np.float32],
    beam_kernel: NDArray[np.float32],
    range_kernel: NDArray[np.float32],
    noise_rel: float,
    k_ln: float,
    row_offset: NDArray[np.float32],
) -> None:
    """``out = 1 + k·ln(conv(raw) + NL/SL) + k·ln(TVG·SL·gain/top)`` (display units, before
    speckle and clipping) for a block of whole rows of the raw echo image (echo re SL), with
    zero echo assumed beyond the block's edges; ``row_offset`` holds the block's rows of
    ``1 + k·ln(TVG·SL·gain/top)``. Written into ``out`` (same shape as ``raw``)."""
    noise_positive = noise_rel > 1e-30  # log() needs a positive argument
    # The separable filter as two filter2D passes (along beams, then in place along range):
    # same result to float32 rounding, about 1.5x faster than OpenCV's sepFilter2D here.
    delta = noise_rel if noise_positive else 0.0
    zero_border = cv2.BORDER_CONSTANT
    cv2.filter2D(raw, cv2.CV_32F, beam_kernel.reshape(1, -1), dst=out, borderType=zero_border)
    cv2.filter2D(out, cv2.CV_32F, range_kernel.reshape(-1, 1), dst=out, delta=delta,
                 borderType=zero_border)  # fmt: skip
    if not noise_positive:
        np.maximum(out, np.float32(1e-37), out=out)
    cv2.log(out, out)
    cv2.scaleAdd(out, k_ln, row_offset, dst=out)


def floor_level(
    beam_kernel: NDArray[np.float32],
    range_kernel: NDArray[np.float32],
    noise_rel: float,
    k_ln: float,
    row_offset: NDArray[np.float32],
) -> NDArray[np.float32]:
    """Display level (before speckle and clipping) of every cell of an echo-free image —
    the noise floor after TVG and gain — formed by the very operations of a ping, so that a
    ping may copy it into the rows no echo reaches instead of filtering them."""
    out = np.empty(row_offset.shape, np.float32)
    log_level(np.zeros_like(out), out, beam_kernel, range_kernel, noise_rel, k_ln, row_offset)
    return out


def uniform_bytes(rng: np.random.Generator, n: int) -> NDArray[np.uint8]:
    """``n`` independent uniform random bytes: the bytes of full-range 64-bit draws
    (several times faster than ``Generator.bytes``, which draws 32 bits at a time through
    the bounded-integer path)."""
    words = rng.integers(0, np.iinfo(np.uint64).max, (n + 7) // 8, np.uint64, endpoint=True)
    return words.view(np.uint8)[:n]


def speckle_lut(bits: int = 8) -> NDArray[np.float32]:
    """Inverse CDF of the unit exponential at the 2^bits mid-quantiles, rescaled to mean 1:
    a uniform ``bits``-bit integer → a speckle factor on intensity (Rayleigh amplitude).

    With 8 bits the amplitude std/mean is 0.522 (continuous Rayleigh: 0.5227) and the
    heaviest draw is 6.2× the mean (a continuous draw exceeds that with probability 0.2 %).
    """
    n = 1 << bits
    u = (np.arange(n, dtype=np.float64) + 0.5) / n
    e = -np.log1p(-u)
    return (e / e.mean()).astype(np.float32)
