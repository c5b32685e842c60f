"""Slow, obviously-correct reference of the physical image formation.

Plain Python loops over rays, cells and kernel taps, written straight from the sonar
equation in ``docs/reference/sonar.md``; tests hold :class:`ImagingSonar`'s vectorised
path to it. Use small configurations only (it is O(cells × kernel taps) in Python).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.acoustics import ambient_noise_band_db, element_directivity
from uhrisim.sensors.sonar.echoes import MAX_FOOTPRINT_TAN
from uhrisim.sensors.sonar.sonar import ImagingSonar


def reference_polar(
    sonar: ImagingSonar,
    idx: NDArray[np.int64],
    r: NDArray[np.float64],
    cos_inc: NDArray[np.float64],
    mu: NDArray[np.float64],
    fields: tuple[NDArray[np.float32], ...] | None = None,
    depth_m: float | None = None,
    axis_depression_rad: float = 0.0,
) -> NDArray[np.float64]:
    """Display level 0…1 (n_bins, n_beams) for hits of rays ``idx`` at slant ranges ``r``
    (m), |cos incidence| ``cos_inc`` and Lambert μ ``mu``.

    Steps: per ray, EL = SL − 2(20 log R + αR) + 10 log(μ cos²β · R²ΔΩ/cos β)
    + 20 log b_v(φ) + 10 log D(θ), spread evenly over its range footprint R·δφ·tan β; the
    diffuse intensity of each row (noise, ambient − DI, volume reverberation, post-TVG
    noise, the far side lobes' share of the row's echo, and the surface when ``depth_m``
    is given); then either (``fields`` None) the mean intensity, the beam pattern (each
    beam's own: its block's, steered beams widening off the axis) and range blur as
    explicit sums of power kernels plus the diffuse intensity, or
    (``fields`` = the ping's (|w|²,) speckle window) that mean times |w|², or
    (``fields`` = the ping's (z_re, z_im) windows) the coherent sum
    Σ h_r·h_b·√(raw + d/P)·z over amplitude kernels and its squared magnitude (image
    borders mirrored; for the mean, the fan edges only); + TVG (held inside
    tvg_min_range_m, capped at the receiver's largest gain) + gain; map
    [top − DR, top] dB → [0, 1].
    """
    cfg = sonar.config
    g = sonar.geometry
    spec = cfg.sonar_spec
    n_bins, n_beams = sonar.polar_shape
    alpha = cfg.alpha_db_per_m
    half_fov = math.radians(spec.fov_h_deg) / 2.0
    dtheta = g.beam_spacing  # mean beam spacing (kernels, reverberation cells)
    local = np.gradient(g.beam_angles)  # each beam's own spacing (its rays' solid angle)
    raw = [[0.0] * n_beams for _ in range(n_bins)]
    for k in range(len(idx)):
        i = int(idx[k])
        R = float(r[k])
        c = float(cos_inc[k])
        phi = float(g.ray_el[i])
        el_pattern = math.exp(-math.log(2.0) * (phi / (0.5 * math.radians(
            spec.beam_width_v_deg))) ** 2)  # fmt: skip
        directivity = float(element_directivity(float(g.ray_az[i]), half_fov, cfg.edge_loss_db))
        solid_angle = math.cos(phi) * local[g.ray_beam[i]] / cfg.rays_per_beam_azimuth * g.dphi
        area = R * R * solid_angle / max(c, 1e-12)
        ts_db = 10.0 * math.log10(max(float(mu[k]) * c * c * area, 1e-300))
        tl_db = 20.0 * math.log10(R) + alpha * R
        el_db = -2.0 * tl_db + ts_db + 20.0 * math.log10(el_pattern)  # re SL
        energy = 10.0 ** (el_db / 10.0) * directivity
        cc = min(max(c, 1.0 / math.sqrt(1.0 + MAX_FOOTPRINT_TAN**2)), 1.0)
        length = R * g.dphi * math.sqrt(1.0 - cc * cc) / cc  # footprint, m
        a = R - 0.5 * length
        bnd = R + 0.5 * length
        beam = int(g.ray_beam[i])
        for b in range(n_bins):
            edge0 = cfg.range_min_m + b * cfg.bin_m
            edge1 = edge0 + cfg.bin_m
            if length < 1e-9 * cfg.bin_m:
                overlap_fraction = 1.0 if edge0 <= R < edge1 else 0.0
            else:
                overlap = min(bnd, edge1) - max(a, edge0)
                overlap_fraction = max(overlap, 0.0) / length
            raw[b][beam] += energy * overlap_fraction

    # Each beam's own horizontal pattern: that of the block it belongs to (steered beams
    # widen off the axis, geometry.beam_blocks).
    block_of = {j: blk for blk in g.beam_blocks for j in range(blk.start, blk.stop)}
    kr = [float(v) for v in g.range_kernel]
    ar = [float(v) for v in g.range_amp]
    hr = len(kr) // 2
    kb_axis = [float(v) for v in g.beam_kernel]  # on the axis: the diffuse terms' pattern
    sl_lin = 10.0 ** (cfg.source_level_db / 10.0)
    noise = 10.0 ** (cfg.noise_floor_db / 10.0)
    if cfg.ambient_noise:
        band = ambient_noise_band_db(spec.frequency_hz, cfg.bandwidth_hz, cfg.sea_state)
        beam_solid_angle = math.radians(spec.beam_width_h_deg) * math.radians(spec.beam_width_v_deg)
        di = 10.0 * math.log10(4.0 * math.pi / beam_solid_angle)
        noise += 10.0 ** ((band - di) / 10.0)
    width_v = math.radians(spec.beam_width_v_deg)
    psi_v = (
        sum(  # ∫ b_v(φ)² dφ by the midpoint rule over ±4 beam widths
            math.exp(
                -2.0 * math.log(2.0) * (((j + 0.5) * 1e-4 - 4 * width_v) / (0.5 * width_v)) ** 2
            )
            for j in range(int(8 * width_v / 1e-4))
        )
        * 1e-4
    )
    diffuse, tvgs = [], []
    for b in range(n_bins):
        Rc = max(cfg.range_min_m + (b + 0.5) * cfg.bin_m, 0.5 * cfg.bin_m)
        Rt = max(Rc, cfg.tvg_min_range_m)
        tvg = cfg.tvg_spreading_db_per_decade * math.log10(Rt) + 2.0 * alpha * Rt if cfg.tvg else 0
        tvg = min(tvg, cfg.tvg_cap_db)
        loss = 10.0 ** (-2.0 * alpha * Rc / 10.0)
        d = noise / sl_lin
        if cfg.volume_scattering_db is not None:
            volume = Rc * Rc * dtheta * psi_v * cfg.bin_m  # m³ of one cell
            d += 10.0 ** (cfg.volume_scattering_db / 10.0) * volume * loss / Rc**4 * sum(kb_axis)
        if cfg.post_tvg_noise_db is not None:
            d += 10.0 ** ((cfg.post_tvg_noise_db - cfg.source_level_db - tvg) / 10.0)
        if cfg.far_sidelobe_db is not None:
            d += 10.0 ** (cfg.far_sidelobe_db / 10.0) * sum(kb_axis) * sum(raw[b]) / n_beams
        if depth_m is not None and cfg.surface_scattering_db is not None and Rc > depth_m:
            off_axis = math.asin(depth_m / Rc) + axis_depression_rad
            b_v2 = math.exp(-2.0 * math.log(2.0) * (off_axis / (0.5 * width_v)) ** 2)
            area = Rc * dtheta * cfg.bin_m  # surface patch of one cell
            d += (10.0 ** (cfg.surface_scattering_db / 10.0) * (depth_m / Rc) ** 2 * area
                  * b_v2 * loss / Rc**4 * sum(kb_axis))  # fmt: skip
        diffuse.append(d)
        tvgs.append(tvg)

    def mirror(i: int, n: int) -> int:  # image borders mirror: −1 → 1, n → n − 2
        return -i if i < 0 else (2 * (n - 1) - i if i >= n else i)

    out = np.zeros((n_bins, n_beams))
    for b in range(n_bins):
        d, tvg = diffuse[b], tvgs[b]
        for j in range(n_beams):
            kb = [float(v) for v in block_of[j].power]
            ab = [float(v) for v in block_of[j].amplitude]
            hb = len(kb) // 2
            if fields is None or len(fields) == 1:  # the mean, times |w|² if given
                s = 0.0
                for u in range(-hr, hr + 1):
                    for v in range(-hb, hb + 1):
                        bb, jj = b + u, mirror(j + v, n_beams)
                        if 0 <= bb < n_bins:  # no echo beyond the window's ends
                            s += kr[u + hr] * kb[v + hb] * raw[bb][jj]
                intensity = s + d
                if fields is not None:
                    intensity *= float(fields[0][b, j])
            else:  # coherent: Σ h_r·h_b·√(raw + d_row/P)·z
                z_re, z_im = fields
                power = sum(x * x for x in ab) * sum(x * x for x in ar)
                cre = cim = 0.0
                for u in range(-hr, hr + 1):
                    for v in range(-hb, hb + 1):
                        bb, jj = mirror(b + u, n_bins), mirror(j + v, n_beams)
                        amp = ar[u + hr] * ab[v + hb] * math.sqrt(raw[bb][jj] + diffuse[bb] / power)
                        cre += amp * float(z_re[bb, jj])
                        cim += amp * float(z_im[bb, jj])
                intensity = cre * cre + cim * cim
            level = 10.0 * math.log10(max(intensity, 1e-300) * sl_lin) + tvg + cfg.gain_db
            out[b, j] = min(
                max(1.0 + (level - cfg.display_top_db) / cfg.dynamic_range_db, 0.0), 1.0
            )
    return out


def reference_bytes(
    polar: NDArray[np.float64], gamma: float, black: int = 0
) -> NDArray[np.uint8]:
    """The 8-bit display mapping, one pixel at a time: round(b + (255 − b)·x^γ)."""
    out = np.zeros(polar.shape, np.uint8)
    for index, x in np.ndenumerate(polar):
        out[index] = math.floor(black + (255.0 - black) * float(x) ** gamma + 0.5)
    return out


def reference_labels(
    sonar: ImagingSonar,
    idx: NDArray[np.int64],
    r: NDArray[np.float64],
    cos_inc: NDArray[np.float64],
    mu: NDArray[np.float64],
    labels: NDArray[np.int32],
) -> NDArray[np.int16]:
    """Per cell, the scene label whose rays put the most echo into it (−1: none), by
    dictionaries of per-label sums (same echo and footprint model as the image)."""
    g = sonar.geometry
    n_bins, n_beams = sonar.polar_shape
    e = sonar.ray_intensity(idx, r, cos_inc, mu)
    start, length = sonar.footprint(r, cos_inc)
    sums: dict[tuple[int, int], dict[int, float]] = {}
    for k in range(len(idx)):
        a = float(start[k])
        bnd = a + float(length[k])
        beam = int(g.ray_beam[int(idx[k])])
        for b in range(n_bins):
            if length[k] < 1e-9:
                frac = 1.0 if b <= a < b + 1 or (b == n_bins - 1 and a >= n_bins) else 0.0
            else:
                frac = max(min(bnd, b + 1.0) - max(a, float(b)), 0.0) / float(length[k])
            if frac > 0.0:
                cell = sums.setdefault((b, beam), {})
                cell[int(labels[k])] = cell.get(int(labels[k]), 0.0) + float(e[k]) * frac
    out = np.full((n_bins, n_beams), -1, dtype=np.int16)
    for (b, j), per_label in sums.items():
        out[b, j] = max(per_label.items(), key=lambda kv: kv[1])[0]
    return out
