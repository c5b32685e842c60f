"""Image formation stages from the raw echo image to the display polar image and its bytes.

The raw image holds, per (range bin, beam) cell, the echo intensity relative to the source
level SL (linear; :mod:`uhrisim.sensors.sonar.echoes`: spreading, absorption, Lambert
scattering, vertical beam pattern and element directivity are already in it). The stages,
each a pure function of the previous stage's array and the per-configuration constants of
:mod:`uhrisim.sensors.sonar.geometry` (physics and sources: ``docs/sonar.md``):

1. :func:`diffuse_rows` — what every beam at a range receives besides the echoes it
   looks at: receiver + ambient noise, volume and surface reverberation and the far
   side lobes' share of the echo at that range (one intensity per range row).
2. Speckle and the beam and pulse patterns, two models (``speckle_model``):
   product (default) — :func:`mean_intensity`, the incoherent mean through the power
   patterns (each beam's pattern with side lobes across beams, :func:`filter_beams`:
   steered beams widen off the axis; pulse envelope along range),
   times a unit speckle field |w|² made once per sonar from complex Gaussian scatterer
   sums through the same patterns' amplitudes (:mod:`uhrisim.sensors.sonar.speckle`):
   Rayleigh amplitude, grain a beam wide and a pulse long; coherent —
   :func:`coherent_field`, each cell's echo and diffuse intensity as complex Gaussian
   amplitudes √I·z summed through the amplitude patterns (exact at edges and point
   targets), :func:`coherent_log_intensity`. ``speckle=False``: the mean alone.
3. :func:`display_level` — TVG (imperfect: held inside ``tvg_min_range_m``, capped at
   the receiver's largest gain), source
   level, user gain and log compression into the display window:
   ``x = 1 + k·ln(I·SL·TVG·gain / top)``, k = 10/(ln 10 · dynamic range); clipped to
   0…1 by :func:`clip_unit`. This is ``SonarPing.polar`` (linear in dB).
4. :func:`display_bytes` — the 8-bit mapping a user sees: ``round(b + (255 − b)·x^γ)``,
   γ the contrast (``display_gamma``), b the black level (``display_black_level``).

``ImagingSonar._physical_polar`` composes them (one place), over the range rows that
echo reaches; rows no echo reaches take the diffuse level (times the speckle field),
which is what the stages give there.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.geometry import BeamBlock

#: Image borders mirror (…cb|abc…): a beam at the fan edge receives diffuse power through
#: its whole pattern, as the beams inside do.
_MIRROR = cv2.BORDER_REFLECT_101
#: Beyond a block of rows there is no echo (the blocks are padded by the pulse half-width).
_ZERO = cv2.BORDER_CONSTANT


def _padded(image: NDArray[np.float32], half: int) -> NDArray[np.float32]:
    """``image`` with ``half`` beams mirrored onto each side (the image's own border)."""
    return cv2.copyMakeBorder(image, 0, 0, half, half, _MIRROR)


def filter_beams(
    src: NDArray[np.float32],
    blocks: Sequence[BeamBlock],
    out: NDArray[np.float32],
    amplitude: bool = False,
    margin: int = 0,
) -> None:
    """Each beam of ``src`` through its block's horizontal pattern (``power``, or
    ``amplitude`` when True) into ``out``, image borders mirrored. One OpenCV pass with
    the pattern of the block with the most beams; each other block (steered beams widening
    off the axis) then filtered again from its beams and a margin of their neighbours, so
    that every beam sees exactly its own pattern. ``margin``: ``src`` carries that many
    columns of its own beyond each side (at least the widest pattern's half-width), used
    instead of mirroring; ``out`` is then that much narrower."""
    kernels = [b.amplitude if amplitude else b.power for b in blocks]
    n = out.shape[1]
    main = max(range(len(blocks)), key=lambda i: blocks[i].stop - blocks[i].start)
    if margin == 0:
        cv2.filter2D(src, cv2.CV_32F, kernels[main].reshape(1, -1), dst=out, borderType=_MIRROR)
    for i, (block, k) in enumerate(zip(blocks, kernels, strict=True)):
        if i == main and margin == 0:
            continue
        h = k.size // 2
        # Columns [lo, hi) of src around the block: where they meet the image's border
        # OpenCV mirrors it, as the image is; elsewhere the h columns beyond are real.
        lo = block.start + margin - h if margin else max(0, block.start - h)
        hi = block.stop + margin + h if margin else min(n, block.stop + h)
        res = cv2.filter2D(src[:, lo:hi], cv2.CV_32F, k.reshape(1, -1), borderType=_MIRROR)
        first = block.start + margin - lo
        out[:, block.start : block.stop] = res[:, first : first + block.stop - block.start]


def diffuse_rows(
    static_rows: NDArray[np.float64],
    raw: NDArray[np.float32] | None,
    leak: float,
    surface_rows: NDArray[np.float64] | None = None,
    rows: Sequence[tuple[int, int]] | None = None,
) -> NDArray[np.float64]:
    """Diffuse intensity per range row re SL (n_bins,): the static terms (noise, volume
    reverberation, post-TVG noise referred to the input), the surface reverberation of
    this ping (None: none) and the far side lobes: ``leak`` times the echo averaged over
    all beams of the row. ``rows``: row ranges [start, stop) outside which ``raw`` is zero
    (None: any row may hold echo); only those are averaged. ``raw`` None: no echo (then
    ``rows`` is empty)."""
    if rows is None:
        mean = cv2.reduce(raw, 1, cv2.REDUCE_AVG, dtype=cv2.CV_64F)[:, 0]
    else:
        mean = np.zeros(static_rows.shape[0])
        for a, b in rows:
            mean[a:b] = cv2.reduce(raw[a:b], 1, cv2.REDUCE_AVG, dtype=cv2.CV_64F)[:, 0]
    d = static_rows + leak * mean
    if surface_rows is not None:
        d = d + surface_rows
    return d


def coherent_field(
    raw: NDArray[np.float32],
    d_rows: NDArray[np.float64],
    z_re: NDArray[np.float32],
    z_im: NDArray[np.float32],
    blocks: Sequence[BeamBlock],
    range_amp: NDArray[np.float32],
    out_re: NDArray[np.float32],
    out_im: NDArray[np.float32],
) -> None:
    """Complex beam output of a block of whole rows:
    ``c = h_r ⊛ h_b ⊛ (√(raw + d/P) · z)``, with z unit complex Gaussian draws per cell
    (E|z|² = 1), each beam's amplitude pattern ``h_b`` (its block's) across beams, the
    pulse amplitude envelope ``h_r`` along range and P = Σh_b²·Σh_r²: the echo of each
    cell and the diffuse intensity ``d`` of its row (noise and reverberation are scattered
    and received through the same patterns) enter as random scatterer amplitudes, so
    E|c|² = |h_r|² ⊛ |h_b|² ⊛ raw + d (d taken constant over a pulse length), the mean of
    :func:`mean_intensity`. Borders mirror the image (the edge beams keep their diffuse
    power). Written into ``out_re``/``out_im`` (same shape as ``raw``)."""
    range_power = float(np.sum(range_amp.astype(np.float64) ** 2))

    def amplitude(raw_cols: NDArray[np.float32], block: BeamBlock) -> NDArray[np.float32]:
        power = float(np.sum(block.amplitude.astype(np.float64) ** 2)) * range_power
        # (numpy broadcasts a column ~3x faster than cv2.repeat + add)
        amp = np.add(raw_cols, (d_rows / power).astype(np.float32)[:, None])
        return cv2.sqrt(amp, amp)

    if len(blocks) == 1:
        amp = amplitude(raw, blocks[0])
        for z, out in ((z_re, out_re), (z_im, out_im)):
            cv2.multiply(amp, z, dst=out)
            cv2.filter2D(out, cv2.CV_32F, blocks[0].amplitude.reshape(1, -1), dst=out,
                         borderType=_MIRROR)  # fmt: skip
    else:  # each block's scatterers at its own P, its beams through its own pattern
        pad = max(b.amplitude.size // 2 for b in blocks)
        raw_p, zr_p, zi_p = (_padded(a, pad) for a in (raw, z_re, z_im))
        for block in blocks:
            h = block.amplitude.size // 2
            cols = slice(block.start + pad - h, block.stop + pad + h)
            amp = amplitude(raw_p[:, cols], block)
            for z_p, out in ((zr_p, out_re), (zi_p, out_im)):
                seg = cv2.filter2D(cv2.multiply(amp, z_p[:, cols]), cv2.CV_32F,
                                   block.amplitude.reshape(1, -1), borderType=_MIRROR)
                out[:, block.start : block.stop] = seg[:, h : h + block.stop - block.start]
    for out in (out_re, out_im):
        cv2.filter2D(out, cv2.CV_32F, range_amp.reshape(-1, 1), dst=out, borderType=_MIRROR)


#: Cells of 1.0 laid on each side of :func:`magnitude`'s operands (more than one SIMD
#: block of the 512-bit path).
_MAGNITUDE_PAD = 32


def magnitude(re: NDArray[np.float32], im: NDArray[np.float32]) -> NDArray[np.float32]:
    """``|re + i·im|`` (``re``'s shape, float32), each cell a function of its own two
    values alone, wherever the operands lie in memory.

    OpenCV's magnitude (Intel IPP's in the wheels) is not: its vector body and the
    elements it peels off at the buffer's unaligned head, at its tail and beside a zero
    round differently (1 ulp in about a third of cells), so the same values gave a
    cell a different bit wherever a buffer happened to start (the heap's state: run to
    run). Here the operands are copied into one fresh buffer between :data:`_MAGNITUDE_PAD`
    cells of 1.0 on each side: every cell is computed by the vector body, as the cells
    of a long buffer's inside always were (the same bits there). The two copies cost
    ~50 µs for a P900-45 image at 30 m (~1 % of a coherent ping)."""
    n, pad = re.size, _MAGNITUDE_PAD
    buf = np.empty((2, n + 2 * pad), np.float32)
    buf[:, :pad] = buf[:, n + pad :] = 1.0
    buf[0, pad : n + pad].reshape(re.shape)[...] = re
    buf[1, pad : n + pad].reshape(im.shape)[...] = im
    cv2.magnitude(buf[0], buf[1], magnitude=buf[0])
    return buf[0, pad : n + pad].reshape(re.shape)


def coherent_log_intensity(
    c_re: NDArray[np.float32], c_im: NDArray[np.float32], out: NDArray[np.float32]
) -> None:
    """``out = ln|c|`` (half the log intensity), via :func:`magnitude` and OpenCV's log."""
    cv2.log(magnitude(c_re, c_im), out)


def mean_intensity(
    raw: NDArray[np.float32],
    blocks: Sequence[BeamBlock],
    range_pow: NDArray[np.float32],
    d_rows: NDArray[np.float64],
    out: NDArray[np.float32],
) -> None:
    """Incoherent (speckle-free) intensity of a block of whole rows:
    ``|h_r|² ⊛ |h_b|² ⊛ raw + d(row)`` with each beam's power pattern ``|h_b|²`` (its
    block's; fan edges mirrored, zero echo beyond the block's rows), into ``out``."""
    filter_beams(raw, blocks, out)
    cv2.filter2D(out, cv2.CV_32F, range_pow.reshape(-1, 1), dst=out, borderType=_ZERO)
    np.add(out, d_rows.astype(np.float32)[:, None], out=out)  # (0 logs to −inf, clipped to 0)


def display_level(
    ln_i: NDArray[np.float32],
    k_ln: float,
    row_offset: NDArray[np.float32],
    out: NDArray[np.float32],
) -> None:
    """Log compression into the display window: ``out = k·ln I + row_offset`` with
    ``row_offset = 1 + k·ln(SL·TVG(R)·gain / top)`` (n_rows, n_beams) and ``ln_i`` the
    natural log of the intensity re SL (pass ``k_ln`` doubled for ``ln|c|``)."""
    cv2.scaleAdd(ln_i, k_ln, row_offset, dst=out)


def clip_unit(img: NDArray[np.float32]) -> NDArray[np.float32]:
    """Clip to 0…1 in place (two OpenCV thresholds: faster than np.clip here)."""
    cv2.threshold(img, 1.0, 1.0, cv2.THRESH_TRUNC, dst=img)
    cv2.threshold(img, 0.0, 0.0, cv2.THRESH_TOZERO, dst=img)
    return img


def display_bytes(
    polar: NDArray[np.float32], gamma: float, black: int = 0, clipped: bool = True
) -> NDArray[np.uint8]:
    """The 8-bit display mapping ``round(b + (255 − b)·x^γ)`` of the clipped display level
    x: the contrast curve γ, and the black level b the viewer gives the bottom of the
    display window (a window's bottom is grey, not black, on real displays).

    ``clipped=False``: ``polar`` is the display level before :func:`clip_unit` (not
    NaN), clipped here in place; the same bytes. For γ ≠ 1 a pass fewer: the curve's floor
    at 1e-30 takes every x ≤ 0 as it takes 0, so only the top is clipped (x^γ of a level
    far above 1 would overflow OpenCV's rounding to int)."""
    scale = 255.0 - black
    if gamma == 1.0:
        if not clipped:
            clip_unit(polar)
        return cv2.convertScaleAbs(polar, alpha=scale, beta=float(black))
    if not clipped:
        cv2.threshold(polar, 1.0, 1.0, cv2.THRESH_TRUNC, dst=polar)
    # x = 0 stays at the black level: 255·(1e-30)^γ < 0.5 for every allowed γ ≥ 0.1 (and
    # OpenCV's log of 0 and exp of −inf take a slow path, ~10× a normal pass).
    t = cv2.max(polar, 1e-30)
    cv2.log(t, t)
    np.multiply(t, np.float32(gamma), out=t)
    cv2.exp(t, t)
    return cv2.convertScaleAbs(t, alpha=scale, beta=float(black))
