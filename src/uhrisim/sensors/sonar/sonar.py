"""The forward-looking imaging sonar: rays → polar image → fan image, per ping.

Frames (``docs/conventions.md``): the **sonar frame** is FRD-like — x along the sonar axis,
y to starboard, z down. A ray at beam angle θ (> 0 starboard) and elevation φ (> 0 down)
has direction (cos φ cos θ, cos φ sin θ, sin φ) there. The mount rotates the sonar frame
into the vehicle body frame FRD by yaw (about z) after a downward tilt (a pitch of −tilt);
the vehicle rotation then takes it to world NED.

Physical image formation (``mode="physical"``), per ray that hits at slant range R with
incidence β on a surface of Lambert coefficient μ (``shared/reference/sonar.md``):

    EL = SL − 2·TL(R) + TS,     TL = 20 log10 R + αR,     TS = 10 log10(μ·cos²β·A)

A ray stands for the solid angle ΔΩ = cos φ·δθ·δφ, i.e. a surface patch A = R²ΔΩ/cos β,
so its echo intensity (re SL) is ``b_v(φ)²·μ·cos β·ΔΩ·R⁻²·10^(−2αR/10)`` with b_v the
vertical (elevation) power pattern, two-way. Each echo is spread evenly over the range
footprint of its elevation slice, R·δφ·tan β (so a floor stays continuous however few
rays are cast), and summed into (range bin, beam) cells — rays stop at the first hit, so
shadows come only from the geometry. The
horizontal beam pattern (sinc², ~1° over ~0.18° spacing) is a convolution along the
beam axis, the pulse length a convolution along range. Then the noise floor is added,
Rayleigh speckle multiplies the intensity (unit exponential draws: Rayleigh amplitude), TVG
(+40 log R + 2αR by default) and gain are applied and the level is log-compressed:
``polar = clip(1 + (L − display_top_db)/dynamic_range_db, 0, 1)``.

2013 mode (``mode="2013"``, DeMarco et al. 2013): hit points projected onto the sonar's
x–y plane, ×10 px/m, apex at the top-left pixel, Gaussian blur, white fan boundary lines.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Protocol

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rotation_zyx, row_dots
from uhrisim.sensors.sonar.acoustics import (
    beam_pattern_gaussian,
    horizontal_beam_kernel,
    range_blur_kernel,
)
from uhrisim.sensors.sonar.config import COLORMAPS, SonarConfig

log = logging.getLogger(__name__)

#: A ping is refused (ConfigError) when more than this fraction of rays hit closer than
#: :data:`INSIDE_GEOMETRY_RANGE_M`: the sonar sits inside (or flush against) geometry.
INSIDE_GEOMETRY_FRACTION = 0.5
INSIDE_GEOMETRY_RANGE_M = 0.02

#: Cap on tan β when spreading a ray's echo over its range footprint (β ≈ 85°).
MAX_FOOTPRINT_TAN = 12.0

_LN10_OVER_10 = math.log(10.0) / 10.0

#: Echo-free row gaps shorter than this (range bins) are filtered with their neighbours
#: rather than split into a separate OpenCV call (exact either way; fewer calls).
_ROW_RUN_MERGE_GAP = 16


class RayCaster(Protocol):
    """What the sonar needs from a ray caster (``uhrisim.world.scene.Scene.raycaster()``)."""

    def cast(
        self,
        origins: NDArray[np.float64],
        directions: NDArray[np.float64],
        max_range: float,
        exclude: frozenset[str] = ...,
    ) -> Any:
        """First hits of N rays from one shared origin (the sonar's; ``origins`` has shape
        (3,)) along ``directions`` (N, 3): hits with ``distance`` (N,) inf on miss,
        ``label`` (N,) int −1 on miss, ``normal`` (N, 3) unit, ``reflectivity`` (N,)
        Lambert μ."""
        ...


@dataclass(frozen=True)
class SonarCloud:
    """The paper's ``sonar_cloud`` message: all rays of one ping, plane-major.

    Plane i is the elevation angle ``-vert_height/2 + (i + 0.5)·vert_resolution`` (each
    plane is the centre of an equal elevation slice; plane 0 is the uppermost). Within a
    plane, points go from ``angle_min`` (port) to ``angle_max`` (starboard) in steps of
    ``angle_increment``. x, y, z are in the sonar frame (metres); rays that hit nothing
    inside the window are NaN. ``intensity`` is each ray's own echo
    level on the display scale 0…1 (0 for misses). Angles in radians, ranges in metres.
    """

    num_planes: int
    num_points_per_plane: int
    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    vert_height: float
    vert_resolution: float
    x: NDArray[np.float32]
    y: NDArray[np.float32]
    z: NDArray[np.float32]
    intensity: NDArray[np.float32]


@dataclass(frozen=True)
class SonarPing:
    """One ping.

    Attributes:
        t: simulation time of the ping, s.
        position_ned: sonar origin in world NED, m.
        rotation_ned_from_sonar: 3×3 rotation taking sonar-frame vectors to NED.
        beam_angles_rad: (n_beams,) beam centre angles, > 0 starboard.
        bin_ranges_m: (n_bins,) range-bin centres, m.
        polar: (n_bins, n_beams) float32 display intensity 0…1 (row 0 = nearest bin);
            physical mode: after beam pattern, speckle, noise, TVG and log compression;
            2013 mode: hit occupancy (1 where a ray hit in the cell).
        polar_u8: ``polar`` as uint8 0…255.
        fan_u8: Cartesian image. Physical mode: apex at the bottom centre, forward up,
            starboard right, black outside the fan. 2013 mode: the paper's image.
        fan_px_per_m: pixels per metre of ``fan_u8``.
        fan_apex_px: (column, row) of the apex in ``fan_u8`` (pixel-centre coordinates).
        fan_rgb: colour-mapped ``fan_u8`` (H, W, 3) BGR, when ``config.colormap`` is set.
        fan_layout: ``"bottom-centre"`` (physical), ``"port-edge"`` or ``"literal"`` (2013).
        fan_half_fov_rad: half the horizontal field of view (for the 2013 layouts).
        label_polar: (n_bins, n_beams) int16: the scene label of the strongest return in
            each cell (cells reached only by a ray's range footprint take the label of the
            nearest ray centre along range), −1 where no echo arrived. With
            ``config.labels`` off: all −1, one read-only array shared by every ping.
        label_fan: label image aligned with ``fan_u8`` (−1 none; read-only and shared
            with labels off).
        form_fan_images: forms (fan_u8, label_fan, fan_rgb). The three fan images are
            formed on first access of any of them (scan conversion is a large share of a
            small ping; a simulation whose hooks never look at the fan never pays for it).
        cloud: the paper's ``sonar_cloud`` with intensities.
        hit_points_sonar, hit_points_ned: (M, 3) hit points of the rays that hit inside the
            window, sonar frame and NED, m.
        hit_labels: (M,) int32 scene labels of those hits.
        mode: ``"physical"`` or ``"2013"``.
    """

    t: float
    position_ned: NDArray[np.float64]
    rotation_ned_from_sonar: NDArray[np.float64]
    beam_angles_rad: NDArray[np.float64]
    bin_ranges_m: NDArray[np.float64]
    polar: NDArray[np.float32]
    polar_u8: NDArray[np.uint8]
    fan_px_per_m: float
    fan_apex_px: tuple[float, float]
    label_polar: NDArray[np.int16]
    cloud: SonarCloud
    hit_points_sonar: NDArray[np.float64]
    hit_points_ned: NDArray[np.float64]
    hit_labels: NDArray[np.int32]
    form_fan_images: Callable[[], tuple[Any, Any, Any]] = field(repr=False, compare=False)
    mode: str = "physical"
    fan_layout: str = "bottom-centre"
    fan_half_fov_rad: float = 0.0

    @cached_property
    def _fan_images(self) -> tuple[NDArray[np.uint8], NDArray[np.int16], NDArray[np.uint8] | None]:
        return self.form_fan_images()

    @property
    def fan_u8(self) -> NDArray[np.uint8]:
        """The Cartesian fan image (see the class docstring); formed on first access."""
        return self._fan_images[0]

    @property
    def label_fan(self) -> NDArray[np.int16]:
        """Label image aligned with ``fan_u8`` (−1 none); formed on first access."""
        return self._fan_images[1]

    @property
    def fan_rgb(self) -> NDArray[np.uint8] | None:
        """Colour-mapped ``fan_u8`` (H, W, 3) BGR when ``config.colormap`` is set;
        formed on first access."""
        return self._fan_images[2]

    def fan_pixels_to_sonar(self, px: NDArray[np.float64]) -> NDArray[np.float64]:
        """Sonar-frame points (N, 3), metres, for fan pixel coordinates ``px`` (N, 2) as
        (column, row). Imaging sonars do not measure elevation: the points are placed in
        the sonar's x–y plane (z = 0)."""
        p = np.asarray(px, dtype=float).reshape(-1, 2)
        s = self.fan_px_per_m
        u = p[:, 0] - self.fan_apex_px[0]
        v = p[:, 1] - self.fan_apex_px[1]
        if self.fan_layout == "bottom-centre":
            x, y = -v / s, u / s
        elif self.fan_layout == "port-edge":
            c, sn = math.cos(self.fan_half_fov_rad), math.sin(self.fan_half_fov_rad)
            x, y = (u * c + v * sn) / s, (-u * sn + v * c) / s
        else:  # "literal"
            x, y = u / s, v / s
        return np.stack([x, y, np.zeros_like(x)], axis=1)

    def sonar_to_ned(self, pts_sonar: NDArray[np.float64]) -> NDArray[np.float64]:
        """World NED points for sonar-frame points (N, 3)."""
        return self.position_ned + np.asarray(pts_sonar, float) @ self.rotation_ned_from_sonar.T


def cloud_hits(cloud: SonarCloud) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The rays of a ``sonar_cloud`` that hit inside the window: sonar-frame points
    (M, 3, m) and their display intensity (M,, 0..1); the cloud lists every ray, NaN on
    a miss."""
    x, y, z = np.ravel(cloud.x), np.ravel(cloud.y), np.ravel(cloud.z)
    keep = np.isfinite(x)
    keep &= np.isfinite(y)
    keep &= np.isfinite(z)
    xyz = np.stack([x[keep], y[keep], z[keep]], -1).astype(float)  # few hits, many rays
    return xyz, np.ravel(cloud.intensity)[keep].astype(float)


def mount_rotation(tilt_deg: float, yaw_deg: float) -> NDArray[np.float64]:
    """Rotation sonar frame → vehicle body FRD: yaw (about z, > 0 starboard) after a tilt
    (pitch −tilt about y, so tilt > 0 points the sonar axis down): ZYX Euler angles
    (roll 0, pitch −tilt, yaw) as in :func:`uhrisim.core.frames.rotation_zyx`."""
    return rotation_zyx(0.0, -math.radians(tilt_deg), math.radians(yaw_deg))


@dataclass(frozen=True)
class _Geometry:
    """Everything precomputed once per config (ray fan, weights, kernels, maps)."""

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


def _log_level(
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


def _floor_level(
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
    _log_level(np.zeros_like(out), out, beam_kernel, range_kernel, noise_rel, k_ln, row_offset)
    return out


def _row_runs(cover: NDArray[np.bool_], pad: int, gap: int) -> list[tuple[int, int]]:
    """Half-open row ranges [start, stop) that hold every True row of ``cover`` widened by
    ``pad`` rows each side (clipped to the image); ranges closer than ``gap`` rows are
    merged. Rows outside the ranges are at least ``pad`` rows from any True row."""
    rows = np.flatnonzero(cover)
    if rows.size == 0:
        return []
    cut = np.flatnonzero(np.diff(rows) > 2 * pad + gap)
    starts = np.maximum(np.concatenate([rows[:1], rows[cut + 1]]) - pad, 0)
    stops = np.minimum(np.concatenate([rows[cut], rows[-1:]]) + pad + 1, cover.size)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def _read_only(a: NDArray[Any]) -> NDArray[Any]:
    """``a``, made read-only (an image shared by many pings)."""
    a.setflags(write=False)
    return a


def _uniform_bytes(rng: np.random.Generator, n: int) -> NDArray[np.uint8]:
    """``n`` independent uniform random bytes: the bytes of full-range 64-bit draws
    (several times faster than ``Generator.bytes``, which draws 32 bits at a time through
    the bounded-integer path)."""
    words = rng.integers(0, np.iinfo(np.uint64).max, (n + 7) // 8, np.uint64, endpoint=True)
    return words.view(np.uint8)[:n]


def _speckle_lut(bits: int = 8) -> NDArray[np.float32]:
    """Inverse CDF of the unit exponential at the 2^bits mid-quantiles, rescaled to mean 1:
    a uniform ``bits``-bit integer → a speckle factor on intensity (Rayleigh amplitude).

    With 8 bits the amplitude std/mean is 0.522 (continuous Rayleigh: 0.5227) and the
    heaviest draw is 6.2× the mean (a continuous draw exceeds that with probability 0.2 %).
    """
    n = 1 << bits
    u = (np.arange(n, dtype=np.float64) + 0.5) / n
    e = -np.log1p(-u)
    return (e / e.mean()).astype(np.float32)


class ImagingSonar:
    """A forward-looking imaging sonar bound to a config and a random Generator.

    ``ping(raycaster, position_ned, rotation_body_to_ned, t)`` casts the ray fan from the
    mount and forms the image. Everything that depends only on the config (ray
    directions, elevation weights, kernels, TVG curve, scan-conversion maps) is computed
    once here. The Generator is the only state that changes between pings (speckle);
    scratch buffers are reused between pings, so one instance must not ping from two
    threads at once (make one instance per thread). Arrays in a returned SonarPing are
    its own (never the scratch buffers).

    Cost per ping is O(rays + range bins × beams); see ``uhrisim bench sonar``.
    """

    def __init__(self, config: SonarConfig, rng: np.random.Generator) -> None:
        if not isinstance(config, SonarConfig):
            raise ConfigError(f"expected a SonarConfig, got {type(config).__name__}", "config")
        if not isinstance(rng, np.random.Generator):
            raise ConfigError(f"expected a numpy Generator, got {type(rng).__name__}", "rng")
        self.config = config
        self.rng = rng
        self.mount_rotation = mount_rotation(config.tilt_deg, config.yaw_deg)
        self.mount_position = np.asarray(config.mount_position_frd, dtype=float)
        # Two-way absorption per metre in natural-log units (the config derives α on access).
        self._two_alpha_ln = 2.0 * config.alpha_db_per_m * _LN10_OVER_10
        self.geometry = self._precompute()
        n_bins, n_beams = self.polar_shape
        # Per-instance scratch buffers, reused every ping (a ping is not re-entrant).
        self._scratch = {
            "raw": np.zeros((n_bins, n_beams), np.float32),
            "diff": np.zeros((n_bins + 1) * n_beams, np.float64),  # all zero between pings
            "integ": np.zeros((n_bins + 2, n_beams + 1), np.float64),
            "speckle": np.zeros((n_bins, n_beams), np.float32),
            "fg_energy": np.zeros(n_bins * n_beams, np.float64),
            "fg_total": np.zeros(n_bins * n_beams, np.float64),
            "fg_best": np.zeros(n_bins * n_beams, np.float64),
            "fg_label": np.full(n_bins * n_beams, -1, np.int16),
            "fg_mark": np.zeros(n_bins * n_beams, np.bool_),
            # Strongest echo per fan pixel for the label splat: all zero between uses. A
            # ping's fan is formed when first read, maybe on another thread: hence the lock.
            "fan_pmax": np.zeros(self.geometry.fan_mask.size, np.float64),
        }
        self._fan_pmax_lock = threading.Lock()
        # With labels off every ping shares these read-only "no label" images.
        self._unlabelled_polar = _read_only(np.full((n_bins, n_beams), -1, np.int16))
        self._unlabelled_fan = _read_only(np.full(self.geometry.fan_mask.shape, -1, np.int16))

    # -- precomputation --------------------------------------------------------------------
    def _precompute(self) -> _Geometry:
        cfg = self.config
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
        # The same mapping in the log domain (see _physical_polar): with I = echo re SL,
        # polar = 1 + k·ln((I + NL/SL)·TVG·10^((SL + gain − top)/10)·speckle).
        k_ln = 10.0 / math.log(10.0) / cfg.dynamic_range_db
        noise_rel = 10.0 ** ((cfg.noise_floor_db - cfg.source_level_db) / 10.0)
        row_off = 1.0 + k_ln * math.log(10.0) * (base + cfg.source_level_db) / 10.0
        row_offset = np.repeat(row_off.astype(np.float32)[:, None], spec.n_beams, axis=1)
        speckle_lut = _speckle_lut()

        # Scan conversion map (fan pixel → fractional (beam, bin) in the polar image).
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
        fx = (th - beam_angles[0]) / dtheta
        fy = (rr - cfg.range_min_m) / cfg.bin_m - 0.5
        inside = (np.abs(th) <= half_fov + 0.5 * dtheta) & (rr >= cfg.range_min_m) & (rr <= r_max)
        map_x = np.where(inside, fx, -10.0).astype(np.float32)
        map_y = np.where(inside, fy, -10.0).astype(np.float32)
        apex = (W / 2.0 - 0.5, H - 0.5)

        return _Geometry(
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
            map_x=map_x,
            map_y=map_y,
            fan_mask=inside,
            fan_mask_u8=inside.astype(np.uint8) * np.uint8(255),
            map_nearest=cv2.convertMaps(map_x, map_y, cv2.CV_16SC2, nninterpolation=True)[0],
            fan_scale=scale,
            fan_apex=apex,
            speckle_lut=speckle_lut,
            noise_rel=noise_rel,
            row_offset=row_offset,
            log_speckle_lut=(k_ln * np.log(speckle_lut.astype(np.float64))).astype(np.float32),
            k_ln=k_ln,
            floor_level=_floor_level(beam_kernel, rk, noise_rel, k_ln, row_offset),
        )

    # -- properties ------------------------------------------------------------------------
    @property
    def n_rays(self) -> int:
        """Rays cast per ping."""
        return int(self.geometry.dirs_sonar.shape[0])

    @property
    def polar_shape(self) -> tuple[int, int]:
        """(n_bins, n_beams)."""
        return self.config.n_bins, self.config.sonar_spec.n_beams

    @property
    def cast_window_m(self) -> tuple[float, float]:
        """Slant ranges (m) of hits that can put echo into the window: the window widened
        by the longest half footprint (0.5·MAX_FOOTPRINT_TAN·R·δφ) at each end, so the
        image does not fray at its near and far edges."""
        cfg = self.config
        k = 0.5 * MAX_FOOTPRINT_TAN * self.geometry.dphi
        return max(0.0, cfg.range_min_m * (1.0 - k)), cfg.range_max_m * (1.0 + k)

    def sonar_pose(
        self, position_ned: NDArray[np.float64], rotation_body_to_ned: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Sonar origin (NED, m) and rotation sonar → NED for a vehicle pose."""
        p = np.asarray(position_ned, dtype=float).reshape(3)
        R = np.asarray(rotation_body_to_ned, dtype=float).reshape(3, 3)
        return p + R @ self.mount_position, R @ self.mount_rotation

    # -- the ping --------------------------------------------------------------------------
    def ping(
        self,
        raycaster: RayCaster,
        position_ned: NDArray[np.float64],
        rotation_body_to_ned: NDArray[np.float64],
        t: float,
        exclude: frozenset[str] = frozenset(),
    ) -> SonarPing:
        """Cast the fan from the mount on a vehicle at ``position_ned`` (m, NED) with
        ``rotation_body_to_ned`` (vehicle FRD → NED) and form the image.

        Raises ConfigError (naming ``SonarConfig.mount_position_frd``) if the sonar sits
        inside geometry: below the sea floor or inside a watertight static mesh of the
        caster's scene, or, for any caster, when most rays hit at ~0 m.
        """
        g = self.geometry
        p_s, R_s = self.sonar_pose(position_ned, rotation_body_to_ned)
        dirs = g.dirs_sonar @ R_s.T
        inside = _inside_scene_geometry(raycaster, p_s)
        if inside is not None:
            raise ConfigError(
                f"sonar at NED {np.round(p_s, 3).tolist()} is inside geometry ({inside})",
                where="SonarConfig.mount_position_frd",
            )
        near_m, far_m = self.cast_window_m
        hits = raycaster.cast(p_s, dirs, far_m, exclude=exclude)  # one shared origin
        distance = np.asarray(hits.distance, dtype=np.float64)
        cos_all = np.abs(row_dots(np.asarray(hits.normal, np.float64), dirs))
        near = np.count_nonzero(distance < INSIDE_GEOMETRY_RANGE_M)
        if near > INSIDE_GEOMETRY_FRACTION * distance.size:
            raise ConfigError(
                f"sonar at NED {np.round(p_s, 3).tolist()} is inside geometry: "
                f"{near}/{distance.size} rays hit closer than {INSIDE_GEOMETRY_RANGE_M} m",
                where="SonarConfig.mount_position_frd",
            )
        valid = (distance >= near_m) & (distance < far_m)
        idx = np.flatnonzero(valid)
        r = distance[idx]
        cos_inc = cos_all[idx]
        mu = np.asarray(hits.reflectivity, dtype=np.float64)[idx]
        labels = np.asarray(hits.label)[idx].astype(np.int32)
        return self.form_image(t, p_s, R_s, idx, r, cos_inc, mu, labels)

    def ray_intensity(
        self,
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        cos_inc: NDArray[np.float64],
        mu: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Echo intensity of each hit ray relative to the source level (linear):
        ``w_ray·μ·cosβ·R⁻²·10^(−2αR/10)``, w_ray = b_v(φ)²·ΔΩ (see the module docstring)."""
        rr = np.maximum(r, 1e-3)
        w = self.geometry.ray_weight[idx]
        return w * mu * cos_inc * np.exp(-self._two_alpha_ln * rr) / (rr * rr)

    def form_image(
        self,
        t: float,
        position_ned: NDArray[np.float64],
        rotation_ned_from_sonar: NDArray[np.float64],
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        cos_inc: NDArray[np.float64],
        mu: NDArray[np.float64],
        labels: NDArray[np.int32],
    ) -> SonarPing:
        """Form a ping from the hits of rays ``idx`` (indices into the ray fan) at slant
        ranges ``r`` (m, inside the window) with |cos incidence| ``cos_inc``, Lambert μ
        ``mu`` and scene ``labels``. Pure apart from drawing speckle from ``self.rng``."""
        g = self.geometry
        cfg = self.config
        n_bins, n_beams = self.polar_shape
        n_cells = n_bins * n_beams
        e = self.ray_intensity(idx, r, cos_inc, mu)
        if cfg.mode == "physical":
            raw, label_polar, rows = self._accumulate(
                idx, r, cos_inc, e, labels if cfg.labels else None
            )
            polar = self._physical_polar(raw, rows)
        # Hits inside the window (the image may also use hits just outside it).
        win = (r >= cfg.range_min_m) & (r < cfg.range_max_m)
        if not win.all():
            idx, r, e, labels = idx[win], r[win], e[win], labels[win]
        bins = ((r - cfg.range_min_m) / cfg.bin_m).astype(np.int64)
        np.clip(bins, 0, n_bins - 1, out=bins)
        if cfg.mode != "physical":
            # 2013 mode: occupancy of the cell each ray's hit falls in; its label.
            cell = bins * n_beams + g.ray_beam[idx]
            label_polar = np.full(n_cells, -1, dtype=np.int16)
            label_polar[cell] = labels  # no intensities: any hit of the cell will do
            label_polar = label_polar.reshape(n_bins, n_beams)
            polar = np.zeros((n_bins, n_beams), dtype=np.float32)
            polar.reshape(-1)[cell] = 1.0
        polar_u8 = cv2.convertScaleAbs(polar, alpha=255.0)

        # Ray-level echo on the display scale, for the cloud's intensity.
        ray_disp = np.zeros(self.n_rays, dtype=np.float32)
        if idx.size:
            lvl = e * g.signal_gain[bins, 0]
            ray_disp[idx] = np.clip(
                1.0 + np.log10(np.maximum(lvl, 1e-30)) * (10.0 / cfg.dynamic_range_db), 0.0, 1.0
            )

        # Hit points as (3, M) columns (cheap to gather and rotate); the ping keeps the
        # (M, 3) transposed views.
        cols_sonar = np.take(g.dirs_sonar_cols, idx, axis=1) * r
        pts_sonar = cols_sonar.T
        pts_ned = (rotation_ned_from_sonar @ cols_sonar + np.reshape(position_ned, (3, 1))).T
        cloud = self._cloud(idx, cols_sonar, ray_disp)

        if cfg.mode == "physical":
            scale, apex = g.fan_scale, g.fan_apex
        else:
            scale, apex = cfg.px_per_m_2013, (0.0, 0.0)  # image_2013's apex: top-left

        def fan_images() -> tuple[NDArray[np.uint8], NDArray[np.int16], NDArray[np.uint8] | None]:
            """(fan_u8, label_fan, fan_rgb) of this ping (formed on first access)."""
            if cfg.mode == "physical":
                fan = cv2.remap(polar_u8, g.map_x, g.map_y, cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)  # fmt: skip
                if cfg.labels:
                    label_fan = self._label_fan(label_polar, cols_sonar, e, labels)
                else:
                    label_fan = self._unlabelled_fan
            else:
                fan, label_fan, _ = image_2013(pts_sonar, labels, cfg)
            fan_rgb = None
            if cfg.colormap is not None:
                fan_rgb = cv2.applyColorMap(fan, COLORMAPS[cfg.colormap])
                if cfg.mode == "physical":
                    fan_rgb = cv2.bitwise_and(fan_rgb, fan_rgb, mask=g.fan_mask_u8)
            return fan, label_fan, fan_rgb

        return SonarPing(
            t=float(t),
            position_ned=np.asarray(position_ned, dtype=float),
            rotation_ned_from_sonar=np.asarray(rotation_ned_from_sonar, dtype=float),
            beam_angles_rad=g.beam_angles,
            bin_ranges_m=g.bin_centres,
            polar=polar,
            polar_u8=polar_u8,
            fan_px_per_m=float(scale),
            fan_apex_px=(float(apex[0]), float(apex[1])),
            label_polar=label_polar,
            cloud=cloud,
            hit_points_sonar=pts_sonar,
            hit_points_ned=pts_ned,
            hit_labels=labels,
            form_fan_images=fan_images,
            mode=cfg.mode,
            fan_layout="bottom-centre" if cfg.mode == "physical" else cfg.layout_2013,
            fan_half_fov_rad=math.radians(cfg.sonar_spec.fov_h_deg) / 2.0,
        )

    # -- pieces ------------------------------------------------------------------------------
    def footprint(
        self, r: NDArray[np.float64], cos_inc: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Range footprint of each ray in bin units: (start, length).

        A ray stands for an elevation slice δφ; on a surface seen at incidence β that slice
        spans ΔR = R·δφ·tan β in range, centred on the ray's hit (a flat floor at height h:
        ΔR ≈ R²δφ/h). Spreading each echo evenly over its footprint keeps the sea floor
        continuous however few rays are cast (tan β is capped at
        :data:`MAX_FOOTPRINT_TAN`). Returned in fractional bins from ``range_min_m``.
        """
        cfg = self.config
        c = np.clip(cos_inc, 1.0 / math.sqrt(1.0 + MAX_FOOTPRINT_TAN**2), 1.0)
        length = r * (self.geometry.dphi / cfg.bin_m) * (np.sqrt(1.0 - c * c) / c)
        start = (r - cfg.range_min_m) / cfg.bin_m - 0.5 * length
        return start, length

    def _footprint_bins(
        self, r: NDArray[np.float64], cos_inc: NDArray[np.float64], e: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], ...]:
        """Footprints clipped to the window, in fractional bins, for the rays whose footprint
        overlaps the window (``keep``): start ``a``, end ``b``, first and last bin ``lo``,
        ``hi``, echo per bin ``dens`` and ``one``, the echo of a footprint inside a single
        bin (all of it, or the part inside the window)."""
        n_bins = self.config.n_bins
        a, length = self.footprint(r, cos_inc)
        length = np.maximum(length, 1e-9)
        b = a + length
        keep = (b > 0.0) & (a < n_bins)
        if not keep.all():
            a, b, length, e = a[keep], b[keep], length[keep], e[keep]
        dens = e / length
        top = n_bins * (1.0 - 1e-12)
        whole = (a >= 0.0) & (b <= top)
        b = np.clip(b, 0.0, top)
        a = np.clip(a, 0.0, top)
        one = np.where(whole, e, dens * (b - a))
        return keep, a, b, a.astype(np.int64), b.astype(np.int64), dens, one

    def _accumulate(
        self,
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        cos_inc: NDArray[np.float64],
        e: NDArray[np.float64],
        labels: NDArray[np.int32] | None = None,
    ) -> tuple[NDArray[np.float32], NDArray[np.int16], list[tuple[int, int]]]:
        """Sum ray echoes into (bin, beam) cells, each spread evenly over its range
        footprint [a, b) (fractional bins: the end bins get their overlap, the bins in
        between e/(b − a) each), and label each cell (−1: none; all −1 when ``labels`` is
        None) with the scene label that put the most echo into it. Also returns the row
        ranges [start, stop) outside which the raw image is zero by construction (no
        footprint reaches those range bins), widened by the range-blur half-width.

        O(rays + cells of the rows the footprints reach): every footprint becomes four steps
        of a difference image whose cumulative sum along range comes from cv2.integral, over
        the slab of rows between the nearest and the farthest footprint only. Labels: the most
        frequent label of the ping (usually the sea floor) is the background; the rays of
        every other label are expanded into their footprint cells and their echo summed per
        label; a cell takes the label with the most echo, the background's being the rest
        of the cell's sum.
        The returned raw image is a scratch buffer of this instance (valid until the next
        ping); the labels are a new array.
        """
        g = self.geometry
        n_bins, n_beams = self.polar_shape
        buf = self._scratch
        if labels is None:
            label_polar = self._unlabelled_polar
        else:
            label_polar = np.full((n_bins, n_beams), -1, dtype=np.int16)
        raw = buf["raw"]
        if idx.size == 0:
            raw.fill(0.0)
            return raw, label_polar, []
        keep, a, b, lo, hi, dens, one = self._footprint_bins(r, cos_inc, e)
        if not keep.all():
            idx, e = idx[keep], e[keep]
            labels = labels[keep] if labels is not None else None
            if idx.size == 0:
                raw.fill(0.0)
                return raw, label_polar, []
        same = lo == hi
        beam = g.ray_beam[idx]
        # Rows [r0, r1) hold every footprint; the rest of the image gets no echo.
        r0, r1 = int(lo.min()), int(hi.max()) + 1
        raw[:r0].fill(0.0)
        raw[r1:].fill(0.0)
        slab = raw[r0:r1]
        # Each footprint as steps along range of a difference image: its first bin gets its
        # overlap w_first, the bins between the density each, its last bin its overlap
        # w_last; a footprint inside one bin puts all its echo there (steps +e, −e).
        w_first = np.where(same, one, dens * (lo + 1 - a))
        w_last = np.where(same, 0.0, dens * (b - hi))
        inner = np.where(same, 0.0, dens)
        rows_first = (lo - r0) * n_beams + beam
        rows_last = (hi - r0) * n_beams + beam
        cells = np.concatenate([rows_first, rows_first + n_beams, rows_last, rows_last + n_beams])
        steps = np.concatenate([w_first, inner - w_first, w_last - inner, -w_last])
        # Summed in input order into the zeroed scratch (a fresh megabyte-sized array per
        # ping would cost page faults), which is zeroed again once read.
        diff = buf["diff"][: (r1 - r0 + 1) * n_beams]
        np.add.at(diff, cells, steps)
        # Cumulative sum along range = column differences of the integral image.
        integ = cv2.integral(
            diff.reshape(r1 - r0 + 1, n_beams), sum=buf["integ"][: r1 - r0 + 2], sdepth=cv2.CV_64F
        )
        diff.fill(0.0)
        cv2.subtract(integ[1:-1, 1:], integ[1:-1, :-1], dst=slab, dtype=cv2.CV_32F)
        # Round-off of the integral image (~1e-16 of a row sum, itself ≤ the ping's total
        # echo) must not count as echo (it would label shadows): zero everything below
        # 1e-12 of the total echo (−120 dB: far below any noise floor).
        tiny = 1e-12 * float(e.sum()) + float(np.finfo(np.float32).tiny)
        cv2.threshold(slab, tiny, 0.0, cv2.THRESH_TOZERO, dst=slab)
        if labels is not None:
            self._label_cells(raw, label_polar, labels, a, b, lo, hi, dens, one, beam)
        # Range bins some footprint reaches (a difference count over [lo, hi]).
        reach = np.bincount(lo, minlength=n_bins + 1) - np.bincount(hi + 1, minlength=n_bins + 1)
        cover = np.cumsum(reach[:n_bins]) > 0
        rows = _row_runs(cover, g.range_kernel.size // 2, _ROW_RUN_MERGE_GAP)
        return raw, label_polar, rows

    def _label_cells(
        self,
        raw: NDArray[np.float32],
        out: NDArray[np.int16],
        labels: NDArray[np.int32],
        a: NDArray[np.float64],
        b: NDArray[np.float64],
        lo: NDArray[np.int64],
        hi: NDArray[np.int64],
        dens: NDArray[np.float64],
        e: NDArray[np.float64],
        beam: NDArray[np.int64],
    ) -> None:
        """Fill ``out`` (n_bins, n_beams) with the label that put the most echo in each
        cell; see :meth:`_accumulate`."""
        n_beams = raw.shape[1]
        present = np.bincount(labels + 1)
        background = int(np.argmax(present)) - 1
        # out = background where raw > 0, else −1 (a look-up on OpenCV's 0/255 mask).
        lut = np.full(256, -1, np.int16)
        lut[255] = background
        cv2.LUT(cv2.compare(raw, 0.0, cv2.CMP_GT), lut, dst=out)
        others = [int(v) - 1 for v in np.flatnonzero(present) if int(v) - 1 != background]
        if not others:
            return
        # Sparse per-cell sums in persistent scratch buffers that are all zero (−1, False)
        # between pings: add, read, reset only the touched cells, so the cost follows the
        # foreground footprints, not the image size.
        oflat = out.reshape(-1)
        rflat = raw.reshape(-1)
        acc = self._scratch["fg_energy"]
        mark = self._scratch["fg_mark"]
        best = self._scratch["fg_best"]
        best_lab = self._scratch["fg_label"]
        total = self._scratch["fg_total"]
        touched = []
        for lab in others:
            sel = np.flatnonzero(labels == lab)
            n_c = hi[sel] - lo[sel] + 1
            ray_of = np.repeat(sel, n_c)
            first = np.cumsum(n_c) - n_c
            row = np.arange(ray_of.size, dtype=np.int64) - np.repeat(first - lo[sel], n_c)
            w = np.minimum(b[ray_of], row + 1.0) - np.maximum(a[ray_of], row)
            w *= dens[ray_of]
            single = np.repeat(n_c == 1, n_c)
            w[single] = e[ray_of[single]]
            cells = row * n_beams + beam[ray_of]
            np.add.at(acc, cells, w)
            mark[cells] = True
            r0 = int(lo[sel].min()) * n_beams
            uniq = np.flatnonzero(mark[r0 : (int(hi[sel].max()) + 1) * n_beams]) + r0
            mark[uniq] = False
            energy = acc[uniq]  # this label's echo in each cell it touches
            acc[uniq] = 0.0
            total[uniq] += energy
            better = energy > best[uniq]
            best[uniq[better]] = energy[better]
            best_lab[uniq[better]] = lab
            touched.append(uniq)
        cells = np.concatenate(touched) if len(touched) > 1 else touched[0]
        # The strongest foreground label wins over the background's share (cell − all fg).
        win = cells[best[cells] > rflat[cells] - total[cells]]
        oflat[win] = best_lab[win]
        best[cells] = 0.0
        best_lab[cells] = -1
        total[cells] = 0.0

    def _physical_polar(
        self, raw: NDArray[np.float32], rows: list[tuple[int, int]] | None = None
    ) -> NDArray[np.float32]:
        """Beam pattern + pulse blur, noise, speckle, TVG and gain, log compression → 0…1
        (a new array).

        Computed in the log domain, which needs fewer passes over the image:
        polar = 1 + k·ln(conv(raw) + NL/SL) + [1 + k·ln(TVG·SL·gain/top) − 1] + k·ln(S),
        equal to compressing ``(conv(raw)·SL + NL)·TVG·gain·S`` (``reference_polar``).
        ``rows``: row ranges outside which ``raw`` is zero at least a range-blur half-width
        deep (None: all rows); only those are filtered, the others take the precomputed
        echo-free level (the same operations on zeros)."""
        g = self.geometry
        img = np.empty(raw.shape, np.float32)
        done = 0  # rows [0, done) are formed
        for a, b in [(0, raw.shape[0])] if rows is None else rows:
            img[done:a] = g.floor_level[done:a]
            _log_level(raw[a:b], img[a:b], g.beam_kernel, g.range_kernel, g.noise_rel, g.k_ln,
                       g.row_offset[a:b])  # fmt: skip
            done = b
        img[done:] = g.floor_level[done:]
        if self.config.speckle:
            u = _uniform_bytes(self.rng, img.size).reshape(img.shape)
            cv2.add(img, cv2.LUT(u, g.log_speckle_lut, dst=self._scratch["speckle"]), dst=img)
        # Clip to 0…1 in place (two OpenCV thresholds: faster than np.clip here).
        cv2.threshold(img, 1.0, 1.0, cv2.THRESH_TRUNC, dst=img)
        cv2.threshold(img, 0.0, 0.0, cv2.THRESH_TOZERO, dst=img)
        return img

    def _label_fan(
        self,
        label_polar: NDArray[np.int16],
        cols_sonar: NDArray[np.float64],
        e: NDArray[np.float64],
        labels: NDArray[np.int32],
    ) -> NDArray[np.int16]:
        """Nearest-neighbour scan conversion of the polar labels, then each hit (sonar-frame
        points ``cols_sonar`` (3, M), m; echo ``e``) splatted at its own fan pixel
        (strongest wins), so thin returns survive the down-sampling."""
        g = self.geometry
        out = cv2.remap(
            label_polar,
            g.map_nearest,
            None,
            cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=-1,
        )
        if e.size:
            H, W = out.shape
            col = np.floor(g.fan_apex[0] + 0.5 + cols_sonar[1] * g.fan_scale).astype(np.int64)
            row = np.floor(g.fan_apex[1] + 0.5 - cols_sonar[0] * g.fan_scale).astype(np.int64)
            ok = (col >= 0) & (col < W) & (row >= 0) & (row < H)
            pix = row[ok] * W + col[ok]
            ee = e[ok]
            with self._fan_pmax_lock:
                pmax = self._scratch["fan_pmax"]  # zeros; only the splatted pixels are reset
                np.maximum.at(pmax, pix, ee)
                win = ee >= pmax[pix]
                pmax[pix] = 0.0
            out.reshape(-1)[pix[win]] = labels[ok][win]
        return out

    def _cloud(
        self, idx: NDArray[np.int64], cols: NDArray[np.float64], ray_disp: NDArray[np.float32]
    ) -> SonarCloud:
        """The ``sonar_cloud`` of a ping from the rays ``idx`` that hit inside the window and
        their sonar-frame points ``cols`` (3, M), m."""
        g = self.geometry
        cfg = self.config
        n = self.n_rays
        x, y, z = np.full((3, n), np.nan, dtype=np.float32)
        x[idx], y[idx], z[idx] = cols
        n_planes = cfg.rays_per_beam
        per_plane = n // n_planes
        az = g.ray_az[:per_plane]
        return SonarCloud(
            num_planes=n_planes,
            num_points_per_plane=per_plane,
            angle_min=float(az[0]),
            angle_max=float(az[-1]),
            angle_increment=float(az[1] - az[0]) if per_plane > 1 else 0.0,
            range_min=float(cfg.range_min_m),
            range_max=float(cfg.range_max_m),
            vert_height=float(g.dphi * n_planes),
            vert_resolution=float(g.dphi),
            x=x,
            y=y,
            z=z,
            intensity=ray_disp,
        )


def _inside_scene_geometry(raycaster: RayCaster, p: NDArray[np.float64]) -> str | None:
    """Why the point ``p`` (NED) is inside the caster's scene geometry, or None: asks the
    caster's ``scene`` when it has one (``uhrisim.world.scene.Scene.inside_solid``: below
    the sea floor or inside a watertight static mesh). Dynamic bodies are not checked (the
    sonar's own vehicle is excluded from its rays anyway)."""
    scene = getattr(raycaster, "scene", None)
    inside_solid = getattr(scene, "inside_solid", None)
    return inside_solid(p) if inside_solid is not None else None


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
