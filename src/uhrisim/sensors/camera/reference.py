"""Slow, obviously-correct reference of the camera's image formation (tests hold the fast
stages of :mod:`.formation` to it).

Pixel by pixel, in float64: the surface radiance from the lamps and the daylight, the
direct attenuation, and both veiling-light integrals summed numerically with a fine
midpoint rule along the ray (no table, no closed form). A hit on a textured material
reads its texel here with plain scalar arithmetic (the hit point taken into the body's
frame, then the picture's row and column). Forward scatter and the sensor are left out
(compare with ``forward_scatter=False``, before exposure).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.camera.config import CameraConfig
from uhrisim.sensors.camera.geometry import lamp_beam_kappa, pixel_directions
from uhrisim.world.materials import Material, RippleTexture
from uhrisim.world.objects import DynamicBody
from uhrisim.world.raycast import RayHits


def _surface_albedo(material: Material, point_ned: NDArray, body: DynamicBody | None
                    ) -> NDArray:
    """(3,) albedo of ``material`` at a hit point (NED): its texel where it has a picture
    under the point, else its one albedo. ``body``: the one-part body hit (None: static)."""
    texture = material.texture
    if texture is None:
        return np.asarray(material.albedo_rgb)
    if isinstance(texture, RippleTexture):  # static floors only: the point as it is
        return np.asarray(texture.albedo_over(material.albedo_rgb, point_ned)[0][0], float)
    p = np.asarray(point_ned, dtype=float)
    if body is not None:
        p = body.rotation.T @ (p - body.position)
        part = body.part_transforms[0]
        p = part[:3, :3].T @ (p - part[:3, 3])
    rel = p - np.asarray(texture.origin)
    u = float(rel @ np.asarray(texture.right))
    v = float(rel @ np.asarray(texture.down))
    off = float(rel @ np.cross(texture.right, texture.down))
    if abs(off) > texture.tolerance_m or not (0.0 <= u < texture.width_m
                                              and 0.0 <= v < texture.height_m):
        return np.asarray(material.albedo_rgb)
    rows, cols = texture.image.shape[:2]
    return np.asarray(texture.image[int(v / texture.height_m * rows),
                                    int(u / texture.width_m * cols)], dtype=float)


def _lamp_light(point: NDArray, normal: NDArray | None, config: CameraConfig) -> NDArray:
    """(3,) lamp irradiance at one point (camera frame), with or without a surface."""
    total = np.zeros(3)
    for lamp in config.lamps:
        p = point - np.asarray(lamp.position_cam)
        dist = math.sqrt(float(p @ p))
        cos_theta = p[0] / dist
        e = lamp.intensity * math.exp(lamp_beam_kappa(lamp) * (cos_theta - 1.0)) / dist**2
        if normal is not None:
            e *= max(-float(normal @ p) / dist, 0.0)
        total += e * np.exp(-config.water.c * dist)
    return total


def reference_radiance(
    config: CameraConfig,
    hits: RayHits,
    position_cam_ned: NDArray[np.float64],
    rotation_ned_from_camera: NDArray[np.float64],
    materials: tuple[Material, ...],
    steps: int = 20000,
    bodies: tuple[DynamicBody, ...] = (),
) -> NDArray[np.float64]:
    """(H, W, 3) radiance at the camera (before forward scatter and the sensor) for the
    ray hits of every pixel (row-major), computed one pixel at a time. ``bodies``: the
    scene's bodies (``hits.body`` indexes them), needed where a body is textured."""
    water = config.water
    b, c, kd = water.b, water.c, water.k_d
    h, w = int(config.height), int(config.width)  # type: ignore[arg-type]
    dirs = pixel_directions(config.intrinsics, w, h)
    R = np.asarray(rotation_ned_from_camera, dtype=float)
    z0 = max(float(position_cam_ned[2]), 0.0)
    L0 = config.sun_radiance
    out = np.zeros((h * w, 3))
    for i in range(h * w):
        d_cam = dirs[i]
        d_z = float(R[2] @ d_cam)
        r = float(hits.distance[i])
        if math.isfinite(r):
            material, body = materials[int(hits.material[i])], int(hits.body[i])
            textured_body = bodies[body] if material.texture is not None and body >= 0 else None
            rho = _surface_albedo(material, np.asarray(position_cam_ned) + r * (R @ d_cam),
                                  textured_body)
            n_ned = hits.normal[i]
            depth = z0 + r * d_z
            j = rho * L0 * np.exp(-kd * max(depth, 0.0)) * 0.5 * (1.0 - n_ned[2])
            j = j + rho / math.pi * _lamp_light(d_cam * r, R.T @ n_ned, config)
            out[i] += j * np.exp(-c * r)
            s_end = r
        elif d_z < 0.0:
            s_end = z0 / -d_z  # up through open water to the surface
            out[i] += L0 * np.exp(-c * s_end)
        else:
            s_end = 40.0 / float(np.min(c))  # exp(−40): nothing left beyond
        # daylight veiling: π·b·p̃(ψ)·L(z)·exp(−c·s), cos ψ = −d_z
        ds = s_end / steps
        s = (np.arange(steps) + 0.5) * ds
        p_tilde = 0.5 * float(water.phase(np.array(-d_z))) + 0.125 / math.pi
        sun = math.pi * b[None, :] * p_tilde * L0 * np.exp(
            -kd[None, :] * np.maximum(z0 + s[:, None] * d_z, 0.0) - c[None, :] * s[:, None])
        out[i] += sun.sum(axis=0) * ds
        # lamp veiling: b·p(ψ)·E_lamp(s)·exp(−c·s), ψ between the lamp's ray and −d
        if config.lamps:
            ds = min(s_end, config.max_range_m) / steps
            s = (np.arange(steps) + 0.5) * ds
            points = s[:, None] * d_cam[None, :]
            for lamp in config.lamps:
                p = points - np.asarray(lamp.position_cam)
                dist = np.sqrt(np.sum(p * p, axis=1))
                cos_psi = -(p @ d_cam) / dist
                beam = np.exp(lamp_beam_kappa(lamp) * (p[:, 0] / dist - 1.0))
                irradiance = (lamp.intensity * beam / dist**2)[:, None] * np.exp(
                    -c[None, :] * dist[:, None])
                beta = b[None, :] * water.phase(cos_psi)[:, None]
                out[i] += (beta * irradiance * np.exp(-c[None, :] * s[:, None])).sum(axis=0) * ds
    return out.reshape(h, w, 3)
