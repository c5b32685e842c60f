"""The underwater camera: pixel rays → ray cast → image formation → 8-bit RGB, per frame.

Casts one ray per pixel through the world's shared ray caster (the one the sonar uses),
then composes the stages of :mod:`.formation`. The depth and label images come from the
same rays. Everything that depends only on the configuration (rays, the lamps'
backscatter table, the sRGB table, a pool of noise draws) is computed once here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.camera import formation as fm
from uhrisim.sensors.camera.config import CameraConfig
from uhrisim.sensors.camera.geometry import camera_geometry
from uhrisim.sensors.sonar.geometry import mount_rotation
from uhrisim.world.materials import Material
from uhrisim.world.raycast import RayCaster, RayHits

_F32 = np.float32


@dataclass(frozen=True)
class CameraFrame:
    """One camera frame (arrays are the frame's own).

    Attributes:
        t: simulation time (s).
        rgb: (H, W, 3) uint8 sRGB image.
        radiance: (H, W, 3) float32 linear radiance before the sensor (relative units).
        range_m: (H, W) float32 distance along each pixel's ray to the surface hit (m);
            inf where nothing was hit within ``max_range_m``.
        depth_m: (H, W) float32 depth along the optical axis (REP-118 depth image: range
            × cos of the ray's angle to the axis); NaN where nothing was hit.
        labels: (H, W) int16 index into ``label_names`` of the object seen; -1 for water.
        label_names: the scene's label strings.
        gain: the exposure gain used (radiance → full scale).
        K: (3, 3) intrinsic matrix (pixels).
        position_ned: (3,) camera centre (m, NED).
        rotation_ned_from_camera: (3, 3) camera frame (x axis, y right, z down) → NED.
    """

    t: float
    rgb: NDArray[np.uint8]
    radiance: NDArray[np.float32]
    range_m: NDArray[np.float32]
    depth_m: NDArray[np.float32]
    labels: NDArray[np.int16]
    label_names: tuple[str, ...]
    gain: float
    K: NDArray[np.float64]
    position_ned: NDArray[np.float64]
    rotation_ned_from_camera: NDArray[np.float64]

    @property
    def shape(self) -> tuple[int, int]:
        return self.rgb.shape[0], self.rgb.shape[1]


class UnderwaterCamera:
    """A pinhole camera with underwater image formation, bound to a config and a Generator.

    ``capture(raycaster, position_ned, rotation_body_to_ned, t)`` renders a frame. The
    Generator (sensor noise) is the only state that changes between frames.
    """

    def __init__(self, config: CameraConfig, rng: np.random.Generator) -> None:
        if not isinstance(config, CameraConfig):
            raise ConfigError(f"expected a CameraConfig, got {type(config).__name__}", "config")
        if not isinstance(rng, np.random.Generator):
            raise ConfigError(f"expected a numpy Generator, got {type(rng).__name__}", "rng")
        self.config = config
        self.rng = rng
        self.mount_rotation = mount_rotation(config.tilt_deg, config.yaw_deg)  # type: ignore[arg-type]
        self.mount_position = np.asarray(config.mount_position_frd, dtype=float)
        self.geometry = camera_geometry(config)
        self._lut = fm.srgb_lut()
        h, w = self.shape
        self._paths: tuple[bytes, fm.DaylightPaths] | None = None
        # Sensor noise: a pool of unit normal draws twice the image, read at a random offset
        # each frame (one integer draw per frame instead of 3·H·W normals).
        self._noise_pool = (
            rng.standard_normal(2 * h * w * 3, dtype=np.float32) if config.noise else None)

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) in pixels."""
        return int(self.config.height), int(self.config.width)  # type: ignore[arg-type]

    def camera_pose(
        self, position_ned: NDArray[np.float64], rotation_body_to_ned: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera centre (NED, m) and rotation camera → NED for a vehicle pose."""
        p = np.asarray(position_ned, dtype=float).reshape(3)
        R = np.asarray(rotation_body_to_ned, dtype=float).reshape(3, 3)
        return p + R @ self.mount_position, R @ self.mount_rotation

    def capture(
        self,
        raycaster: RayCaster,
        position_ned: NDArray[np.float64],
        rotation_body_to_ned: NDArray[np.float64],
        t: float,
        exclude: frozenset[str] = frozenset(),
    ) -> CameraFrame:
        """Render one frame from the vehicle pose (position NED m, rotation body→NED);
        ``exclude`` names bodies the camera cannot see (its own vehicle)."""
        cfg, geo = self.config, self.geometry
        h, w = self.shape
        origin, R = self.camera_pose(position_ned, rotation_body_to_ned)
        # einsum, not @: a BLAS product of these skinny shapes spawns threads, which costs
        # far more than it saves on a busy machine
        dirs_ned = np.einsum("ij,kj->ik", geo.dirs_cam, R)
        hits = raycaster.cast(origin, dirs_ned, cfg.max_range_m, exclude)
        rng32 = hits.distance.astype(_F32)
        scene = raycaster.scene
        radiance = self._radiance(hits, rng32, origin, R, getattr(scene, "materials", ()))
        gain = fm.exposure_gain(radiance, cfg)
        noise = None
        if self._noise_pool is not None:
            start = int(self.rng.integers(0, h * w * 3))
            noise = self._noise_pool[start : start + h * w * 3].reshape(h, w, 3)
        rgb = fm.expose(radiance, gain, cfg, noise, self._lut)
        depth = rng32 * geo.cos_axis
        depth[~np.isfinite(rng32)] = np.nan
        scene_labels = getattr(scene, "labels", ())
        return CameraFrame(
            t=float(t), rgb=rgb, radiance=radiance, range_m=rng32.reshape(h, w),
            depth_m=depth.reshape(h, w), labels=hits.label.astype(np.int16).reshape(h, w),
            label_names=tuple(scene_labels), gain=gain, K=geo.K.copy(),
            position_ned=origin, rotation_ned_from_camera=R)

    def _daylight_paths(self, R: NDArray[np.float64]) -> fm.DaylightPaths:
        """The rays' daylight factors for camera rotation ``R`` (cached on its tilt: the
        down components of the rays change only when the camera's down axis does)."""
        key = R[2].tobytes()
        if self._paths is None or self._paths[0] != key:
            down = np.einsum("ij,j->i", self.geometry.dirs_cam, R[2]).astype(_F32)
            self._paths = (key, fm.DaylightPaths.of(down, self.config.water))
        return self._paths[1]

    def _radiance(self, hits: RayHits, range_m: NDArray[np.float32],
                  origin: NDArray[np.float64], R: NDArray[np.float64],
                  materials: tuple[Material, ...]) -> NDArray[np.float32]:
        """(H, W, 3) linear radiance at the camera: the stages of :mod:`.formation`."""
        cfg, geo, water = self.config, self.geometry, self.config.water
        h, w = self.shape
        paths = self._daylight_paths(R)
        hit = np.flatnonzero(hits.material >= 0)
        r_hit = range_m[hit]
        albedo_table = np.array([m.albedo_rgb for m in materials] or [[0.0] * 3], _F32)
        albedo = np.take(albedo_table, np.take(hits.material, hit), axis=0)
        normal_ned = np.take(hits.normal, hit, axis=0).astype(_F32)
        depth_hit = np.take(paths.down, hit) * r_hit + _F32(origin[2])
        source = fm.daylight_on_surface(albedo, depth_hit, -normal_ned[:, 2], water,
                                        cfg.sun_radiance)
        if cfg.lamps:
            points_cam = np.take(geo.dirs_cam, hit, axis=0).astype(_F32) * r_hit[:, None]
            normals_cam = np.einsum("ij,jk->ik", normal_ned, R.astype(_F32))
            source += fm.lamplight_on_surface(albedo, points_cam, normals_cam, cfg.lamps,
                                              water)
        total = fm.sun_veiling(paths, range_m, float(origin[2]), water, cfg.sun_radiance)
        direct = fm.attenuate(source, r_hit, water.c)
        if cfg.forward_scatter and cfg.forward_scatter_spread > 0.0:
            fs = np.zeros((h * w, 3), _F32)
            fs[hit] = fm.attenuate(source, r_hit, water.a + water.b_b) - direct
            total += fm.forward_scatter(
                fs.reshape(h, w, 3), range_m.reshape(h, w), water, cfg.forward_scatter_spread,
                float(geo.K[0, 0])).reshape(-1, 3)
        total[hit] += direct
        if geo.backscatter_table is not None:
            total += fm.lamp_backscatter(geo, range_m)
        return total.reshape(h, w, 3)
