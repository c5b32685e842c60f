"""Folders of synthetic 8-bit fan frames with known statistics, for ``sonar-compare``.

A polar field (range bins × beams, 1 px and 0.25° apart) is scan-converted to a square
fan (apex at the bottom centre, 90° wide, one bin per pixel row of range) by nearest
neighbour, so every pixel is a sample of the field:

* Rayleigh amplitude of scale σ: a = σ·√(−2 ln u), u uniform (independent pixels);
* K-distributed amplitude of shape ν: a = s·√(G·X), G ~ Gamma(ν, 1/ν) (mean 1) the
  texture, X ~ Exp(1) the speckle intensity;
* speckle of known grain: the intensity |h ⊛ z|² of unit complex Gaussian z through a
  Gaussian amplitude kernel of std s samples along each axis, whose autocorrelation is
  exp(−Δ²/2s²): half maximum at FWHM = 2·√(2 ln 2)·s.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

SIZE = 256  # px: the fan's height (range) and width
FOV_DEG = 90.0
N_BEAMS = 361  # 0.25° apart
FWHM_PER_STD = 2.0 * math.sqrt(2.0 * math.log(2.0))


def fan_maps() -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_]]:
    """(beam index, range bin, inside) of every fan pixel."""
    x, y = np.meshgrid(np.arange(SIZE) - (SIZE - 1) / 2.0, (SIZE - 0.5) - np.arange(SIZE))
    r, bearing = np.hypot(x, y), np.degrees(np.arctan2(x, y))
    inside = (np.abs(bearing) <= FOV_DEG / 2) & (r <= SIZE - 1)
    beam = (bearing + FOV_DEG / 2) / FOV_DEG * (N_BEAMS - 1)
    return (np.where(inside, beam, -10).astype(np.float32),
            np.where(inside, r - 0.5, -10).astype(np.float32), inside)  # fmt: skip


def to_fan(polar: NDArray[np.float64]) -> NDArray[np.uint8]:
    """A polar field (SIZE bins × N_BEAMS) as an 8-bit fan (rounded, clipped)."""
    mx, my, inside = fan_maps()
    fan = cv2.remap(polar.astype(np.float32), mx, my, cv2.INTER_NEAREST,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)  # fmt: skip
    return (np.clip(np.rint(fan), 0, 255) * inside).astype(np.uint8)


def rayleigh(rng: np.random.Generator, sigma: float) -> NDArray[np.float64]:
    return sigma * np.sqrt(-2.0 * np.log(1.0 - rng.random((SIZE, N_BEAMS))))


def k_field(rng: np.random.Generator, nu: float, scale: float) -> NDArray[np.float64]:
    texture = rng.gamma(nu, 1.0 / nu, (SIZE, N_BEAMS))
    return scale * np.sqrt(texture * rng.exponential(1.0, (SIZE, N_BEAMS)))


def grained(rng: np.random.Generator, std_range: float, std_beams: float,
            mean: float = 40.0) -> NDArray[np.float64]:  # fmt: skip
    """Intensity speckle of mean ``mean`` whose autocorrelation has std ``std_range``
    bins along range and ``std_beams`` beams across."""

    def kernel(s: float) -> NDArray[np.float32]:
        t = np.arange(-int(4 * s + 1), int(4 * s + 2))
        g = np.exp(-t * t / (2 * s * s))
        return (g / np.sqrt(np.sum(g * g))).astype(np.float32)

    parts = [cv2.sepFilter2D(rng.standard_normal((SIZE, N_BEAMS)).astype(np.float32), -1,
                             kernel(std_beams), kernel(std_range),
                             borderType=cv2.BORDER_REFLECT) for _ in range(2)]  # fmt: skip
    return mean * 0.5 * (parts[0].astype(np.float64) ** 2 + parts[1].astype(np.float64) ** 2)


def write_folder(folder: Path, frames: list[NDArray[np.uint8]],
                 objects: list[NDArray[np.bool_]] | None = None) -> Path:  # fmt: skip
    """``fNNN.png`` frames (with ``fNNN_mask.png`` objects) and the ``fan_mask.png``."""
    folder.mkdir(parents=True, exist_ok=True)
    for i, frame in enumerate(frames):
        cv2.imwrite(str(folder / f"f{i:03d}.png"), frame)
        if objects is not None:
            cv2.imwrite(str(folder / f"f{i:03d}_mask.png"), objects[i].astype(np.uint8) * 255)
    cv2.imwrite(str(folder / "fan_mask.png"), fan_maps()[2].astype(np.uint8) * 255)
    return folder
