"""Underwater image formation after Jaffe (1990) and McGlamery (1980), as named stages.

Each stage is a pure function of arrays and the configuration; :mod:`.camera` composes
them. Per channel λ ∈ {R, G, B}, a pixel whose ray hits a surface at range r receives

    E = E_direct + E_forward + B_sun + B_lamps,

* **object radiance** J (:func:`lamplight_on_surface`, :func:`daylight_on_surface`):
  Lambertian albedo ρ times the light reaching the surface — the lamps (cone,
  inverse-square fall-off, attenuation exp(−c·d) on the way out, cosine of incidence)
  and the down-welling daylight, which
  dims with depth as exp(−K_d·z) and lights upward-facing surfaces ((1 + n_up)/2;
  no shadows);
* **direct** (:func:`attenuate`): J·exp(−c·r), c = a + b the beam attenuation;
* **forward scatter** (:func:`forward_scatter`): J·(exp(−G·r) − exp(−c·r)) spread by a
  blur whose angular width grows with range, σ = spread·b·r (Jaffe's B·R_c), G = a + b_b
  (light scattered forward stays near the beam; what is absorbed or scattered backwards
  is lost);
* **veiling light from daylight** (:func:`sun_veiling`): single scattering of the
  down-welling light, irradiance π·L(z) with L(z) = L₀·exp(−K_d·z), into the ray:
  ∫₀ʳ π·L(z₀ + s·d_z)·b·p̃(ψ)·exp(−c·s) ds (closed form), ψ the angle between straight
  down and the way back to the camera, p̃ the water's phase function half smoothed into
  isotropy (half of the down-welling light is diffuse: an assumption); rays that miss
  everything run to the surface (looking up: the bright surface, attenuated) or to
  infinity;
* **veiling light from the lamps** (:func:`lamp_backscatter`): the single-scattering
  integral of :func:`.geometry.lamp_backscatter_along`, tabulated once per config and
  interpolated in range per pixel;
* **sensor** (:func:`expose`): exposure gain (fixed, or auto: mean level to a target),
  shot noise (Poisson, as Gaussian with variance = electrons) and read noise, clipping,
  sRGB transfer curve, 8 bits.

All per-frame arrays are float32.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.camera.config import CameraConfig, Lamp
from uhrisim.sensors.camera.geometry import CameraGeometry, lamp_radiance_at
from uhrisim.sensors.camera.water import WaterOptics

_F32 = np.float32
#: forward-scatter blur levels: Gaussian σ = 2^k pixels, k = 0 … FS_LEVELS − 1
FS_LEVELS = 6


def lamplight_on_surface(
    albedo: NDArray[np.float32],
    points_cam: NDArray[np.float32],
    normals_cam: NDArray[np.float32],
    lamps: tuple[Lamp, ...],
    water: WaterOptics,
) -> NDArray[np.float32]:
    """(N, 3) radiance leaving N Lambertian surface points lit by the lamps: ρ/π times
    the irradiance I·B(θ)·cos(incidence)/d²·exp(−c·d) summed over the lamps.

    ``albedo`` (N, 3); ``points_cam``/``normals_cam`` (N, 3) camera frame (normals facing
    the camera)."""
    if not lamps:
        return np.zeros_like(albedo)
    light = lamp_radiance_at(points_cam, normals_cam, lamps, water.c)
    return albedo * light * _F32(1.0 / math.pi)


def daylight_on_surface(
    albedo: NDArray[np.float32], depth_m: NDArray[np.float32], n_up: NDArray[np.float32],
    water: WaterOptics, sun_radiance: float,
) -> NDArray[np.float32]:
    """(N, 3) radiance of Lambertian surfaces lit by the down-welling daylight
    L₀·exp(−K_d·z): ρ·L(z)·(1 + n_up)/2 (a level floor gets all of it, a wall half)."""
    kd = water.k_d.astype(_F32)
    level = np.exp(-np.maximum(depth_m, _F32(0.0))[:, None] * kd[None, :])
    return albedo * level * (_F32(0.5 * sun_radiance) * (1.0 + n_up))[:, None]


def attenuate(radiance: NDArray[np.float32], range_m: NDArray[np.float32],
              coefficient: NDArray[np.float64]) -> NDArray[np.float32]:
    """radiance·exp(−coefficient·r) per channel; ``range_m`` (N,), radiance (N, 3)."""
    return radiance * np.exp(-range_m[:, None] * coefficient.astype(_F32)[None, :])


def forward_scatter(
    source: NDArray[np.float32], range_img: NDArray[np.float32], water: WaterOptics,
    spread: float, focal_px: float,
) -> NDArray[np.float32]:
    """Forward-scattered light: (H, W, 3) ``source`` (J·(exp(−G·r) − exp(−c·r)), zero
    where nothing was hit) blurred per pixel by a Gaussian of σ = spread·b·r radians
    (× focal length in pixels; b of the green channel), blending between the levels of a
    Gaussian pyramid (σ ≈ 2^k px at level k). Level 0 (no blur) is weighed in at full
    resolution; the blurred levels, smooth by construction, are blended at half
    resolution and brought back to full size bilinearly."""
    sigma_px = np.where(np.isfinite(range_img), range_img, _F32(0.0))
    sigma_px *= _F32(spread * float(water.b[1]) * focal_px)
    top = float(sigma_px.max()) if sigma_px.size else 0.0
    h, w = source.shape[:2]
    if top < 0.5 or min(h, w) < 4:
        return source
    n_levels = min(FS_LEVELS, math.ceil(math.log2(top)) + 2)
    # level index log2(σ) + 1 for σ ≥ 1 px, 0 (no blur) for σ ≤ 0.5 px, linear between
    idx = np.log2(np.maximum(sigma_px, _F32(0.5)))
    idx += _F32(1.0)
    np.clip(idx, 0.0, n_levels - 1.0, out=idx)
    w0 = np.maximum(1.0 - idx, 0.0)
    half = cv2.pyrDown(source)
    hh, hw = half.shape[:2]
    idx_half = cv2.resize(idx, (hw, hh), interpolation=cv2.INTER_NEAREST)
    blurred = np.zeros_like(half)
    small = half
    for k in range(1, n_levels):
        if k > 1:
            small = cv2.pyrDown(small) if min(small.shape[:2]) >= 2 else small
        weight = 1.0 - np.abs(idx_half - _F32(k))
        np.maximum(weight, 0.0, out=weight)
        if not weight.any():
            continue
        level = small if k == 1 else cv2.resize(small, (hw, hh), interpolation=cv2.INTER_LINEAR)
        blurred += level * weight[..., None]
    out = cv2.resize(blurred, (w, h), interpolation=cv2.INTER_LINEAR)
    out += source * w0[..., None]
    return out


@dataclass(frozen=True)
class DaylightPaths:
    """What the daylight veiling light needs of a set of ray directions (NED down
    components ``down``, (N,)): the per-ray factor π·b·p̃(ψ) (N, 3) and x = c + K_d·d_z
    (N, 3, kept away from 0). Depends only on the rays' tilt, so a level vehicle reuses
    it for every heading."""

    down: NDArray[np.float32]
    coefficient: NDArray[np.float32]
    x: NDArray[np.float32]

    @staticmethod
    def of(down: NDArray[np.float32], water: WaterOptics) -> DaylightPaths:
        phase = 0.5 * water.phase(-down.astype(np.float64)) + 0.125 / math.pi
        coefficient = (math.pi * water.b[None, :] * phase[:, None]).astype(_F32)
        x = water.c[None, :] + water.k_d[None, :] * down.astype(np.float64)[:, None]
        x = np.where(np.abs(x) < 1e-6, 1e-6, x).astype(_F32)
        return DaylightPaths(down.astype(_F32), coefficient, x)

    def take(self, rays: NDArray[np.intp] | None) -> DaylightPaths:
        """The paths of a subset of the rays (None: all)."""
        if rays is None:
            return self
        return DaylightPaths(np.take(self.down, rays), np.take(self.coefficient, rays, axis=0),
                             np.take(self.x, rays, axis=0))


def sun_veiling(
    paths: DaylightPaths, range_m: NDArray[np.float32], camera_depth_m: float,
    water: WaterOptics, sun_radiance: float,
) -> NDArray[np.float32]:
    """(N, 3) veiling light (path radiance) from daylight scattered into N rays.

    ``paths``: the rays' :class:`DaylightPaths` (d_z > 0 looks down); ``range_m``: where
    each ray stops (inf: it ran into open water). With L(z) = L₀·exp(−K_d·z),
    x = c + K_d·d_z and cos ψ = −d_z:

        B = π·b·p̃(ψ)·L(z₀)·(1 − exp(−x·r))/x,   p̃ = ½·p + ½/(4π),

    and a ray that leaves upwards through open water ends at the surface
    (r = z₀/(−d_z)) where it adds the surface radiance L₀·exp(−c·r)."""
    if sun_radiance == 0.0:
        return np.zeros((len(range_m), 3), _F32)
    z0 = max(float(camera_depth_m), 0.0)
    r = range_m
    upward = np.flatnonzero(paths.down < 0.0)
    if len(upward):
        up_open = upward[~np.isfinite(range_m[upward])]
        if len(up_open):
            r = range_m.copy()
            r[up_open] = z0 / -paths.down[up_open]
    term = np.expm1(-paths.x * r[:, None])  # −(1 − exp(−x·r)); −1 for r = inf (x > 0)
    term /= paths.x
    term *= paths.coefficient
    term *= veil_scale(camera_depth_m, water, sun_radiance)[None, :]
    if len(upward) and len(up_open):
        term[up_open] += sun_radiance * np.exp(
            -water.c.astype(_F32)[None, :] * r[up_open][:, None])
    return term


def veil_scale(camera_depth_m: float, water: WaterOptics, sun_radiance: float
               ) -> NDArray[np.float32]:
    """(3,) −L(z₀) = −L₀·exp(−K_d·z₀) per channel: :func:`sun_veiling`'s scale."""
    z0 = max(float(camera_depth_m), 0.0)
    return (-sun_radiance * np.exp(-water.k_d * z0)).astype(_F32)


def lamp_backscatter(geometry: CameraGeometry, cells: NDArray[np.int32],
                     range_m: NDArray[np.float32]) -> NDArray[np.float32]:
    """(N, 3) veiling light of the lamps along N rays (their table ``cells``, where they
    stop ``range_m``) from the precomputed table: linear interpolation in range between
    the nodes r_k = R·(k/(K − 1))² (a miss, or a hit beyond R, reads the last node)."""
    table = geometry.backscatter_table
    n_nodes = len(geometry.range_nodes)
    r_max = float(geometry.range_nodes[-1])
    rr = np.minimum(np.where(np.isfinite(range_m), range_m, _F32(r_max)), _F32(r_max))
    kf = np.sqrt(rr * _F32(1.0 / r_max)) * _F32(n_nodes - 1)
    k0 = np.minimum(kf.astype(np.int32), n_nodes - 2)
    frac = (kf - k0)[:, None]
    row = cells * n_nodes + k0
    lo = np.take(table, row, axis=0)
    hi = np.take(table, row + 1, axis=0)
    hi -= lo
    hi *= frac
    hi += lo
    return hi


def srgb_lut(levels: int = 4096) -> NDArray[np.uint8]:
    """8-bit sRGB encoding of ``levels`` linear values in [0, 1] (IEC 61966-2-1)."""
    x = np.linspace(0.0, 1.0, levels)
    y = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(255.0 * y).astype(np.uint8)


def exposure_gain(radiance: NDArray[np.float32], config: CameraConfig) -> float:
    """Radiance → full-scale gain: ``exposure``, or auto (mean level to the target,
    capped by ``max_gain``)."""
    if config.exposure != "auto":
        return float(config.exposure)
    mean = float(radiance.mean(dtype=np.float64))
    if mean <= 0.0:
        return float(config.max_gain)
    return min(config.auto_exposure_target / mean, float(config.max_gain))


def expose(
    radiance: NDArray[np.float32], gain: float, config: CameraConfig,
    noise: NDArray[np.float32] | None, lut: NDArray[np.uint8],
) -> NDArray[np.uint8]:
    """(H, W, 3) linear radiance → 8-bit sRGB: gain, shot + read noise (``noise`` holds unit
    normal draws of the same shape, or None), clip, transfer curve."""
    signal = radiance * _F32(gain)
    np.clip(signal, 0.0, 1.0, out=signal)
    if noise is not None:  # in place, to spare the memory traffic of temporaries
        fw = _F32(config.full_well_e)
        sigma = signal * fw
        sigma += _F32(config.read_noise_e) ** 2
        np.sqrt(sigma, out=sigma)
        sigma *= noise
        sigma *= _F32(1.0) / fw
        signal += sigma
        np.clip(signal, 0.0, 1.0, out=signal)
    signal *= _F32(len(lut) - 1)
    signal += _F32(0.5)
    return np.take(lut, signal.astype(np.uint16))
