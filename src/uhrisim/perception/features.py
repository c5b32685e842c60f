"""The paper's sonar feature step (DeMarco, West & Howard 2013): corners and edges found
with OpenCV on the sonar image, turned into obstacle points in the sonar frame and in
world NED.

Corners: ``cv2.goodFeaturesToTrack`` (Shi–Tomasi); edges: ``cv2.Canny``, sub-sampled. An
imaging sonar has no elevation, so every point lies in the sonar's x–y plane (z = 0 in
the sonar frame) before it is rotated into NED. Pixels near the fan boundary (and the
white boundary lines of the 2013 image) are masked out, so the fan outline is not
reported as an obstacle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.ping import SonarPing


@dataclass(frozen=True)
class FeatureParams:
    """Settings of the feature step (OpenCV defaults of the kind the paper used).

    Attributes:
        max_corners: most corners returned (strongest first).
        quality_level: Shi–Tomasi quality relative to the best corner (0…1).
        min_distance_px: minimum spacing between corners, pixels.
        block_size: Shi–Tomasi neighbourhood, pixels.
        canny_low, canny_high: Canny hysteresis thresholds (8-bit intensity gradients).
        blur_ksize: Gaussian pre-blur (odd, 1 = none) against speckle.
        min_intensity: corners on pixels darker than this (after the blur) are dropped.
        edge_stride: keep every n-th edge pixel (edges come back as points).
        border_px: pixels within this distance of the fan boundary are ignored.
        min_range_m: ignore features closer than this to the sonar, metres.
    """

    max_corners: int = 50
    quality_level: float = 0.05
    min_distance_px: float = 5.0
    block_size: int = 5
    canny_low: float = 60.0
    canny_high: float = 150.0
    blur_ksize: int = 5
    min_intensity: int = 60
    edge_stride: int = 4
    border_px: int = 4
    min_range_m: float = 0.5

    def __post_init__(self) -> None:
        def bad(name: str, msg: str) -> ConfigError:
            return ConfigError(msg, where=f"FeatureParams.{name}")

        if self.max_corners < 1:
            raise bad("max_corners", f"must be >= 1, got {self.max_corners!r}")
        if not 0.0 < self.quality_level < 1.0:
            raise bad("quality_level", f"must be in (0, 1), got {self.quality_level!r}")
        if self.blur_ksize < 1 or self.blur_ksize % 2 == 0:
            raise bad("blur_ksize", f"must be an odd integer >= 1, got {self.blur_ksize!r}")
        if self.edge_stride < 1:
            raise bad("edge_stride", f"must be >= 1, got {self.edge_stride!r}")
        if not 0.0 <= self.canny_low <= self.canny_high:
            raise bad("canny_low", "must satisfy 0 <= canny_low <= canny_high")


@dataclass(frozen=True)
class SonarFeatures:
    """Obstacle features of one ping.

    Attributes:
        corners_px, edges_px: (N, 2) pixel coordinates (column, row) in ``ping.fan_u8``.
        corners_sonar, edges_sonar: (N, 3) sonar-frame points, metres (z = 0).
        corners_ned, edges_ned: (N, 3) world NED points, metres.
        t: the ping time, s.
    """

    t: float
    corners_px: NDArray[np.float64]
    edges_px: NDArray[np.float64]
    corners_sonar: NDArray[np.float64]
    edges_sonar: NDArray[np.float64]
    corners_ned: NDArray[np.float64]
    edges_ned: NDArray[np.float64]

    @property
    def obstacles_ned(self) -> NDArray[np.float64]:
        """Corners then edge points, world NED (N, 3)."""
        return np.concatenate([self.corners_ned, self.edges_ned], axis=0)


def valid_mask(ping: SonarPing, params: FeatureParams) -> NDArray[np.bool_]:
    """Pixels of ``ping.fan_u8`` that lie inside the fan, ``border_px`` away from its
    boundary, and beyond ``min_range_m``."""
    H, W = ping.fan_u8.shape
    cols, rows = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    pts = ping.fan_pixels_to_sonar(np.stack([cols.ravel(), rows.ravel()], axis=1))
    r = np.hypot(pts[:, 0], pts[:, 1]).reshape(H, W)
    th = np.arctan2(pts[:, 1], pts[:, 0]).reshape(H, W)
    margin_m = params.border_px / ping.fan_px_per_m
    r_max = float(ping.bin_ranges_m[-1])
    half = ping.fan_half_fov_rad
    with np.errstate(divide="ignore"):
        ang_margin = np.where(r > 0, margin_m / np.maximum(r, 1e-9), math.pi)
    inside = (
        (r >= max(params.min_range_m, float(ping.bin_ranges_m[0]) + margin_m))
        & (r <= r_max - margin_m)
        & (np.abs(th) <= half - ang_margin)
    )
    return inside


def extract_features(ping: SonarPing, params: FeatureParams | None = None) -> SonarFeatures:
    """Corners (Shi–Tomasi) and edges (Canny) of ``ping.fan_u8`` as obstacle points."""
    p = params if params is not None else FeatureParams()
    img = ping.fan_u8
    if p.blur_ksize > 1:
        img = cv2.GaussianBlur(img, (p.blur_ksize, p.blur_ksize), 0)
    mask = valid_mask(ping, p)
    mask_u8 = mask.astype(np.uint8) * np.uint8(255)
    corners = cv2.goodFeaturesToTrack(
        img,
        maxCorners=p.max_corners,
        qualityLevel=p.quality_level,
        minDistance=p.min_distance_px,
        mask=mask_u8,
        blockSize=p.block_size,
    )
    if corners is None:
        corners_px = np.zeros((0, 2))
    else:
        corners_px = corners.reshape(-1, 2).astype(float)
        ci = np.round(corners_px).astype(int)
        keep = img[ci[:, 1], ci[:, 0]] >= p.min_intensity
        corners_px = corners_px[keep]
    edges = cv2.Canny(img, p.canny_low, p.canny_high)
    edges[~mask] = 0
    er, ec = np.nonzero(edges)
    edges_px = np.stack([ec, er], axis=1).astype(float)[:: p.edge_stride]
    cs = ping.fan_pixels_to_sonar(corners_px)
    es = ping.fan_pixels_to_sonar(edges_px)
    return SonarFeatures(
        t=ping.t,
        corners_px=corners_px,
        edges_px=edges_px,
        corners_sonar=cs,
        edges_sonar=es,
        corners_ned=ping.sonar_to_ned(cs),
        edges_ned=ping.sonar_to_ned(es),
    )
