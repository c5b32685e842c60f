"""The random fields of the speckle, drawn once per sonar and windowed per ping.

Drawing ~600 k float32 normals costs ~2.5 ms — the whole image-formation budget of a
ping — so each sonar draws, once, from its own Generator (its named stream,
``core/rng.py``):

* ``w``: the speckle field — unit complex Gaussian scatterer amplitudes passed through
  the beam and pulse amplitude patterns and scaled to E|w|² = 1, kept as its log
  intensity ``k·ln|w|²`` (k: the display's log scale): exponential intensity (Rayleigh
  amplitude) with the grain of the beam and the pulse (each beam's own: steered beams
  widen off the axis); a 2-D bank :data:`ROW_EXTRA` rows and up to :data:`COL_EXTRA`
  beams larger than the image (:func:`bank_columns`). The product model multiplies
  the mean image by |w|²; the coherent model uses it in the rows no echo reaches;
* ``z`` (coherent model only): i.i.d. unit complex Gaussian scatterer amplitudes
  (E|z|² = 1), a flat bank :data:`FLAT_EXTRA` cells longer than the image.

Each ping draws a random offset into each bank from the same Generator. Why this is
statistically honest: inside one ping every statistic is that of fresh draws (the w
window is a stationary Gaussian field with the beam/pulse correlation, cut from the
interior of a larger filtered field; the z window is i.i.d.), and the offsets are
uniform, so a pixel's values in two pings are independent unless the two offsets fall
within one grain of each other (probability ≈ grain cells / offsets ≈ 0.5 % per pair of
pings for w) — real speckle decorrelates between pings too (a platform moving a few
millimetres, a fraction of the 1.7 mm wavelength at 900 kHz, changes it). What repeats
is a shifted copy of a field, never a pixel pattern at the same place. Memory: one
float32 plane of about the image size (≈ 2 MB for a P900-45 at 30 m, ≈ 15 MB for a
P900-130 at 100 m); the coherent model adds two (its z bank).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.geometry import BLOCK_WIDTH_RATIO, BeamBlock
from uhrisim.sensors.sonar.polar import filter_beams, magnitude

#: Extra cells of the flat scatterer bank beyond the image (possible z offsets).
FLAT_EXTRA = 1 << 18
#: Extra rows and beams of the diffuse-field bank (possible w offsets: 513 × 65).
ROW_EXTRA = 512
COL_EXTRA = 64


def complex_normals(
    rng: np.random.Generator, shape: tuple[int, ...]
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Real and imaginary parts of unit complex Gaussian draws (E|z|² = 1), float32."""
    scale = np.float32(np.sqrt(0.5))
    re = rng.standard_normal(shape, dtype=np.float32) * scale
    im = rng.standard_normal(shape, dtype=np.float32) * scale
    return re, im


def bank_columns(blocks: Sequence[BeamBlock]) -> int:
    """How many columns wider than the image the bank of ``blocks`` may be: the largest
    span (≤ :data:`COL_EXTRA`) over which a window can slide while every beam still gets
    the pattern of its own width band or a neighbouring one, within
    ``BLOCK_WIDTH_RATIO``^1.5 (6 %) of its own (all of :data:`COL_EXTRA` for one block or
    a 45° fan; a few beams for a 130° steered fan, whose edge bands are a few beams long)."""
    width = np.concatenate([np.full(b.stop - b.start, b.width) for b in blocks])
    step = BLOCK_WIDTH_RATIO**1.5
    extra = COL_EXTRA
    while extra > 0:
        half = extra // 2
        moved = [width[np.clip(np.arange(width.size) + d, 0, width.size - 1)]
                 for d in range(-half, extra - half + 1)]  # fmt: skip
        worst = max(float(np.max(np.maximum(m / width, width / m))) for m in moved)
        if worst <= step * (1.0 + 1e-9) or len(blocks) == 1:
            return extra
        extra -= 1
    return 0


def bank_blocks(blocks: Sequence[BeamBlock], extra: int) -> tuple[BeamBlock, ...]:
    """The image's beam blocks laid over a bank ``extra`` columns wider: bank column c
    takes the pattern of image beam c − extra//2 (the outer blocks extended to the bank's
    edges), so a window at column offset o ≤ ``extra`` gives beam j the pattern of beam
    j + o − extra//2 (:func:`bank_columns` keeps that within one width band)."""
    half = extra // 2
    last = len(blocks) - 1
    return tuple(
        BeamBlock(0 if i == 0 else b.start + half,
                  b.stop + extra if i == last else b.stop + half, b.width, b.power,
                  b.amplitude)
        for i, b in enumerate(blocks)
    )  # fmt: skip


def filtered_field(
    re: NDArray[np.float32],
    im: NDArray[np.float32],
    blocks: Sequence[BeamBlock],
    range_amp: NDArray[np.float32],
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """The complex field ``h_r ⊛ h_b ⊛ z`` scaled to unit mean intensity, cropped by the
    kernels' half-widths on every side (so no cell sees the border). Output column j takes
    the pattern (and scale) of the block that holds it (``blocks`` cover the output's
    columns); the input is wider by twice the widest pattern's half-width."""
    hr = range_amp.size // 2
    range_power = float(np.sum(range_amp.astype(np.float64) ** 2))
    pad = max(b.amplitude.size // 2 for b in blocks)
    out = []
    for part in (re, im):
        f = cv2.sepFilter2D(part, cv2.CV_32F, np.ones(1, np.float32), range_amp,
                            borderType=cv2.BORDER_REFLECT)[hr : part.shape[0] - hr]  # fmt: skip
        field = np.empty((f.shape[0], f.shape[1] - 2 * pad), np.float32)
        filter_beams(f, blocks, field, amplitude=True, margin=pad)
        for block in blocks:
            power = np.sum(block.amplitude.astype(np.float64) ** 2) * range_power
            field[:, block.start : block.stop] *= np.float32(1.0 / np.sqrt(power))
        out.append(field)
    return out[0], out[1]


@dataclass(frozen=True)
class SpeckleBank:
    """The per-sonar random fields (module docstring); windows are views, never copies."""

    shape: tuple[int, int]  # (n_bins, n_beams) of the image
    z_re: NDArray[np.float32] | None  # flat; None: no scatterer bank (product speckle)
    z_im: NDArray[np.float32] | None
    k_ln_w2: NDArray[np.float32]  # k·ln|w|², (n_bins + ROW_EXTRA, n_beams + ≤ COL_EXTRA)
    z_offsets: int = FLAT_EXTRA + 1  # possible z offsets

    @staticmethod
    def draw(
        rng: np.random.Generator,
        shape: tuple[int, int],
        blocks: Sequence[BeamBlock],
        range_amp: NDArray[np.float32],
        k_ln: float,
        scatterers: bool = True,
    ) -> SpeckleBank:
        """Draw the banks for an image of ``shape`` from ``rng``, its beams formed through
        ``blocks`` (:func:`uhrisim.sensors.sonar.geometry.beam_blocks`); ``k_ln`` scales
        the stored log intensity (display units per natural-log unit); ``scatterers``:
        draw the z bank too (the coherent model needs it). With several blocks (steered
        beams widening off the axis) the bank is :func:`bank_columns` wider, so that
        wherever a ping's window falls each beam's grain is that of its own width band or
        the next."""
        n_bins, n_beams = shape
        z_re = z_im = None
        if scatterers:
            z_re, z_im = complex_normals(rng, (n_bins * n_beams + FLAT_EXTRA,))
        hb = max(b.amplitude.size // 2 for b in blocks)
        extra = bank_columns(blocks)
        big = (n_bins + ROW_EXTRA + 2 * (range_amp.size // 2), n_beams + extra + 2 * hb)
        layout = bank_blocks(blocks, extra)
        w_re, w_im = filtered_field(*complex_normals(rng, big), layout, range_amp)
        ln_w2 = magnitude(w_re, w_im)
        cv2.log(np.maximum(ln_w2, np.float32(1e-30)), ln_w2)
        return SpeckleBank(shape, z_re, z_im, ln_w2 * np.float32(2.0 * k_ln))

    def w_offset(self, rng: np.random.Generator) -> tuple[int, int]:
        """A ping's random window of the diffuse field: (row, column). (Two scalar draws:
        the numbers, and the Generator's state after them, of one ``integers`` call with
        the two bounds, in under half its time.)"""
        row = int(rng.integers(0, ROW_EXTRA + 1))
        return row, int(rng.integers(0, self.k_ln_w2.shape[1] - self.shape[1] + 1))

    def z(self, offset: int) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """The scatterer amplitudes of a ping, (n_bins, n_beams) views."""
        n = self.shape[0] * self.shape[1]
        return (self.z_re[offset : offset + n].reshape(self.shape),
                self.z_im[offset : offset + n].reshape(self.shape))  # fmt: skip

    def log_w(self, row: int, col: int) -> NDArray[np.float32]:
        """The diffuse field's k·ln|w|² for a ping, an (n_bins, n_beams) view."""
        return self.k_ln_w2[row : row + self.shape[0], col : col + self.shape[1]]
