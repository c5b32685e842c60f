"""The random fields of the speckle, drawn once per sonar and windowed per ping.

Drawing ~600 k float32 normals costs ~2.5 ms — the whole image-formation budget of a
ping — so each sonar draws, once, from its own Generator (its named stream,
``core/rng.py``):

* ``w``: the speckle field — unit complex Gaussian scatterer amplitudes passed through
  the beam and pulse amplitude patterns and scaled to E|w|² = 1, kept as its log
  intensity ``k·ln|w|²`` (k: the display's log scale): exponential intensity (Rayleigh
  amplitude) with the grain of the beam and the pulse; a 2-D bank :data:`ROW_EXTRA`
  rows and :data:`COL_EXTRA` beams larger than the image. The product model multiplies
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

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

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


def filtered_field(
    re: NDArray[np.float32],
    im: NDArray[np.float32],
    beam_amp: NDArray[np.float32],
    range_amp: NDArray[np.float32],
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """The complex field ``h_r ⊛ h_b ⊛ z`` scaled to unit mean intensity, cropped by the
    kernels' half-widths on every side (so no cell sees the border)."""
    hb, hr = beam_amp.size // 2, range_amp.size // 2
    power = float(np.sum(beam_amp.astype(np.float64) ** 2)) * float(
        np.sum(range_amp.astype(np.float64) ** 2)
    )
    norm = np.float32(1.0 / np.sqrt(power))
    out = []
    for part in (re, im):
        f = cv2.sepFilter2D(part, cv2.CV_32F, beam_amp, range_amp, borderType=cv2.BORDER_REFLECT)
        out.append(np.ascontiguousarray(f[hr : f.shape[0] - hr, hb : f.shape[1] - hb]) * norm)
    return out[0], out[1]


@dataclass(frozen=True)
class SpeckleBank:
    """The per-sonar random fields (module docstring); windows are views, never copies."""

    shape: tuple[int, int]  # (n_bins, n_beams) of the image
    z_re: NDArray[np.float32] | None  # flat; None: no scatterer bank (product speckle)
    z_im: NDArray[np.float32] | None
    k_ln_w2: NDArray[np.float32]  # k·ln|w|², (n_bins + ROW_EXTRA, n_beams + COL_EXTRA)
    z_offsets: int = FLAT_EXTRA + 1  # possible z offsets

    @staticmethod
    def draw(
        rng: np.random.Generator,
        shape: tuple[int, int],
        beam_amp: NDArray[np.float32],
        range_amp: NDArray[np.float32],
        k_ln: float,
        scatterers: bool = True,
    ) -> SpeckleBank:
        """Draw the banks for an image of ``shape`` from ``rng``; ``k_ln`` scales the
        stored log intensity (display units per natural-log unit); ``scatterers``: draw
        the z bank too (the coherent model needs it)."""
        n_bins, n_beams = shape
        z_re = z_im = None
        if scatterers:
            z_re, z_im = complex_normals(rng, (n_bins * n_beams + FLAT_EXTRA,))
        hb, hr = beam_amp.size // 2, range_amp.size // 2
        big = (n_bins + ROW_EXTRA + 2 * hr, n_beams + COL_EXTRA + 2 * hb)
        w_re, w_im = filtered_field(*complex_normals(rng, big), beam_amp, range_amp)
        ln_w2 = cv2.magnitude(w_re, w_im)
        cv2.log(np.maximum(ln_w2, np.float32(1e-30)), ln_w2)
        return SpeckleBank(shape, z_re, z_im, ln_w2 * np.float32(2.0 * k_ln))

    @staticmethod
    def w_offset(rng: np.random.Generator) -> tuple[int, int]:
        """A ping's random window of the diffuse field: (row, column)."""
        o = rng.integers(0, (ROW_EXTRA + 1, COL_EXTRA + 1))
        return int(o[0]), int(o[1])

    def z(self, offset: int) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """The scatterer amplitudes of a ping, (n_bins, n_beams) views."""
        n = self.shape[0] * self.shape[1]
        return (self.z_re[offset : offset + n].reshape(self.shape),
                self.z_im[offset : offset + n].reshape(self.shape))  # fmt: skip

    def log_w(self, row: int, col: int) -> NDArray[np.float32]:
        """The diffuse field's k·ln|w|² for a ping, an (n_bins, n_beams) view."""
        return self.k_ln_w2[row : row + self.shape[0], col : col + self.shape[1]]
