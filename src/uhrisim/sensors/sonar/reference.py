"""Slow, obviously-correct reference of the physical image formation (no speckle).

Plain Python loops over rays, cells and kernel taps, written straight from the sonar
equation in ``shared/reference/sonar.md``; tests hold :class:`ImagingSonar`'s vectorised
path to it. Use small configurations only (it is O(cells × kernel taps) in Python).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.echoes import MAX_FOOTPRINT_TAN
from uhrisim.sensors.sonar.sonar import ImagingSonar


def reference_polar(
    sonar: ImagingSonar,
    idx: NDArray[np.int64],
    r: NDArray[np.float64],
    cos_inc: NDArray[np.float64],
    mu: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Display intensity 0…1 (n_bins, n_beams) for hits of rays ``idx`` at slant ranges
    ``r`` (m), |cos incidence| ``cos_inc`` and Lambert μ ``mu``, speckle off.

    Steps: per ray, EL = SL − 2(20 log R + αR) + 10 log(μ cos²β · R²ΔΩ/cos β) + 20 log b_v(φ),
    spread evenly over its range footprint R·δφ·tan β; beam pattern and range blur as
    explicit sums; + noise; + TVG (k log R + 2αR) + gain; map
    [top − DR, top] dB → [0, 1].
    """
    cfg = sonar.config
    g = sonar.geometry
    n_bins, n_beams = sonar.polar_shape
    alpha = cfg.alpha_db_per_m
    raw = [[0.0] * n_beams for _ in range(n_bins)]
    for k in range(len(idx)):
        i = int(idx[k])
        R = float(r[k])
        c = float(cos_inc[k])
        phi = float(g.ray_el[i])
        el_pattern = math.exp(-math.log(2.0) * (phi / (0.5 * math.radians(
            cfg.sonar_spec.beam_width_v_deg))) ** 2)  # fmt: skip
        solid_angle = math.cos(phi) * (g.beam_angles[1] - g.beam_angles[0]) / (
            cfg.rays_per_beam_azimuth
        ) * g.dphi  # fmt: skip
        area = R * R * solid_angle / max(c, 1e-12)
        ts_db = 10.0 * math.log10(max(float(mu[k]) * c * c * area, 1e-300))
        tl_db = 20.0 * math.log10(R) + alpha * R
        el_db = -2.0 * tl_db + ts_db + 20.0 * math.log10(el_pattern)  # re SL
        energy = 10.0 ** (el_db / 10.0)
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

    kb = [float(v) for v in g.beam_kernel]
    kr = [float(v) for v in g.range_kernel]
    hb, hr = len(kb) // 2, len(kr) // 2
    out = np.zeros((n_bins, n_beams))
    for b in range(n_bins):
        Rc = max(cfg.range_min_m + (b + 0.5) * cfg.bin_m, 0.5 * cfg.bin_m)
        tvg = cfg.tvg_spreading_db_per_decade * math.log10(Rc) + 2.0 * alpha * Rc if cfg.tvg else 0
        for j in range(n_beams):
            s = 0.0
            for u in range(-hr, hr + 1):
                for v in range(-hb, hb + 1):
                    bb, jj = b + u, j + v
                    if 0 <= bb < n_bins and 0 <= jj < n_beams:
                        s += kr[u + hr] * kb[v + hb] * raw[bb][jj]
            signal = s * 10.0 ** (cfg.source_level_db / 10.0)
            total = signal + 10.0 ** (cfg.noise_floor_db / 10.0)
            level = 10.0 * math.log10(total) + tvg + cfg.gain_db
            out[b, j] = min(
                max(1.0 + (level - cfg.display_top_db) / cfg.dynamic_range_db, 0.0), 1.0
            )
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
