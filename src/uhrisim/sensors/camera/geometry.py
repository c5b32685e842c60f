"""What a camera computes once per configuration: pixel rays and the lamp backscatter table.

Pixel (u, v) (u column, right; v row, down) looks along the camera-frame direction
(1, (u − c_x − s·(v − c_y)/f_y)/f_x, (v − c_y)/f_y), normalised (camera frame FRD-like:
x optical axis, y right, z down; see :mod:`.config`).

The lamps' backscatter (veiling light) in a pixel depends only on the pixel's direction
and on how far the ray runs before it hits something — the lamps move with the camera.
So it is integrated once, per channel, on a grid of directions (square cells of about
``CELL_DEG``)
and ``N_RANGE_NODES`` ranges r_k = R·(k/(K − 1))² (dense near the camera, where the lamp
cones enter the view), and looked up per frame (:func:`.formation.lamp_backscatter`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.camera.config import CameraConfig, Lamp
from uhrisim.sensors.camera.water import WaterOptics

#: angular size of a backscatter-table cell at the image centre (a square of pixels)
CELL_DEG = 1.0
#: range nodes of the backscatter table
N_RANGE_NODES = 48
#: integration samples along each direction when building the table
_TABLE_SAMPLES = 160


def pixel_directions(K: NDArray[np.float64], width: int, height: int) -> NDArray[np.float64]:
    """(H·W, 3) unit directions in the camera frame, row-major (v, then u)."""
    fx, s, cx = K[0]
    fy, cy = K[1, 1], K[1, 2]
    v, u = np.mgrid[0:height, 0:width].astype(float)
    y_img = (v - cy) / fy
    x_img = (u - cx - s * y_img) / fx
    d = np.stack([np.ones_like(x_img), x_img, y_img], axis=-1).reshape(-1, 3)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def lamp_beam_kappa(lamp: Lamp) -> float:
    """Concentration κ of the lamp's beam exp(κ·(cos θ − 1)) (θ off the lamp's axis):
    half power at the half-angle, κ = ln 2 / (1 − cos θ½)."""
    return math.log(2.0) / (1.0 - math.cos(math.radians(lamp.half_angle_deg)))


def lamp_radiance_at(
    points_cam: NDArray, normals_cam: NDArray | None, lamps: tuple[Lamp, ...], c: NDArray
) -> NDArray:
    """(N, 3) lamp irradiance per channel at N points (camera frame, m): the sum over the
    lamps of I·exp(κ·(cos θ − 1))/d²·exp(−c·d), times the cosine of incidence on a surface
    with normals ``normals_cam`` (facing the camera), or without it (None: light in the
    water, for scattering). θ is the angle off the lamp's axis (the camera axis), d the
    lamp-to-point distance."""
    dtype = points_cam.dtype
    out = np.zeros((len(points_cam), 3), dtype=dtype)
    cc = np.asarray(c, dtype=dtype)[None, :]
    for lamp in lamps:
        p = points_cam - np.asarray(lamp.position_cam, dtype=dtype)
        inv = 1.0 / np.sqrt(np.einsum("ij,ij->i", p, p))
        kappa = lamp_beam_kappa(lamp)
        weight = (lamp.intensity * inv * inv) * np.exp(kappa * (p[:, 0] * inv - 1.0))
        if normals_cam is not None:
            weight *= np.maximum(-np.einsum("ij,ij->i", normals_cam, p) * inv, 0.0)
        out += weight[:, None] * np.exp(-cc / inv[:, None])
    return out


@dataclass(frozen=True)
class CameraGeometry:
    """Per-configuration arrays (camera frame; metres)."""

    K: NDArray[np.float64]
    dirs_cam: NDArray[np.float64]  # (H·W, 3) unit
    cos_axis: NDArray[np.float32]  # (H·W,) d·x: range → depth along the optical axis
    cell_of_pixel: NDArray[np.int32]  # (H·W,) backscatter-table cell of each pixel
    range_nodes: NDArray[np.float64]  # (N_RANGE_NODES,)
    backscatter_table: NDArray[np.float32] | None  # (cells·N_RANGE_NODES, 3); None: no lamps


def lamp_backscatter_along(
    dirs_cam: NDArray[np.float64], lamps: tuple[Lamp, ...], water: WaterOptics,
    range_nodes: NDArray[np.float64], samples: int = _TABLE_SAMPLES,
) -> NDArray[np.float64]:
    """(N, len(range_nodes), 3) lamp backscatter radiance reaching the camera along each
    direction, integrated from 0 to each range node (single scattering, Jaffe 1990):

        B(r) = ∫₀ʳ β(ψ)·I·B(θ)/d_l²·exp(−c·d_l)·exp(−c·s) ds,   β(ψ) = b·p(ψ),

    d_l the lamp-to-sample distance, ψ the scattering angle between the lamp's ray and
    the way back to the camera. Midpoint rule on ``samples`` points spaced like the nodes
    (denser near the camera)."""
    c, b = water.c, water.b
    r_max = float(range_nodes[-1])
    edges = r_max * np.linspace(0.0, 1.0, samples + 1) ** 2
    mids, widths = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    out = np.zeros((len(dirs_cam), len(range_nodes), 3))
    for a in range(0, len(dirs_cam), 256):
        d = dirs_cam[a : a + 256]
        pts = d[:, None, :] * mids[None, :, None]  # (n, S, 3)
        flat = pts.reshape(-1, 3)
        integrand = np.zeros((len(flat), 3))
        for lamp in lamps:
            p = flat - np.asarray(lamp.position_cam)
            dist = np.linalg.norm(p, axis=1)
            # scattering angle: light along +p, leaves towards the camera along −d
            cos_psi = -np.einsum("ij,ij->i", p / dist[:, None], np.repeat(d, len(mids), 0))
            integrand += lamp_radiance_at(flat, None, (lamp,), c) * (
                b[None, :] * water.phase(cos_psi)[:, None])
        integrand = integrand.reshape(len(d), len(mids), 3)
        integrand *= np.exp(-c[None, None, :] * mids[None, :, None]) * widths[None, :, None]
        cum = np.concatenate([np.zeros((len(d), 1, 3)), np.cumsum(integrand, axis=1)], axis=1)
        for ch in range(3):  # cumulative integral at the nodes (linear between edges)
            out[a : a + 256, :, ch] = np.array(
                [np.interp(range_nodes, edges, row) for row in cum[:, :, ch]])
    return out


def camera_geometry(config: CameraConfig) -> CameraGeometry:
    """Everything the configuration fixes: rays, and the lamp backscatter table."""
    w, h = int(config.width), int(config.height)  # type: ignore[arg-type]
    K = config.intrinsics
    dirs = pixel_directions(K, w, h)
    block = max(1, int(K[0, 0] * math.radians(CELL_DEG)))
    cw, ch = -(-w // block), -(-h // block)
    v, u = np.mgrid[0:h, 0:w]
    cell = ((v // block) * cw + (u // block)).reshape(-1).astype(np.int32)
    nodes = config.max_range_m * np.linspace(0.0, 1.0, N_RANGE_NODES) ** 2
    table = None
    if config.lamps:
        # cell centres (pixel coordinates of the block's middle, clipped to the image)
        cv_, cu_ = np.mgrid[0:ch, 0:cw]
        uc = np.minimum(cu_ * block + 0.5 * (block - 1), w - 1).reshape(-1)
        vc = np.minimum(cv_ * block + 0.5 * (block - 1), h - 1).reshape(-1)
        y_img = (vc - K[1, 2]) / K[1, 1]
        x_img = (uc - K[0, 2] - K[0, 1] * y_img) / K[0, 0]
        cdirs = np.stack([np.ones_like(x_img), x_img, y_img], axis=-1)
        cdirs /= np.linalg.norm(cdirs, axis=1, keepdims=True)
        table = lamp_backscatter_along(cdirs, config.lamps, config.water, nodes)
        table = np.ascontiguousarray(table.reshape(-1, 3), dtype=np.float32)
    return CameraGeometry(
        K=K, dirs_cam=dirs, cos_axis=dirs[:, 0].astype(np.float32), cell_of_pixel=cell,
        range_nodes=nodes, backscatter_table=table)
