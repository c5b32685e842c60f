"""The paper's ``sonar_cloud``: every ray of a ping as a point in the sonar frame.

The **sonar frame** is FRD-like — x along the sonar axis, y to starboard, z down (metres).
:func:`sonar_cloud` forms the cloud of a ping (rays that miss the window are NaN);
:func:`cloud_hits` reads the hits back out of one, as recorders and bridges publish them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.config import SonarConfig
from uhrisim.sensors.sonar.geometry import SonarGeometry


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


def sonar_cloud(
    g: SonarGeometry,
    cfg: SonarConfig,
    idx: NDArray[np.int64],
    cols: NDArray[np.float64],
    ray_disp: NDArray[np.float32],
) -> SonarCloud:
    """The ``sonar_cloud`` of a ping from the rays ``idx`` (indices into the ray fan of
    ``g``) that hit inside the window, their sonar-frame points ``cols`` (3, M), m, and the
    display level 0…1 of every ray's own echo ``ray_disp`` (one per ray of the fan)."""
    n = int(g.dirs_sonar.shape[0])
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
