"""What an imaging sonar computes once per configuration: its :class:`SonarGeometry`.

The **sonar frame** is FRD-like — x along the sonar axis, y to starboard, z down. A ray at
beam angle θ (> 0 starboard) and elevation φ (> 0 down) has direction
(cos φ cos θ, cos φ sin θ, sin φ) there. The mount rotates the sonar frame into the
vehicle body frame FRD by yaw (about z) after a downward tilt (a pitch of −tilt).

Precomputed: the ray fan (``rays_per_beam`` elevation slices of equal width δφ, each ray
their centre, and ``rays_per_beam_azimuth`` rays across each beam); each ray's weight
b_v(φ)²·ΔΩ (vertical beam pattern, two-way, times the solid angle ΔΩ = cos φ·δθ·δφ it stands
for); the range bins; the horizontal beam-pattern and pulse kernels; TVG, source level and
gain per range bin, linear and in log display units; the speckle tables; the display level
of an echo-free image; and the scan-conversion maps of the fan (:mod:`.fan`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.frames import rotation_zyx
from uhrisim.sensors.sonar.acoustics import (
    beam_pattern_gaussian,
    horizontal_beam_kernel,
    range_blur_kernel,
)
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.fan import fan_maps
from uhrisim.sensors.sonar.polar import floor_level, speckle_lut


def mount_rotation(tilt_deg: float, yaw_deg: float) -> NDArray[np.float64]:
    """Rotation sonar frame → vehicle body FRD: yaw (about z, > 0 starboard) after a tilt
    (pitch −tilt about y, so tilt > 0 points the sonar axis down): ZYX Euler angles
    (roll 0, pitch −tilt, yaw) as in :func:`uhrisim.core.frames.rotation_zyx`."""
    return rotation_zyx(0.0, -math.radians(tilt_deg), math.radians(yaw_deg))


def mounted_pose(
    position_ned: NDArray[np.float64], rotation_body_to_ned: NDArray[np.float64],
    mount_position_frd: NDArray[np.float64], mount_rotation_to_body: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A sensor's origin (NED, m) and rotation sensor → NED, for a vehicle pose (position
    NED, rotation body FRD → NED) and the sensor's mount (position in the body FRD frame,
    rotation sensor → body)."""
    p = np.asarray(position_ned, dtype=float).reshape(3)
    R = np.asarray(rotation_body_to_ned, dtype=float).reshape(3, 3)
    return p + R @ mount_position_frd, R @ mount_rotation_to_body


@dataclass(frozen=True)
class SonarGeometry:
    """Everything precomputed once per config (ray fan, weights, kernels, maps); angles in
    radians, ranges in metres, directions in the sonar frame."""

    beam_angles: NDArray[np.float64]
    ray_az: NDArray[np.float64]
    ray_el: NDArray[np.float64]
    dirs_sonar: NDArray[np.float64]
    dirs_sonar_cols: NDArray[np.float64]  # the same, (3, N) contiguous
    ray_beam: NDArray[np.int64]
    ray_weight: NDArray[np.float64]
    dphi: float
    bin_centres: NDArray[np.float64]
    beam_kernel: NDArray[np.float32]
    range_kernel: NDArray[np.float32]
    signal_gain: NDArray[np.float32]  # (n_bins, 1) intensity re SL → display units
    map_x: NDArray[np.float32]
    map_y: NDArray[np.float32]
    fan_mask: NDArray[np.bool_]
    fan_mask_u8: NDArray[np.uint8]
    map_nearest: NDArray[np.int16]  # (H, W, 2) integer (beam, bin) per fan pixel
    fan_scale: float
    fan_apex: tuple[float, float]
    speckle_lut: NDArray[np.float32]
    noise_rel: float  # noise floor relative to the source level (linear)
    row_offset: NDArray[np.float32]  # (n_bins, n_beams) 1 + k·ln(TVG·SL·gain/top)
    log_speckle_lut: NDArray[np.float32]  # k·ln(speckle factor), 256 entries
    k_ln: float  # display units per natural-log unit: 10/(ln 10 · dynamic range)
    floor_level: NDArray[np.float32]  # (n_bins, n_beams) display level of an echo-free cell


def sonar_geometry(cfg: SonarConfig) -> SonarGeometry:
    """Precompute the ray fan, weights, kernels, TVG/display curves and scan-conversion
    maps of ``cfg`` (see the module docstring)."""
    spec = cfg.sonar_spec
    n_beams = spec.n_beams
    half_fov = math.radians(spec.fov_h_deg) / 2.0
    beam_angles = np.linspace(-half_fov, half_fov, n_beams)
    dtheta = beam_angles[1] - beam_angles[0]
    sub = cfg.rays_per_beam_azimuth
    offsets = ((np.arange(sub) + 0.5) / sub - 0.5) * dtheta
    ray_az_plane = (beam_angles[:, None] + offsets[None, :]).ravel()
    beam_of_az = np.repeat(np.arange(n_beams), sub)
    span = math.radians(spec.beam_width_v_deg) * cfg.elevation_span
    n_el = cfg.rays_per_beam
    dphi = span / n_el  # each ray is the centre of an equal elevation slice
    el = -span / 2.0 + (np.arange(n_el) + 0.5) * dphi
    ray_el = np.repeat(el, ray_az_plane.size)
    ray_az = np.tile(ray_az_plane, n_el)
    ray_beam = np.tile(beam_of_az, n_el).astype(np.int64)
    ce = np.cos(ray_el)
    dirs = np.stack([ce * np.cos(ray_az), ce * np.sin(ray_az), np.sin(ray_el)], axis=1)
    b_v = beam_pattern_gaussian(ray_el, math.radians(spec.beam_width_v_deg))
    solid_angle = ce * (dtheta / sub) * dphi
    ray_weight = b_v * b_v * solid_angle

    n_bins = cfg.n_bins
    bin_centres = cfg.range_min_m + (np.arange(n_bins) + 0.5) * cfg.bin_m
    beam_kernel = horizontal_beam_kernel(
        dtheta, math.radians(spec.beam_width_h_deg), sidelobe_db=cfg.sidelobe_db
    )
    rk = range_blur_kernel(cfg.bin_m, cfg.pulse_m)
    if rk.size > 1:  # drop negligible tails (keeps the convolution short)
        keep = rk >= 1e-3 * rk.max()
        nz = np.flatnonzero(keep)
        trim = min(int(nz[0]), rk.size - 1 - int(nz[-1]))
        rk = rk[trim : rk.size - trim]
        rk = (rk / rk.sum()).astype(np.float32)

    alpha = cfg.alpha_db_per_m
    r = np.maximum(bin_centres, 0.5 * cfg.bin_m)
    if cfg.tvg:
        tvg_db = cfg.tvg_spreading_db_per_decade * np.log10(r) + 2.0 * alpha * r
    else:
        tvg_db = np.zeros_like(r)
    base = cfg.gain_db - cfg.display_top_db + tvg_db
    signal_gain = (10.0 ** ((base + cfg.source_level_db) / 10.0)).astype(np.float32)[:, None]
    # The same mapping in the log domain (ImagingSonar._physical_polar): with I = echo re SL,
    # polar = 1 + k·ln((I + NL/SL)·TVG·10^((SL + gain − top)/10)·speckle).
    k_ln = 10.0 / math.log(10.0) / cfg.dynamic_range_db
    noise_rel = 10.0 ** ((cfg.noise_floor_db - cfg.source_level_db) / 10.0)
    row_off = 1.0 + k_ln * math.log(10.0) * (base + cfg.source_level_db) / 10.0
    row_offset = np.repeat(row_off.astype(np.float32)[:, None], spec.n_beams, axis=1)
    speckle = speckle_lut()

    fan = fan_maps(cfg, beam_angles)

    return SonarGeometry(
        beam_angles=beam_angles,
        ray_az=ray_az,
        ray_el=ray_el,
        dirs_sonar=dirs,
        dirs_sonar_cols=np.ascontiguousarray(dirs.T),
        ray_beam=ray_beam,
        ray_weight=ray_weight,
        dphi=dphi,
        bin_centres=bin_centres,
        beam_kernel=beam_kernel,
        range_kernel=rk,
        signal_gain=signal_gain,
        map_x=fan.map_x,
        map_y=fan.map_y,
        fan_mask=fan.mask,
        fan_mask_u8=fan.mask_u8,
        map_nearest=fan.map_nearest,
        fan_scale=fan.px_per_m,
        fan_apex=fan.apex,
        speckle_lut=speckle,
        noise_rel=noise_rel,
        row_offset=row_offset,
        log_speckle_lut=(k_ln * np.log(speckle.astype(np.float64))).astype(np.float32),
        k_ln=k_ln,
        floor_level=floor_level(beam_kernel, rk, noise_rel, k_ln, row_offset),
    )
