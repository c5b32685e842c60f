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

This module composes the stages, each in a module of its own: :mod:`.geometry` (what is
computed once per configuration), :mod:`.cast` (casting the fan), :mod:`.echoes` (ray
echoes summed into the raw image), :mod:`.polar` (beam pattern, pulse, noise, speckle, TVG,
log compression), :mod:`.fan` (scan conversion), :mod:`.labels` and :mod:`.cloud` (the
label images and the point cloud); :mod:`.ping` holds what a ping produces.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.cast import RayCaster, cast_fan
from uhrisim.sensors.sonar.cloud import cloud_hits, sonar_cloud
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.echoes import MAX_FOOTPRINT_TAN, EchoAccumulator, footprint, ray_echo
from uhrisim.sensors.sonar.fan import color_fan, fan_image, image_2013
from uhrisim.sensors.sonar.geometry import mount_rotation, mounted_pose, sonar_geometry
from uhrisim.sensors.sonar.labels import FanLabeller, unlabelled
from uhrisim.sensors.sonar.ping import SonarPing
from uhrisim.sensors.sonar.polar import log_level, uniform_bytes

#: ``cloud_hits`` (:mod:`.cloud`) stays importable from here, where callers import it.
__all__ = ["ImagingSonar", "cloud_hits"]

_LN10_OVER_10 = math.log(10.0) / 10.0


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
        self.geometry = sonar_geometry(config)
        # The stages that keep scratch images between pings (a ping is not re-entrant).
        self._echoes = EchoAccumulator(self.geometry, config)
        self._fan_labels = FanLabeller(self.geometry)
        self._speckle = np.zeros(self.polar_shape, np.float32)
        # With labels off every ping shares this read-only "no label" fan image.
        self._unlabelled_fan = unlabelled(self.geometry.fan_mask.shape)

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
        return mounted_pose(position_ned, rotation_body_to_ned, self.mount_position,
                            self.mount_rotation)

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
        p_s, R_s = self.sonar_pose(position_ned, rotation_body_to_ned)
        dirs = self.geometry.dirs_sonar @ R_s.T
        hits = cast_fan(raycaster, p_s, dirs, self.cast_window_m, exclude)
        return self.form_image(t, p_s, R_s, *hits)

    def ray_intensity(
        self,
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        cos_inc: NDArray[np.float64],
        mu: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Echo intensity of each hit ray relative to the source level (linear):
        ``w_ray·μ·cosβ·R⁻²·10^(−2αR/10)``, w_ray = b_v(φ)²·ΔΩ (see the module docstring)."""
        return ray_echo(self.geometry.ray_weight[idx], r, cos_inc, mu, self._two_alpha_ln)

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
        cloud = sonar_cloud(g, cfg, idx, cols_sonar, ray_disp)

        if cfg.mode == "physical":
            scale, apex = g.fan_scale, g.fan_apex
        else:
            scale, apex = cfg.px_per_m_2013, (0.0, 0.0)  # image_2013's apex: top-left

        def fan_images() -> tuple[NDArray[np.uint8], NDArray[np.int16], NDArray[np.uint8] | None]:
            """(fan_u8, label_fan, fan_rgb) of this ping (formed on first access)."""
            if cfg.mode == "physical":
                fan = fan_image(polar_u8, g.map_x, g.map_y)
                if cfg.labels:
                    label_fan = self._fan_labels.label_fan(label_polar, cols_sonar, e, labels)
                else:
                    label_fan = self._unlabelled_fan
            else:
                fan, label_fan, _ = image_2013(pts_sonar, labels, cfg)
            fan_rgb = None
            if cfg.colormap is not None:
                mask = g.fan_mask_u8 if cfg.mode == "physical" else None
                fan_rgb = color_fan(fan, cfg.colormap, mask)
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

    # -- stages ------------------------------------------------------------------------------
    def footprint(
        self, r: NDArray[np.float64], cos_inc: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Range footprint of each ray in fractional bins from ``range_min_m``: (start,
        length); see :func:`uhrisim.sensors.sonar.echoes.footprint`."""
        return footprint(r, cos_inc, self.geometry.dphi, self.config)

    def _accumulate(
        self,
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        cos_inc: NDArray[np.float64],
        e: NDArray[np.float64],
        labels: NDArray[np.int32] | None = None,
    ) -> tuple[NDArray[np.float32], NDArray[np.int16], list[tuple[int, int]]]:
        """The raw echo image of ray echoes ``e``, its cell labels and the row ranges that
        hold echo: :meth:`uhrisim.sensors.sonar.echoes.EchoAccumulator.accumulate` (the raw
        image is this sonar's scratch buffer, valid until the next ping)."""
        return self._echoes.accumulate(idx, r, cos_inc, e, labels)

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
            log_level(raw[a:b], img[a:b], g.beam_kernel, g.range_kernel, g.noise_rel, g.k_ln,
                      g.row_offset[a:b])  # fmt: skip
            done = b
        img[done:] = g.floor_level[done:]
        if self.config.speckle:
            u = uniform_bytes(self.rng, img.size).reshape(img.shape)
            cv2.add(img, cv2.LUT(u, g.log_speckle_lut, dst=self._speckle), dst=img)
        # Clip to 0…1 in place (two OpenCV thresholds: faster than np.clip here).
        cv2.threshold(img, 1.0, 1.0, cv2.THRESH_TRUNC, dst=img)
        cv2.threshold(img, 0.0, 0.0, cv2.THRESH_TOZERO, dst=img)
        return img
