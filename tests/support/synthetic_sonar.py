"""Synthetic polar sonar pings with known answers, for the perception tests.

The image model follows ``docs/reference/sonar.md`` ("a physically grounded image"):
linear intensity = noise floor × unit-exponential speckle (Rayleigh amplitude), speckle
grain spread over ~5 beams (a 1° beam over 0.176° spacing), plus point targets whose
echo is a sinc² main lobe across beams (1° wide) and a Gaussian of the pulse across
range bins; then log compression ``level = clip(1 + 10·log10(I)/DR, 0, 1)`` (intensity
relative to the display top). The geometry is the P900-45's (256 beams over 45°,
2.54 cm bins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

N_BEAMS = 256
FOV_DEG = 45.0
BIN_M = 0.0254
DR_DB = 50.0
BEAMS = np.radians(np.linspace(-FOV_DEG / 2, FOV_DEG / 2, N_BEAMS))
BEAM_STEP = float(BEAMS[1] - BEAMS[0])


def bins(range_min: float = 0.5, range_max: float = 10.0) -> np.ndarray:
    n = round((range_max - range_min) / BIN_M)
    return range_min + (np.arange(n) + 0.5) * BIN_M


@dataclass(frozen=True)
class Target:
    range_m: float
    bearing_rad: float
    level_db: float = -10.0  # echo of each point relative to the display top, dB
    extent_m: float = 0.0  # a square patch of point scatterers this wide (0: one point)


@dataclass
class Ping:
    """What perception reads of a SonarPing."""

    t: float
    polar: np.ndarray
    bin_ranges_m: np.ndarray
    beam_angles_rad: np.ndarray
    position_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation_ned_from_sonar: np.ndarray = field(default_factory=lambda: np.eye(3))


def rotation_yaw(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def polar_image(ranges: np.ndarray, targets: list[Target], rng: np.random.Generator | None,
                floor_db: float | None = -35.0) -> np.ndarray:
    """The display level (n_bins, n_beams) of ``targets`` over a speckled noise floor
    (``floor_db`` re the display top; None: a clean image with no floor, as the 2026
    simulator drew it)."""
    n_bins = ranges.size
    intensity = np.zeros((n_bins, N_BEAMS))
    if floor_db is not None:
        speckle = rng.exponential(1.0, (n_bins, N_BEAMS + 8))
        kernel = np.ones(5) / 5.0
        speckle = np.apply_along_axis(lambda row: np.convolve(row, kernel, "same"), 1, speckle)
        speckle = speckle[:, 4:-4] / speckle.mean()
        intensity += 10 ** (floor_db / 10) * speckle
    sigma_bins = 1.0
    for tg in targets:
        points = [(tg.range_m, tg.bearing_rad)]
        if tg.extent_m > 0:
            offs = np.arange(-tg.extent_m / 2, tg.extent_m / 2 + 1e-9, 0.05)
            points = [(tg.range_m + a, tg.bearing_rad + b / tg.range_m)
                      for a in offs for b in offs]
        for r0, th0 in points:
            u = (BEAMS - th0) / math.radians(1.0) * 0.886  # sinc² with a 1° -3 dB width
            beam = np.sinc(u) ** 2
            rng_profile = np.exp(-0.5 * ((ranges - r0) / (sigma_bins * BIN_M)) ** 2)
            intensity += 10 ** (tg.level_db / 10) * np.outer(rng_profile, beam)
    with np.errstate(divide="ignore"):
        level = 1.0 + 10.0 * np.log10(intensity) / DR_DB
    return np.clip(np.nan_to_num(level, neginf=0.0), 0.0, 1.0).astype(np.float32)
