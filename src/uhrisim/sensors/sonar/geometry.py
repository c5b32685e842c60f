"""What an imaging sonar computes once per configuration: its :class:`SonarGeometry`.

The **sonar frame** is FRD-like — x along the sonar axis, y to starboard, z down. A ray at
beam angle θ (> 0 starboard) and elevation φ (> 0 down) has direction
(cos φ cos θ, cos φ sin θ, sin φ) there. The mount rotates the sonar frame into the
vehicle body frame FRD by yaw (about z) after a downward tilt (a pitch of −tilt).

Precomputed: the ray fan (``rays_per_beam`` elevation slices of equal width δφ, each ray
their centre, and ``rays_per_beam_azimuth`` rays across each beam); each ray's weight
b_v(φ)²·D(θ)·ΔΩ (vertical beam pattern, two-way, element directivity across the fan,
times the solid angle ΔΩ = cos φ·δθ·δφ it stands for, δθ the beam's own share of the
fan); the range bins; the horizontal beam patterns (power and amplitude), one per run of
beams of about one width (:func:`beam_blocks`: a steered beam at θ is 1/cos θ wider) and
the pulse kernels; the diffuse intensity of every range row (noise, volume reverberation,
post-TVG noise); TVG (held near, capped far), source level and gain per range bin, linear
and in log display units; and the scan-conversion maps of the fan (:mod:`.fan`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.frames import rotation_zyx
from uhrisim.sensors.sonar.acoustics import (
    ambient_noise_band_db,
    beam_amplitude_kernel,
    beam_pattern_gaussian,
    directivity_index_db,
    element_directivity,
    gaussian_pattern_integral,
    horizontal_beam_kernel,
    range_blur_kernel,
)
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.fan import fan_maps

#: Neighbouring beams whose widths (in beam spacings) differ by at most this factor share
#: one horizontal pattern (a :class:`BeamBlock`), that of their middle beam: each beam's
#: pattern is within 4 % of its own width (exact on the axis), far finer than the 1/cos θ
#: broadening it stands for.
BLOCK_WIDTH_RATIO = 1.04


@dataclass(frozen=True)
class BeamBlock:
    """Beams [start, stop) formed through one horizontal pattern of −3 dB ``width`` (in
    beam spacings), sampled across beams: ``power`` (peak 1, side lobes at the preset's
    level) and ``amplitude`` (signed, amplitude² = power)."""

    start: int
    stop: int
    width: float
    power: NDArray[np.float32]
    amplitude: NDArray[np.float32]


def beam_widths(cfg: SonarConfig, beam_angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each beam's −3 dB width in units of its own beam spacing.

    Steered (a line array, beams formed electronically): the aperture seen from θ is
    L·cos θ, so the beam widens to W/cos θ (W the width on the axis) while the spacing is
    the native one. A lens (ARIS): each beam is as wide as its share of the fan, so the
    width in spacings is W over the mean spacing everywhere."""
    spec = cfg.sonar_spec
    width = math.radians(spec.beam_width_h_deg)
    mean_spacing = float(beam_angles[-1] - beam_angles[0]) / (beam_angles.size - 1)
    if not cfg.steering:
        return np.full(beam_angles.size, width / mean_spacing)
    return width / (np.cos(beam_angles) * np.gradient(beam_angles))


def beam_blocks(cfg: SonarConfig, beam_angles: NDArray[np.float64]) -> tuple[BeamBlock, ...]:
    """The beams grouped into runs whose widths fall in one band of ratio
    :data:`BLOCK_WIDTH_RATIO` above the narrowest beam's (bands of log width: symmetric
    about the axis), each run with the pattern of its middle beam's width (on the axis,
exactly the axis beam's): one run for a lens
    or a narrow fan, ~45 for a 130° steered fan, whose edge beams are 2.4× wider."""
    widths = beam_widths(cfg, beam_angles)
    band = np.floor(np.log(widths / widths.min()) / math.log(BLOCK_WIDTH_RATIO) + 1e-9)
    cuts = np.flatnonzero(np.diff(band)) + 1
    blocks = []
    for a, b in zip([0, *cuts.tolist()], [*cuts.tolist(), widths.size], strict=True):
        w = float(widths[(a + b) // 2])
        args = (1.0, w, cfg.beam_sidelobe_db, cfg.n_sidelobes)  # in beam spacings
        blocks.append(
            BeamBlock(a, b, w, horizontal_beam_kernel(*args), beam_amplitude_kernel(*args))
        )
    return tuple(blocks)


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
    beam_spacing: float  # mean spacing of the beam centres, rad
    ray_az: NDArray[np.float64]
    ray_el: NDArray[np.float64]
    dirs_sonar: NDArray[np.float64]
    dirs_sonar_cols: NDArray[np.float64]  # the same, (3, N) contiguous
    ray_beam: NDArray[np.int64]
    ray_weight: NDArray[np.float64]
    dphi: float
    bin_centres: NDArray[np.float64]
    beam_kernel: NDArray[np.float32]  # power pattern across beams on the axis (peak 1)
    beam_blocks: tuple[BeamBlock, ...]  # the patterns beam by beam (steered beams widen)
    range_kernel: NDArray[np.float32]  # power envelope along range (sum 1)
    beam_amp: NDArray[np.float32]  # signed amplitude pattern, beam_amp² = beam_kernel
    range_amp: NDArray[np.float32]  # amplitude envelope, range_amp² = range_kernel
    signal_gain: NDArray[np.float32]  # (n_bins, 1) intensity re SL → display units
    map_x: NDArray[np.float32]
    map_y: NDArray[np.float32]
    fan_mask: NDArray[np.bool_]
    fan_mask_u8: NDArray[np.uint8]
    map_nearest: NDArray[np.int16]  # (H, W, 2) integer (beam, bin) per fan pixel
    fan_scale: float
    fan_apex: tuple[float, float]
    noise_rel: float  # receiver + ambient noise at the beam output re SL (linear)
    diffuse_static: NDArray[np.float64]  # (n_bins,) noise + reverb + post-TVG noise re SL
    leak: float  # far side lobes: share of the beam-averaged row echo every beam receives
    tvg_db: NDArray[np.float64]  # (n_bins,) TVG applied, dB
    row_offset: NDArray[np.float32]  # (n_bins, n_beams) 1 + k·ln(TVG·SL·gain/top)
    k_ln: float  # display units per natural-log unit: 10/(ln 10 · dynamic range)
    floor_level: NDArray[np.float32]  # (n_bins, n_beams) mean display level, no echo


def sonar_geometry(cfg: SonarConfig) -> SonarGeometry:
    """Precompute the ray fan, weights, kernels, TVG/display curves and scan-conversion
    maps of ``cfg`` (see the module docstring)."""
    spec = cfg.sonar_spec
    n_beams = spec.n_beams
    half_fov = math.radians(spec.fov_h_deg) / 2.0
    beam_angles = spec.beam_angles_rad  # native: evenly spaced, or the maker's table
    dtheta = float(beam_angles[-1] - beam_angles[0]) / (n_beams - 1)  # mean spacing
    local = np.gradient(beam_angles)  # each beam's own spacing (its share of the fan)
    sub = cfg.rays_per_beam_azimuth
    offsets = ((np.arange(sub) + 0.5) / sub - 0.5)[None, :] * local[:, None]
    ray_az_plane = (beam_angles[:, None] + offsets).ravel()
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
    solid_angle = ce * (np.tile(np.repeat(local, sub), n_el) / sub) * dphi
    directivity = element_directivity(ray_az, half_fov, cfg.edge_loss_db)
    ray_weight = b_v * b_v * directivity * solid_angle

    n_bins = cfg.n_bins
    bin_centres = cfg.range_min_m + (np.arange(n_bins) + 0.5) * cfg.bin_m
    beam_kernel = horizontal_beam_kernel(
        dtheta, math.radians(spec.beam_width_h_deg), cfg.beam_sidelobe_db, cfg.n_sidelobes
    )
    beam_amp = beam_amplitude_kernel(
        dtheta, math.radians(spec.beam_width_h_deg), cfg.beam_sidelobe_db, cfg.n_sidelobes
    )
    rk = range_blur_kernel(cfg.bin_m, cfg.pulse_m)
    if rk.size > 1:  # drop negligible tails (keeps the convolution short)
        keep = rk >= 1e-3 * rk.max()
        nz = np.flatnonzero(keep)
        trim = min(int(nz[0]), rk.size - 1 - int(nz[-1]))
        rk = rk[trim : rk.size - trim]
        rk = (rk / rk.sum()).astype(np.float32)
    range_amp = np.sqrt(rk).astype(np.float32)

    alpha = cfg.alpha_db_per_m
    r = np.maximum(bin_centres, 0.5 * cfg.bin_m)
    if cfg.tvg:  # imperfect: held below tvg_min_range_m, capped at the amplifier's range
        r_tvg = np.maximum(r, cfg.tvg_min_range_m)
        tvg_db = cfg.tvg_spreading_db_per_decade * np.log10(r_tvg) + 2.0 * alpha * r_tvg
        tvg_db = np.minimum(tvg_db, cfg.tvg_cap_db)
    else:
        tvg_db = np.zeros_like(r)
    base = cfg.gain_db - cfg.display_top_db + tvg_db
    signal_gain = (10.0 ** ((base + cfg.source_level_db) / 10.0)).astype(np.float32)[:, None]
    # The mapping in the log domain (ImagingSonar._physical_polar): with I = intensity re
    # SL, polar = 1 + k·ln(I·TVG·10^((SL + gain − top)/10)).
    k_ln = 10.0 / math.log(10.0) / cfg.dynamic_range_db
    row_off = 1.0 + k_ln * math.log(10.0) * (base + cfg.source_level_db) / 10.0
    row_offset = np.repeat(row_off.astype(np.float32)[:, None], spec.n_beams, axis=1)
    noise_rel, diffuse_static = diffuse_terms(cfg, r, tvg_db, dtheta, float(beam_kernel.sum()))
    leak = 0.0 if cfg.far_sidelobe_db is None else 10.0 ** (cfg.far_sidelobe_db / 10.0)
    floor = row_off + k_ln * np.log(np.maximum(diffuse_static, 1e-300))

    fan = fan_maps(cfg, beam_angles)

    return SonarGeometry(
        beam_angles=beam_angles,
        beam_spacing=dtheta,
        ray_az=ray_az,
        ray_el=ray_el,
        dirs_sonar=dirs,
        dirs_sonar_cols=np.ascontiguousarray(dirs.T),
        ray_beam=ray_beam,
        ray_weight=ray_weight,
        dphi=dphi,
        bin_centres=bin_centres,
        beam_kernel=beam_kernel,
        beam_blocks=beam_blocks(cfg, beam_angles),
        range_kernel=rk,
        beam_amp=beam_amp,
        range_amp=range_amp,
        signal_gain=signal_gain,
        map_x=fan.map_x,
        map_y=fan.map_y,
        fan_mask=fan.mask,
        fan_mask_u8=fan.mask_u8,
        map_nearest=fan.map_nearest,
        fan_scale=fan.px_per_m,
        fan_apex=fan.apex,
        noise_rel=noise_rel,
        diffuse_static=diffuse_static,
        leak=leak * float(beam_kernel.sum()),
        tvg_db=tvg_db,
        row_offset=row_offset,
        k_ln=k_ln,
        floor_level=np.repeat(floor.astype(np.float32)[:, None], spec.n_beams, axis=1),
    )


def diffuse_terms(
    cfg: SonarConfig,
    r: NDArray[np.float64],
    tvg_db: NDArray[np.float64],
    dtheta: float,
    beam_power_sum: float,
) -> tuple[float, NDArray[np.float64]]:
    """(noise at the beam output re SL, the static diffuse intensity per range row re SL).

    Noise: receiver self-noise plus, when ``ambient_noise``, the Wenz-style ambient band
    level less the beam's directivity index. Volume reverberation of a cell (range ``r``,
    one beam spacing ``dtheta`` wide, one bin deep): S_v·V·R⁻⁴·10^(−2αR/10) with
    V = R²·δθ·Ψ_v·Δr (Ψ_v the two-way vertical pattern's equivalent width), summed
    through the horizontal beam pattern (``beam_power_sum``). Post-TVG noise: its display
    level referred back to the input through the TVG, ``post − SL − TVG(R)``."""
    spec = cfg.sonar_spec
    noise_lin = 10.0 ** (cfg.noise_floor_db / 10.0)
    if cfg.ambient_noise:
        di = directivity_index_db(
            math.radians(spec.beam_width_h_deg), math.radians(spec.beam_width_v_deg)
        )
        ambient = ambient_noise_band_db(spec.frequency_hz, cfg.bandwidth_hz, cfg.sea_state)
        noise_lin += 10.0 ** ((ambient - di) / 10.0)
    sl = 10.0 ** (cfg.source_level_db / 10.0)
    d = np.full(r.shape, noise_lin / sl)
    if cfg.volume_scattering_db is not None:
        psi_v = gaussian_pattern_integral(math.radians(spec.beam_width_v_deg))
        loss = 10.0 ** (-2.0 * cfg.alpha_db_per_m * r / 10.0)
        sv = 10.0 ** (cfg.volume_scattering_db / 10.0)
        d += sv * dtheta * psi_v * cfg.bin_m * beam_power_sum * loss / (r * r)
    if cfg.post_tvg_noise_db is not None:
        d += 10.0 ** ((cfg.post_tvg_noise_db - cfg.source_level_db - tvg_db) / 10.0)
    return noise_lin / sl, d


def surface_rows(
    cfg: SonarConfig,
    r: NDArray[np.float64],
    depth_m: float,
    axis_depression_rad: float,
    dtheta: float,
    beam_power_sum: float,
) -> NDArray[np.float64] | None:
    """Surface (boundary) reverberation per range row re SL for a sonar ``depth_m`` below
    the surface whose axis points ``axis_depression_rad`` below the horizontal; None when
    off or out of the water. A Lambert surface (μ_s = ``surface_scattering_db``) seen at
    slant range R > h covers R·δθ·Δr per beam and bin, at incidence cos β = h/R from its
    normal and elevation asin(h/R) above the horizontal, weighted by the two-way vertical
    pattern there: μ_s·(h/R)²·R·δθ·Δr·b_v²·R⁻⁴·10^(−2αR/10), summed through the horizontal
    beam pattern. (Level sonar rows only: roll is ignored.)"""
    if cfg.surface_scattering_db is None or depth_m <= 0.0:
        return None
    spec = cfg.sonar_spec
    lit = r > depth_m
    out = np.zeros_like(r)
    rr = r[lit]
    off_axis = np.arcsin(depth_m / rr) + axis_depression_rad
    b_v = beam_pattern_gaussian(off_axis, math.radians(spec.beam_width_v_deg))
    mu = 10.0 ** (cfg.surface_scattering_db / 10.0)
    loss = 10.0 ** (-2.0 * cfg.alpha_db_per_m * rr / 10.0)
    out[lit] = (mu * (depth_m / rr) ** 2 * rr * dtheta * cfg.bin_m * b_v * b_v * loss
                * beam_power_sum / rr**4)  # fmt: skip
    return out
