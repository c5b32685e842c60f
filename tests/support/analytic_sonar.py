"""Analytic scenes for the imaging sonar's tests (no mesh ray caster needed): a flat floor
and a square plate facing the sonar, each expected number computable from the geometry;
small sonar configurations and the hits of a sonar's own window.

Used by tests/unit/test_sonar_image.py and tests/unit/test_sonar_stages.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, SonarSpec
from uhrisim.sensors.sonar.config import ECHOES_ONLY

FLOOR, PLATE = 0, 1


@dataclass(frozen=True)
class Hits:
    distance: np.ndarray
    label: np.ndarray
    normal: np.ndarray
    reflectivity: np.ndarray
    body: np.ndarray


@dataclass(frozen=True)
class AnalyticCaster:
    """Flat floor at depth ``floor_z`` (NED) and an optional square plate of half-size
    ``plate_half`` facing north at north = ``plate_north`` centred on (east 0, depth
    ``plate_z``). Closed-form first hits."""

    floor_z: float | None = 8.0
    floor_mu: float = 0.02
    plate_north: float | None = None
    plate_half: float = 0.05
    plate_z: float = 4.0
    plate_mu: float = 0.2

    def cast(self, origins, directions, max_range, exclude=frozenset()):
        d = np.asarray(directions, float)
        o = np.broadcast_to(np.asarray(origins, float), d.shape)  # (3,): one shared origin
        n = len(d)
        dist = np.full(n, np.inf)
        lab = np.full(n, -1, np.int32)
        nrm = np.zeros((n, 3))
        mu = np.zeros(n)
        if self.floor_z is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (self.floor_z - o[:, 2]) / d[:, 2]
            ok = (d[:, 2] > 0) & (t > 0) & (t < dist)
            dist[ok], lab[ok], mu[ok] = t[ok], FLOOR, self.floor_mu
            nrm[ok] = (0.0, 0.0, -1.0)
        if self.plate_north is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (self.plate_north - o[:, 0]) / d[:, 0]
            p = o + t[:, None] * d
            ok = (
                (d[:, 0] > 0)
                & (np.abs(p[:, 1]) <= self.plate_half)
                & (np.abs(p[:, 2] - self.plate_z) <= self.plate_half)
                & (t < dist)
            )
            dist[ok], lab[ok], mu[ok] = t[ok], PLATE, self.plate_mu
            nrm[ok] = (-1.0, 0.0, 0.0)
        dist[dist > max_range] = np.inf
        miss = ~np.isfinite(dist)
        lab[miss] = -1
        mu[miss] = 0.0
        return Hits(dist, lab, nrm, mu, np.full(n, -1, np.int32))


LEVEL = np.eye(3)
ORIGIN = np.array([0.0, 0.0, 4.0])


def linear_display(polar: np.ndarray, cfg: SonarConfig) -> np.ndarray:
    """Invert the log compression: display-scale intensity (unclipped cells only)."""
    return 10.0 ** ((polar.astype(np.float64) - 1.0) * cfg.dynamic_range_db / 10.0)


def small_cfg(**kw) -> SonarConfig:
    spec = SonarSpec(
        "tiny", 900e3, 8.0, 12, 1.0, 20.0, 100.0, 0.1, 15.0, source="test: small P900-like"
    )
    base = dict(
        spec=spec, range_min_m=8.0, range_max_m=14.0, rays_per_beam=16, tilt_deg=15.0,
        mount_position_frd=(0.0, 0.0, 0.0), speckle=False, rate_hz=10.0, labels=True,
    )  # fmt: skip
    base.update(kw)
    return SonarConfig(**base)


def window_hits(sonar: ImagingSonar, caster) -> tuple[Hits, np.ndarray, np.ndarray]:
    """The hits a ping at (ORIGIN, LEVEL) forms its image from: all hits, the indices of
    the rays that hit inside the cast window (hits just outside the image window spill
    echo into it), and their |cos incidence|."""
    p_s, R_s = sonar.sonar_pose(ORIGIN, LEVEL)
    dirs = sonar.geometry.dirs_sonar @ R_s.T
    hits = caster.cast(np.broadcast_to(p_s, dirs.shape), dirs, sonar.cast_window_m[1])
    near, far = sonar.cast_window_m
    idx = np.flatnonzero((hits.distance >= near) & (hits.distance < far))
    cos_inc = np.abs(np.einsum("ij,ij->i", hits.normal[idx], dirs[idx]))
    return hits, idx, cos_inc


#: A caster with nothing in the water: only the diffuse terms reach the image.
NO_SCENE = AnalyticCaster(floor_z=None)


def level_db(polar: np.ndarray, cfg: SonarConfig) -> np.ndarray:
    """Display level in dB (after TVG and gain) from the log-compressed polar image."""
    return (polar.astype(np.float64) - 1.0) * cfg.dynamic_range_db + cfg.display_top_db


def diffuse_only(**kw) -> SonarConfig:
    """Window 0.5–30 m, no echo (the caster has no scene), speckle off, every diffuse term
    off unless ``kw`` turns it on; a display window wide enough that nothing clips."""
    base = dict(
        spec=SonarSpec("diffuse", 900e3, 8.0, 9, 1.0, 20.0, 100.0, 0.1, 15.0, source="test"),
        range_min_m=0.5, range_max_m=30.0, rays_per_beam=4, tilt_deg=0.0, speckle=False,
        mount_position_frd=(0.0, 0.0, 0.0), rate_hz=10.0, dynamic_range_db=400.0,
        display_top_db=300.0, **ECHOES_ONLY,
    )  # fmt: skip
    base.update(kw)
    return SonarConfig(**base)


def rows_at(cfg: SonarConfig, ranges: list[float]) -> list[int]:
    return [round((r - cfg.range_min_m) / cfg.bin_m - 0.5) for r in ranges]


def acf_fwhm(fields: list[np.ndarray], axis: int) -> float:
    """Full width at half maximum (cells) of the autocorrelation of ``fields`` along
    ``axis``, linearly interpolated between lags."""
    lags = range(0, 40)
    acf = []
    for lag in lags:
        num = den = 0.0
        for f in fields:
            g = f - f.mean()
            a = np.take(g, range(0, g.shape[axis] - lag), axis=axis)
            b = np.take(g, range(lag, g.shape[axis]), axis=axis)
            num += float((a * b).mean())
            den += float((g * g).mean())
        acf.append(num / den)
    acf = np.array(acf)
    m = int(np.argmax(acf < 0.5))
    half = (m - 1) + (acf[m - 1] - 0.5) / (acf[m - 1] - acf[m])
    return 2.0 * half
