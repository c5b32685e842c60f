"""Scan conversion: the polar image (range bins × beams) into the Cartesian fan image.

Physical mode: the fan has its apex at the bottom centre, forward up, starboard right,
black outside the field of view; :func:`fan_maps` (once per configuration) gives each fan
pixel its fractional (beam, bin) in the polar image, and :func:`fan_image` resamples a
ping's polar image through them (bilinear). 2013 mode (DeMarco et al. 2013):
:func:`image_2013` draws the hit points themselves. :func:`color_fan` applies the
configured OpenCV colour map. Metres and radians; beam angles > 0 to starboard.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.config import SonarConfig


class FanMaps(NamedTuple):
    """Where each fan pixel (row, column) samples the polar image."""

    map_x: NDArray[np.float32]  # fractional beam index; −10 outside the fan
    map_y: NDArray[np.float32]  # fractional range bin; −10 outside the fan
    map_nearest: NDArray[np.int16]  # (H, W, 2) integer (beam, bin): nearest-neighbour maps
    mask: NDArray[np.bool_]  # inside the field of view and the range window
    mask_u8: NDArray[np.uint8]  # the mask as 0/255
    px_per_m: float
    apex: tuple[float, float]  # (column, row) of the apex, pixel-centre coordinates


def fractional_beam(
    theta: NDArray[np.float64], beam_angles: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Fractional beam index of bearings ``theta`` (rad) for beams at ``beam_angles`` (rad,
    ascending, evenly spaced or not): linear between beam centres, continued beyond the
    first and last beam with their spacing."""
    first = beam_angles[1] - beam_angles[0]
    last = beam_angles[-1] - beam_angles[-2]
    n = beam_angles.size
    index = np.interp(theta, beam_angles, np.arange(n, dtype=np.float64))
    index = np.where(theta < beam_angles[0], (theta - beam_angles[0]) / first, index)
    return np.where(theta > beam_angles[-1], n - 1 + (theta - beam_angles[-1]) / last, index)


def fan_maps(cfg: SonarConfig, beam_angles: NDArray[np.float64]) -> FanMaps:
    """Scan-conversion maps of a physical-mode fan ``cfg.fan_size_px`` pixels across (its
    larger side) for the beams at ``beam_angles`` (rad, ascending; the native angles,
    evenly spaced or not: each fan pixel samples the beams whose centres bracket its
    bearing). The fan covers the beams' centres and half a beam beyond the outer ones."""
    half_fov = math.radians(cfg.sonar_spec.fov_h_deg) / 2.0
    r_max = cfg.range_max_m
    width_m = 2.0 * r_max * math.sin(half_fov)
    height_m = r_max
    scale = cfg.fan_size_px / max(width_m, height_m)
    W = max(2, math.ceil(width_m * scale))
    H = max(2, math.ceil(height_m * scale))
    cols = (np.arange(W, dtype=np.float64) + 0.5 - W / 2.0) / scale  # starboard, m
    rows = (H - (np.arange(H, dtype=np.float64) + 0.5)) / scale  # forward, m
    xs, ys = np.meshgrid(cols, rows)
    rr = np.hypot(xs, ys)
    th = np.arctan2(xs, ys)
    fx = fractional_beam(th, beam_angles)
    fy = (rr - cfg.range_min_m) / cfg.bin_m - 0.5
    inside = (fx >= -0.5) & (fx <= beam_angles.size - 0.5) & (rr >= cfg.range_min_m) & (
        rr <= r_max
    )
    map_x = np.where(inside, fx, -10.0).astype(np.float32)
    map_y = np.where(inside, fy, -10.0).astype(np.float32)
    return FanMaps(
        map_x=map_x,
        map_y=map_y,
        map_nearest=cv2.convertMaps(map_x, map_y, cv2.CV_16SC2, nninterpolation=True)[0],
        mask=inside,
        mask_u8=inside.astype(np.uint8) * np.uint8(255),
        px_per_m=scale,
        apex=(W / 2.0 - 0.5, H - 0.5),
    )


def fan_image(
    polar_u8: NDArray[np.uint8], map_x: NDArray[np.float32], map_y: NDArray[np.float32]
) -> NDArray[np.uint8]:
    """The fan image of a polar image through the maps of :func:`fan_maps` (bilinear,
    black outside the fan)."""
    return cv2.remap(polar_u8, map_x, map_y, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)  # fmt: skip


def color_fan(
    fan: NDArray[np.uint8], colormap: str, mask_u8: NDArray[np.uint8] | None = None
) -> NDArray[np.uint8]:
    """``fan`` through the OpenCV colour map ``colormap`` (H, W, 3) BGR; black outside
    ``mask_u8`` when given."""
    rgb = cv2.applyColorMap(fan, getattr(cv2, f"COLORMAP_{colormap.upper()}"))
    if mask_u8 is not None:
        rgb = cv2.bitwise_and(rgb, rgb, mask=mask_u8)
    return rgb


def image_2013(
    pts_sonar: NDArray[np.float64], labels: NDArray[np.int32], cfg: SonarConfig
) -> tuple[NDArray[np.uint8], NDArray[np.int16], tuple[float, float]]:
    """The paper's image (DeMarco et al. 2013, §sonar): drop z, scale x and y by
    ``px_per_m_2013`` (10 px/m), draw the points with the apex at the top-left pixel,
    Gaussian-blur, then draw the fan boundaries in white.

    ``layout_2013="port-edge"`` (default) measures bearings from the port edge of the fan
    (θ' = θ + fov/2) so the whole fan (fov ≤ 90°) lies in the image: column = s·r·cos θ',
    row = s·r·sin θ'. ``"literal"``: column = s·x, row = s·y, as the projection reads;
    the port half (y < 0) falls outside the image. Returns (image, labels, apex (col, row)).
    """
    spec = cfg.sonar_spec
    s = cfg.px_per_m_2013
    half = math.radians(spec.fov_h_deg) / 2.0
    R = cfg.range_max_m
    x = pts_sonar[:, 0]
    y = pts_sonar[:, 1]
    if cfg.layout_2013 == "port-edge":
        c, sn = math.cos(half), math.sin(half)
        u = s * (x * c - y * sn)  # rotate by +half: port edge onto the image x axis
        v = s * (x * sn + y * c)
        fov = 2.0 * half
        W = math.ceil(s * R) + 1
        H = math.ceil(s * R * (math.sin(fov) if fov < math.pi / 2 else 1.0)) + 1
        edge_ends = [(s * R, 0.0), (s * R * math.cos(fov), s * R * math.sin(fov))]
    else:
        u = s * x
        v = s * y
        W = math.ceil(s * R) + 1
        H = math.ceil(s * R * math.sin(half)) + 1
        edge_ends = [
            (s * R * math.cos(half), -s * R * math.sin(half)),
            (s * R * math.cos(half), s * R * math.sin(half)),
        ]
    img = np.zeros((H, W), dtype=np.uint8)
    lab = np.full((H, W), -1, dtype=np.int16)
    col = np.round(u).astype(np.int64)
    row = np.round(v).astype(np.int64)
    ok = (col >= 0) & (col < W) & (row >= 0) & (row < H)
    img[row[ok], col[ok]] = 255
    lab[row[ok], col[ok]] = labels[ok]
    k = cfg.blur_ksize_2013
    if k > 1:
        img = cv2.GaussianBlur(img, (k, k), cfg.blur_sigma_2013)
    for ex, ey in edge_ends:
        cv2.line(img, (0, 0), (round(ex), round(ey)), 255, 1, lineType=cv2.LINE_8)
    return img, lab, (0.0, 0.0)
