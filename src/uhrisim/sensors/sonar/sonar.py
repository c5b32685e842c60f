"""The forward-looking imaging sonar: rays → polar image → fan image, per ping.

Frames (``docs/conventions.md``): the **sonar frame** is FRD-like — x along the sonar axis,
y to starboard, z down. A ray at beam angle θ (> 0 starboard) and elevation φ (> 0 down)
has direction (cos φ cos θ, cos φ sin θ, sin φ) there. The mount rotates the sonar frame
into the vehicle body frame FRD by yaw (about z) after a downward tilt (a pitch of −tilt);
the vehicle rotation then takes it to world NED.

Physical image formation (``mode="physical"``), per ray that hits at slant range R with
incidence β on a surface of Lambert coefficient μ (``docs/reference/sonar.md``):

    EL = SL − 2·TL(R) + TS,     TL = 20 log10 R + αR,     TS = 10 log10(μ·cos²β·A)

A ray stands for the solid angle ΔΩ = cos φ·δθ·δφ, i.e. a surface patch A = R²ΔΩ/cos β,
so its echo intensity (re SL) is ``b_v(φ)²·D(θ)·μ·cos β·ΔΩ·R⁻²·10^(−2αR/10)`` with b_v the
vertical (elevation) power pattern, two-way, and D the element directivity across the fan.
Each echo is spread evenly over the range footprint of its elevation slice, R·δφ·tan β (so
a floor stays continuous however few rays are cast), and summed into (range bin, beam)
cells — rays stop at the first hit, so shadows come only from the geometry; an optional
surface ghost adds each echo again at the range of its surface-bounce path. The stages of
:mod:`.polar` then form the display image: diffuse terms (noise, reverberation, far side
lobes), coherent speckle through the beam pattern (sinc with side lobes across beams,
steered beams 1/cos θ wider off the axis) and the pulse envelope (along range), TVG
(held near, capped far), gain and log compression
``polar = clip(1 + (L − display_top_db)/dynamic_range_db, 0, 1)``, and the 8-bit mapping
``polar_u8 = round(b + (255 − b)·polar^display_gamma)`` (b the black level).

2013 mode (``mode="2013"``, DeMarco et al. 2013): hit points projected onto the sonar's
x–y plane, ×10 px/m, apex at the top-left pixel, Gaussian blur, white fan boundary lines.

This module composes the stages, each in a module of its own: :mod:`.geometry` (what is
computed once per configuration), :mod:`.cast` (casting the fan), :mod:`.echoes` (ray
echoes summed into the raw image), :mod:`.polar` (diffuse terms, speckle through beam
pattern and pulse, TVG, log compression, 8-bit mapping), :mod:`.speckle` (the random
fields), :mod:`.fan` (scan conversion), :mod:`.labels` and :mod:`.cloud` (the label images
and the point cloud); :mod:`.ping` holds what a ping produces.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Protocol

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.cast import FanHits, RayCaster, cast_fan, own_fan_is_valid
from uhrisim.sensors.sonar.cloud import SonarCloud, cloud_hits, sonar_cloud
from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.echoes import MAX_FOOTPRINT_TAN, EchoAccumulator, footprint, ray_echo
from uhrisim.sensors.sonar.fan import color_fan, fan_image, image_2013
from uhrisim.sensors.sonar.geometry import (
    mount_rotation,
    mounted_pose,
    sonar_geometry,
    surface_rows,
)
from uhrisim.sensors.sonar.labels import FanLabeller, unlabelled
from uhrisim.sensors.sonar.ping import SonarInfo, SonarPing
from uhrisim.sensors.sonar.polar import (
    clip_unit,
    coherent_field,
    coherent_log_intensity,
    diffuse_rows,
    display_bytes,
    display_level,
    mean_intensity,
)
from uhrisim.sensors.sonar.speckle import SpeckleBank

#: ``cloud_hits`` (:mod:`.cloud`) stays importable from here, where callers import it.
__all__ = ["ImagingSonar", "cloud_hits"]

_LN10_OVER_10 = math.log(10.0) / 10.0
#: Echoes of volume scatterers per cell: (range bins, beams, echoes re SL).
VolumeEchoes = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]


#: Elevation rays per beam that sample a medium's volume scatterers (:meth:`volume_echoes`).
VOLUME_ELEVATIONS = 8
#: Range cell (m) in which a medium's volume scatterers are integrated.
VOLUME_CELL_M = 0.1


class VolumeScatterers(Protocol):
    """Scatterers spread through the water near the sonar (a silt cloud:
    :class:`uhrisim.world.silt.SiltMedium`)."""

    def backscatter(self, origin_ned: NDArray[np.float64], directions: NDArray[np.float64],
                    ends: NDArray[np.float64], edges: NDArray[np.float64],
                    frequency_hz: float) -> tuple[NDArray, NDArray, NDArray]:
        """(ray, bin, ∫ s_v dR over the bin) along rays up to ``ends`` (m), range bin
        ``edges`` (m)."""
        ...


class ImagingSonar:
    """A forward-looking imaging sonar bound to a config and a random Generator.

    ``ping(raycaster, position_ned, rotation_body_to_ned, t)`` casts the ray fan from the
    mount and forms the image. Everything that depends only on the config (ray
    directions, elevation weights, kernels, TVG curve, scan-conversion maps) is computed
    once here, and so are the random fields of the speckle, drawn from ``rng``
    (:mod:`.speckle`). The Generator is the only state that changes between pings (the
    speckle's offsets);
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
        spec = config.sonar_spec
        self.info = SonarInfo(spec.name, spec.frequency_hz, config.sound_speed_m_s,
                              config.range_min_m, config.range_max_m, spec.fov_h_deg,
                              spec.n_beams, config.bin_m)
        # The stages that keep scratch images between pings (a ping is not re-entrant).
        self._echoes = EchoAccumulator(self.geometry, config)
        self._fan_labels = FanLabeller(self.geometry)
        self._bank = (
            SpeckleBank.draw(rng, self.polar_shape, self.geometry.beam_blocks,
                             self.geometry.range_amp, self.geometry.k_ln,
                             scatterers=config.speckle_model == "coherent")
            if config.speckle and config.mode == "physical" else None
        )  # fmt: skip
        self._c_re = np.empty(self.polar_shape, np.float32)
        self._c_im = np.empty(self.polar_shape, np.float32)
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
        medium: VolumeScatterers | None = None,
    ) -> SonarPing:
        """Cast the fan from the mount on a vehicle at ``position_ned`` (m, NED) with
        ``rotation_body_to_ned`` (vehicle FRD → NED) and form the image. ``medium``: local
        volume scatterers in the water (a silt cloud), whose backscatter along each ray,
        up to what it hits, adds to the echoes (:meth:`volume_echoes`).

        Raises ConfigError (naming ``SonarConfig.mount_position_frd``) if the sonar sits
        inside geometry: below the sea floor or inside a watertight static mesh of the
        caster's scene, or, for any caster, when most rays hit at ~0 m.
        """
        p_s, R_s = self.sonar_pose(position_ned, rotation_body_to_ned)
        dirs = self.geometry.dirs_sonar @ R_s.T
        hits = cast_fan(raycaster, p_s, dirs, self.cast_window_m, exclude,
                        unit_rays=own_fan_is_valid(p_s, R_s))  # fmt: skip
        volume = None
        if medium is not None and self.config.mode == "physical":
            volume = self.volume_echoes(medium, p_s, dirs, hits[0], hits[1])
        return self.form_image(t, p_s, R_s, *hits, volume=volume)

    def volume_echoes(self, medium: VolumeScatterers, position_ned: NDArray[np.float64],
                      dirs_ned: NDArray[np.float64], idx: NDArray[np.int64],
                      r: NDArray[np.float64]) -> VolumeEchoes:
        """Echoes of the medium's volume scatterers per (range bin, beam): every ray
        collects, in each bin before what it hits (rays ``idx`` hit at ``r``), the
        volume reverberation of :func:`.geometry.diffuse_terms` with the local
        ``s_v``: ``w_ray·∫s_v dR·R⁻²·10^(−2αR/10)`` (the scattering volume R²ΔΩ dR of the
        ray, b_v² and D in its weight w_ray). Returns (bins, beams, echoes re SL).

        A cloud is smooth on the scale of the fan's sampling, so the volume is sampled
        coarser than the echoes: :data:`VOLUME_ELEVATIONS` elevation rays per beam (each
        standing for its neighbours' weight too) and range cells of about
        :data:`VOLUME_CELL_M`, each spread evenly over its bins."""
        cfg, g = self.config, self.geometry
        n_el = cfg.rays_per_beam
        n_az = len(g.ray_beam) // n_el
        step = max(1, n_el // VOLUME_ELEVATIONS)
        rays = (np.arange(step // 2, n_el, step)[:, None] * n_az + np.arange(n_az)).ravel()
        ends = np.full(len(dirs_ned), cfg.range_max_m)
        ends[idx] = np.minimum(r, cfg.range_max_m)
        merge = max(1, round(VOLUME_CELL_M / cfg.bin_m))
        edges = cfg.range_min_m + cfg.bin_m * np.arange(0, cfg.n_bins + merge, merge)
        edges[-1] = min(edges[-1], cfg.range_min_m + cfg.bin_m * cfg.n_bins)
        cell_ray, cell, sv_dr = medium.backscatter(position_ned, dirs_ned[rays], ends[rays],
                                                   edges, cfg.sonar_spec.frequency_hz)
        ray = rays[cell_ray]
        rc = 0.5 * (edges[cell] + edges[cell + 1])
        echo = (step * g.ray_weight[ray] * sv_dr * np.exp(-self._two_alpha_ln * rc)
                / (rc * rc))
        # each cell's echo over its bins, by their share of its length
        first = cell * merge
        count = np.minimum(first + merge, cfg.n_bins) - first
        bins = np.repeat(first, count) + (np.arange(count.sum())
                                          - np.repeat(np.cumsum(count) - count, count))
        return bins, np.repeat(g.ray_beam[ray], count), np.repeat(echo / count, count)

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
        volume: VolumeEchoes | None = None,
    ) -> SonarPing:
        """Form a ping from the hits of rays ``idx`` (indices into the ray fan) at slant
        ranges ``r`` (m, inside the window) with |cos incidence| ``cos_inc``, Lambert μ
        ``mu`` and scene ``labels``; ``volume``: echoes of volume scatterers as (bins,
        beams, echoes) (:meth:`volume_echoes`). Pure apart from drawing speckle from
        ``self.rng``. The ping keeps these arrays and forms its fan images, hit points and
        cloud from them on first access: they must not change afterwards."""
        g = self.geometry
        cfg = self.config
        n_bins, n_beams = self.polar_shape
        n_cells = n_bins * n_beams
        e = self.ray_intensity(idx, r, cos_inc, mu)
        if cfg.mode == "physical":
            polar, label_polar = self._physical_image(
                position_ned, rotation_ned_from_sonar, FanHits(idx, r, cos_inc, mu, labels), e,
                volume)
        # Hits inside the window (the image may also use hits just outside it).
        win = (r >= cfg.range_min_m) & (r < cfg.range_max_m)
        if not win.all():
            idx, r, e, labels = idx[win], r[win], e[win], labels[win]
        if cfg.mode == "physical":
            polar_u8 = display_bytes(polar, cfg.display_gamma, cfg.black_level)
        else:
            # 2013 mode: occupancy of the cell each ray's hit falls in; its label.
            cell = self._hit_bins(r) * n_beams + g.ray_beam[idx]
            label_polar = np.full(n_cells, -1, dtype=np.int16)
            label_polar[cell] = labels  # no intensities: any hit of the cell will do
            label_polar = label_polar.reshape(n_bins, n_beams)
            polar = np.zeros((n_bins, n_beams), dtype=np.float32)
            polar.reshape(-1)[cell] = 1.0
            polar_u8 = cv2.convertScaleAbs(polar, alpha=255.0)

        @cache
        def hit_columns() -> NDArray[np.float64]:
            """The hit points in the sonar frame as (3, M) columns (cheap to gather and
            rotate; the ping keeps the (M, 3) transposed views)."""
            return np.take(g.dirs_sonar_cols, idx, axis=1) * r

        def hit_products() -> tuple[SonarCloud, NDArray[np.float64], NDArray[np.float64]]:
            """(cloud, hit points sonar frame, hit points NED) of this ping (formed on
            first access)."""
            # Ray-level echo on the display scale, for the cloud's intensity.
            ray_disp = np.zeros(self.n_rays, dtype=np.float32)
            if idx.size:
                lvl = e * g.signal_gain[self._hit_bins(r), 0]
                ray_disp[idx] = np.clip(
                    1.0 + np.log10(np.maximum(lvl, 1e-30)) * (10.0 / cfg.dynamic_range_db),
                    0.0, 1.0)  # fmt: skip
            cols_sonar = hit_columns()
            pts_ned = (rotation_ned_from_sonar @ cols_sonar
                       + np.reshape(position_ned, (3, 1))).T  # fmt: skip
            return sonar_cloud(g, cfg, idx, cols_sonar, ray_disp), cols_sonar.T, pts_ned

        if cfg.mode == "physical":
            scale, apex = g.fan_scale, g.fan_apex
        else:
            scale, apex = cfg.px_per_m_2013, (0.0, 0.0)  # image_2013's apex: top-left

        def fan_images() -> tuple[NDArray[np.uint8], NDArray[np.int16], NDArray[np.uint8] | None]:
            """(fan_u8, label_fan, fan_rgb) of this ping (formed on first access)."""
            if cfg.mode == "physical":
                fan = fan_image(polar_u8, g.map_x, g.map_y)
                if cfg.labels:
                    label_fan = self._fan_labels.label_fan(label_polar, hit_columns(), e,
                                                           labels)  # fmt: skip
                else:
                    label_fan = self._unlabelled_fan
            else:
                fan, label_fan, _ = image_2013(hit_columns().T, labels, cfg)
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
            hit_labels=labels,
            info=self.info,
            form_fan_images=fan_images,
            form_hit_products=hit_products,
            mode=cfg.mode,
            fan_layout="bottom-centre" if cfg.mode == "physical" else cfg.layout_2013,
            fan_half_fov_rad=math.radians(cfg.sonar_spec.fov_h_deg) / 2.0,
        )

    def _hit_bins(self, r: NDArray[np.float64]) -> NDArray[np.int64]:
        """Range bin of hits at slant ranges ``r`` (m, inside the window)."""
        cfg = self.config
        bins = ((r - cfg.range_min_m) / cfg.bin_m).astype(np.int64)
        np.clip(bins, 0, cfg.n_bins - 1, out=bins)
        return bins

    def polar_bytes(self, position_ned: NDArray[np.float64],
                    rotation_ned_from_sonar: NDArray[np.float64], hits: FanHits
                    ) -> NDArray[np.uint8]:
        """``polar_u8`` of :meth:`form_image` for the same ``hits``, and nothing else (no
        hit points, cloud, labels or fan): the same code, so equal bit for bit, drawing
        the same speckle. A physical ping with no hit skips the echo stages
        (:meth:`_echo_free_level`)."""
        cfg = self.config
        if cfg.mode != "physical":
            return self.form_image(0.0, position_ned, rotation_ned_from_sonar, *hits).polar_u8
        if hits.idx.size == 0:
            level = self._echo_free_level(position_ned, rotation_ned_from_sonar)
        else:
            e = self.ray_intensity(hits.idx, hits.r, hits.cos_inc, hits.mu)
            level, _ = self._physical_image(position_ned, rotation_ned_from_sonar, hits, e,
                                            clipped=False)
        return display_bytes(level, cfg.display_gamma, cfg.black_level, clipped=False)

    def _echo_free_level(self, position_ned: NDArray[np.float64],
                         rotation_ned_from_sonar: NDArray[np.float64]) -> NDArray[np.float32]:
        """Physical mode's display level (not clipped) of a ping with no hit (its pose:
        sonar origin NED m, rotation sonar → NED): :meth:`_physical_polar` of no echo
        with this ping's surface reverberation, what :meth:`_physical_image` gives on no
        hit (no echo, no surface ghost, every row echo-free), bit for bit and drawing the
        same speckle, without its raw image."""
        return self._physical_polar(None, [], self._surface(position_ned,
                                                            rotation_ned_from_sonar),
                                    clipped=False)

    def _surface(self, position_ned: NDArray[np.float64],
                 rotation_ned_from_sonar: NDArray[np.float64]
                 ) -> NDArray[np.float64] | None:
        """This ping's surface reverberation per range row (re SL, (n_bins,); None: none):
        :func:`~uhrisim.sensors.sonar.geometry.surface_rows` at the sonar's depth and
        depression angle (rad, from its boresight's NED z)."""
        cfg, g = self.config, self.geometry
        depression = math.asin(max(-1.0, min(1.0, float(rotation_ned_from_sonar[2, 0]))))
        return surface_rows(cfg, g.bin_centres, float(position_ned[2]), depression,
                            g.beam_spacing, float(g.beam_kernel.sum()))

    def _physical_image(self, position_ned: NDArray[np.float64],
                        rotation_ned_from_sonar: NDArray[np.float64], hits: FanHits,
                        e: NDArray[np.float64], volume: VolumeEchoes | None = None,
                        clipped: bool = True
                        ) -> tuple[NDArray[np.float32], NDArray[np.int16]]:
        """Physical mode's display level and cell labels (``polar``, ``label_polar``) of
        the ``hits``' ray echoes ``e`` (:meth:`form_image`): the raw echo image (with the
        surface ghosts and ``volume`` echoes), then :meth:`_physical_polar` (``clipped``:
        its level clipped to 0…1)."""
        idx, r, cos_inc, _, labels = hits
        cfg = self.config
        if cfg.multipath:
            ghosts = self._surface_ghosts(position_ned, rotation_ned_from_sonar, idx, r, e)
            g_idx, g_r, g_e, keep = ghosts
            raw, label_polar, rows = self._accumulate(
                np.concatenate([idx, g_idx]), np.concatenate([r, g_r]),
                np.concatenate([cos_inc, cos_inc[keep]]), np.concatenate([e, g_e]),
                np.concatenate([labels, labels[keep]]) if cfg.labels else None,
            )  # fmt: skip
        else:
            raw, label_polar, rows = self._accumulate(
                idx, r, cos_inc, e, labels if cfg.labels else None
            )
        surface = self._surface(position_ned, rotation_ned_from_sonar)
        if volume is not None and len(volume[2]):
            self._echoes.add_echoes(*volume)
            rows = None  # volume echo may lie in any row
        return self._physical_polar(raw, rows, surface, clipped), label_polar

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

    def _surface_ghosts(
        self,
        position_ned: NDArray[np.float64],
        rotation_ned_from_sonar: NDArray[np.float64],
        idx: NDArray[np.int64],
        r: NDArray[np.float64],
        e: NDArray[np.float64],
    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """The surface ghost of each hit below the surface (``multipath``): the echo that
        returns via one bounce off the sea surface (NED z = 0), arriving at the mean of
        the direct and the mirrored path, R' = (R + |p − p̃_s|)/2 with p̃_s the sonar
        mirrored in the surface, in the same beam, weaker by ``multipath_loss_db`` and by
        the longer return leg's spreading (R/|p − p̃_s|)². The vertical beam pattern is
        that of the direct ray (a simplification). Returns (beam rays, ranges, echoes,
        which hits have a ghost)."""
        cfg = self.config
        g = self.geometry
        dirs_ned = rotation_ned_from_sonar @ np.take(g.dirs_sonar_cols, idx, axis=1)
        pts = dirs_ned * r + np.reshape(position_ned, (3, 1))
        mirror = np.array([position_ned[0], position_ned[1], -position_ned[2]])
        keep = (pts[2] > 0.0) & (position_ned[2] > 0.0)
        back = np.linalg.norm(pts[:, keep] - mirror[:, None], axis=0)
        rk = r[keep]
        loss = 10.0 ** (-cfg.multipath_loss_db / 10.0)
        return idx[keep], 0.5 * (rk + back), e[keep] * loss * (rk / back) ** 2, keep

    def _physical_polar(
        self,
        raw: NDArray[np.float32] | None,
        rows: list[tuple[int, int]] | None = None,
        surface: NDArray[np.float64] | None = None,
        clipped: bool = True,
    ) -> NDArray[np.float32]:
        """The stages of :mod:`.polar`, composed: diffuse terms per row, the mean image
        through the beam and pulse patterns times the product speckle field, or the
        coherent sum (``speckle_model``), TVG, gain and log compression, clipped to 0…1
        unless not ``clipped`` (a new array). ``surface``: this ping's surface
        reverberation per row (None: none). ``raw`` None: no echo (``rows`` must be
        empty).

        ``rows``: row ranges outside which ``raw`` is zero at least a range-kernel
        half-width deep (None: all rows); only those are filtered. The others hold only
        the diffuse terms and take their level (in the coherent model times the bank's
        diffuse field: what the stages give on zero echo, in distribution)."""
        g = self.geometry
        k = g.k_ln
        d = diffuse_rows(g.diffuse_static, raw, g.leak, surface, rows)
        free = (g.row_offset[:, :1] + k * np.log(np.maximum(d, 1e-300))[:, None]).astype(
            np.float32
        )  # display level of the diffuse terms alone, per row
        img = np.empty(self.polar_shape, np.float32)
        bank = self._bank
        coherent = bank is not None and bank.z_re is not None
        if bank is not None:
            k_ln_w2 = bank.log_w(*bank.w_offset(self.rng))
        if coherent:
            z_re, z_im = bank.z(int(self.rng.integers(0, bank.z_offsets)))
        done = 0  # rows [0, done) are formed
        for a, b in [*([(0, img.shape[0])] if rows is None else rows), (img.shape[0], None)]:
            # echo-free rows: the diffuse level (times the diffuse field); the column set,
            # then OpenCV's add, is ~1.7x faster than numpy adding the broadcast column
            img[done:a] = free[done:a]
            if bank is not None:
                cv2.add(img[done:a], k_ln_w2[done:a], dst=img[done:a])
            if b is None:
                break
            blk = img[a:b]
            if coherent:
                c_re, c_im = self._c_re[a:b], self._c_im[a:b]
                coherent_field(raw[a:b], d[a:b], z_re[a:b], z_im[a:b], g.beam_blocks,
                               g.range_amp, c_re, c_im)  # fmt: skip
                coherent_log_intensity(c_re, c_im, blk)
                display_level(blk, 2.0 * k, g.row_offset[a:b], blk)
            else:
                mean_intensity(raw[a:b], g.beam_blocks, g.range_kernel, d[a:b], blk)
                cv2.log(blk, blk)
                display_level(blk, k, g.row_offset[a:b], blk)
                if bank is not None:  # product speckle: a factor |w|² on intensity
                    cv2.add(blk, k_ln_w2[a:b], dst=blk)
            done = b
        return clip_unit(img) if clipped else img
