"""The underwater camera: pixel rays → ray cast → image formation → 8-bit RGB, per frame.

Casts one ray per pixel through the world's shared ray caster (the one the sonar uses),
then composes the stages of :mod:`.formation`. The depth and label images come from the
same rays. Everything that depends only on the configuration (rays, the lamps'
backscatter table, the sRGB table, a pool of noise draws) is computed once here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.camera import formation as fm
from uhrisim.sensors.camera import fused
from uhrisim.sensors.camera.config import CameraConfig
from uhrisim.sensors.camera.geometry import camera_geometry
from uhrisim.sensors.camera.sampling import AdaptiveGrid, smooth_of
from uhrisim.sensors.camera.textures import SceneTextures
from uhrisim.sensors.camera.water import through_cloud
from uhrisim.sensors.sonar.geometry import mount_rotation, mounted_pose
from uhrisim.world.raycast import RayCaster, RayHits

_F32 = np.float32
#: a local cloud's optical depth and veil are computed every this many pixels
_MEDIUM_STEP = 8


class TurbidMedium(Protocol):
    """A local cloud in the water (:class:`uhrisim.world.silt.SiltMedium`)."""

    def optical_depth(self, origin_ned: NDArray[np.float64], directions: NDArray[np.float64],
                      ends: NDArray[np.float32]) -> NDArray[np.float64]:
        """(N,) extra optical depth along rays from ``origin_ned`` up to ``ends`` (m)."""
        ...


def _linear_weights(samples: NDArray[np.intp], n: int) -> NDArray[np.float32]:
    """(n, len(samples)) weights that interpolate linearly, at every index 0…n−1, between
    values given at the increasing indices ``samples`` (which start at 0, end at n − 1)."""
    eye = np.eye(len(samples), dtype=np.float64)
    at = np.arange(n)
    return np.stack([np.interp(at, samples, col) for col in eye], axis=1).astype(_F32)


@dataclass(frozen=True)
class _Rays:
    """A set of the camera's pixel rays: camera-frame directions, cos of their angle to
    the optical axis, backscatter-table cells and daylight factors."""

    dirs_cam: NDArray[np.float64]
    cos_axis: NDArray[np.float32]
    cells: NDArray[np.int32]
    paths: fm.DaylightPaths


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
        #: the compiled formation's constants (None: the numpy stages, :mod:`.fused`)
        self._fused = (fused.OpticsConstants.of(config, self.geometry.backscatter_table,
                                                self.geometry.range_nodes)
                       if fused.available() else None)
        h, w = self.shape
        self._paths: tuple[bytes, fm.DaylightPaths] | None = None
        self._grid = AdaptiveGrid.of(h, w) if config.sampling == "adaptive" else None
        self._coarse_rays: tuple[fm.DaylightPaths, _Rays] | None = None
        #: share of the pixels that got their own ray in the last adaptive frame
        self.last_exact_fraction = 1.0
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
        return mounted_pose(position_ned, rotation_body_to_ned, self.mount_position,
                            self.mount_rotation)

    def capture(
        self,
        raycaster: RayCaster,
        position_ned: NDArray[np.float64],
        rotation_body_to_ned: NDArray[np.float64],
        t: float,
        exclude: frozenset[str] = frozenset(),
        medium: TurbidMedium | None = None,
    ) -> CameraFrame:
        """Render one frame from the vehicle pose (position NED m, rotation body→NED);
        ``exclude`` names bodies the camera cannot see (its own vehicle); ``medium``: a
        local cloud in the water (silt) that veils what lies behind it
        (:meth:`_through_medium`)."""
        cfg, geo = self.config, self.geometry
        h, w = self.shape
        origin, R = self.camera_pose(position_ned, rotation_body_to_ned)
        if not (np.isfinite(origin).all() and np.isfinite(R).all()):  # (its casts skip checks)
            raise ConfigError(f"camera pose must be finite, got {origin.tolist()}",
                              where="UnderwaterCamera.capture")
        scene = raycaster.scene
        materials = tuple(getattr(scene, "materials", ()))
        albedo = np.array([m.albedo_rgb for m in materials] or [[0.0] * 3], _F32)
        textures = SceneTextures.of(materials, tuple(getattr(scene, "bodies", ())))

        def form(rays: _Rays) -> tuple[RayHits, NDArray, NDArray, NDArray]:
            # einsum, not @: a BLAS product of these skinny shapes spawns threads, which
            # costs far more than it saves on a busy machine (compiled: the same bits)
            dirs = (np.einsum("ij,kj->ik", rays.dirs_cam, R) if self._fused is None
                    else fused.rotated(rays.dirs_cam, R))
            hits = raycaster.cast(origin, dirs, cfg.max_range_m, exclude, checked=False)
            r = hits.distance.astype(_F32)
            light, fs = self._light(hits, r, rays, origin, R, albedo, textures)
            return hits, r, light, fs

        if self._grid is None:  # one ray per pixel
            hits, range_m, light, fs = form(self._rays(R, None))
            labels = hits.label.astype(np.int16)
        else:
            light, fs, range_m, labels = self._adaptive(form, R, textures)
        light, fs = light.reshape(h, w, 3), fs.reshape(h, w, 3)
        radiance = light
        if cfg.forward_scatter and cfg.forward_scatter_spread > 0.0:
            blur = (range_m.reshape(h, w), cfg.water, cfg.forward_scatter_spread,
                    float(geo.K[0, 0]))
            radiance = (light + fm.forward_scatter(fs, *blur) if self._fused is None
                        else fused.with_forward_scatter(light, fs, *blur))
        if medium is not None:
            radiance = self._through_medium(radiance, range_m, origin, R, medium)
        gain = fm.exposure_gain(radiance, cfg)
        noise = None
        if self._noise_pool is not None:
            start = int(self.rng.integers(0, h * w * 3))
            noise = self._noise_pool[start : start + h * w * 3].reshape(h, w, 3)
        expose = fm.expose if self._fused is None else fused.expose
        rgb = expose(radiance, gain, cfg, noise, self._lut)
        depth = range_m * geo.cos_axis
        depth[~np.isfinite(range_m)] = np.nan
        return CameraFrame(
            t=float(t), rgb=rgb, radiance=radiance, range_m=range_m.reshape(h, w),
            depth_m=depth.reshape(h, w), labels=labels.reshape(h, w),
            label_names=tuple(getattr(scene, "labels", ())), gain=gain, K=geo.K.copy(),
            position_ned=origin, rotation_ned_from_camera=R)

    def _adaptive(self, form: Callable[[_Rays], tuple[RayHits, NDArray, NDArray, NDArray]],
                  R: NDArray[np.float64], textures: SceneTextures | None
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """Adaptive sampling (:mod:`.sampling`): ``form`` the coarse grid's rays, then the
        rays of the cells that are not smooth (a cell with a corner on a sharp picture
        never is: its printed cells vary within a surface); everything else
        interpolated. Returns the (H·W, 3) light and forward-scatter source, (H·W,) range
        and labels."""
        grid, geo = self._grid, self.geometry
        assert grid is not None
        hc, wc = grid.coarse_shape
        coarse = self._rays(R, grid.coarse)
        hits_c, range_c, light_c, fs_c = form(coarse)
        inverse_depth = 1.0 / (range_c * coarse.cos_axis)  # 0 for open water
        sharp = None if textures is None else textures.sharp(hits_c.material).reshape(hc, wc)
        r_seen = np.where(np.isfinite(range_c), range_c, _F32(0.0))
        points = coarse.dirs_cam * r_seen[:, None]
        normals = (np.einsum("ij,jk->ik", hits_c.normal, R) if self._fused is None
                   else fused.rotated(hits_c.normal, R, transposed=True))  # camera frame
        smooth = smooth_of(*(a.reshape(hc, wc) for a in (hits_c.label, hits_c.body,
                                                         hits_c.material)),
                           sharp, grid, points.reshape(hc, wc, 3), normals.reshape(hc, wc, 3),
                           r_seen.reshape(hc, wc), self._fused is not None)
        exact = grid.exact_pixels(smooth)
        self.last_exact_fraction = len(exact) / len(geo.cos_axis)
        light, fs, range_m, labels = grid.fill(
            light_c.reshape(hc, wc, 3), fs_c.reshape(hc, wc, 3),
            inverse_depth.reshape(hc, wc), hits_c.label.astype(np.int16).reshape(hc, wc),
            geo.cos_axis, self._fused is not None)
        if len(exact):
            hits_e, range_e, light_e, fs_e = form(self._rays(R, exact))
            light[exact], fs[exact], range_m[exact] = light_e, fs_e, range_e
            labels[exact] = hits_e.label
        range_m[grid.coarse] = range_c
        return light, fs, range_m, labels

    def _through_medium(self, radiance: NDArray[np.float32], range_m: NDArray[np.float32],
                        origin: NDArray[np.float64], R: NDArray[np.float64],
                        medium: TurbidMedium) -> NDArray[np.float32]:
        """``radiance`` (H, W, 3) seen through ``medium`` by Koschmieder's law
        (:func:`.water.through_cloud`). The optical depth and the water's path radiance
        L_∞ (daylight veil and lamp backscatter of a ray into open water) are computed on
        a grid of every ``_MEDIUM_STEP``-th pixel (a cloud is smooth on that scale: its
        puffs are tens of centimetres wide) and interpolated bilinearly."""
        geo, cfg = self.geometry, self.config
        h, w = self.shape
        rows = np.unique(np.append(np.arange(0, h, _MEDIUM_STEP), h - 1))
        cols = np.unique(np.append(np.arange(0, w, _MEDIUM_STEP), w - 1))
        pixels = (rows[:, None] * w + cols[None, :]).reshape(-1)
        dirs = np.einsum("ij,kj->ik", np.take(geo.dirs_cam, pixels, axis=0), R)
        tau = medium.optical_depth(origin, dirs, np.take(range_m, pixels))
        if not np.any(tau > 0.0):
            return radiance
        paths = self._daylight_paths(R).take(pixels)
        far = np.full(len(pixels), np.inf, _F32)
        background = fm.sun_veiling(paths, far, float(origin[2]), cfg.water, cfg.sun_radiance)
        if geo.backscatter_table is not None:
            background += fm.lamp_backscatter(geo, np.take(geo.cell_of_pixel, pixels), far)
        across_rows, across_cols = _linear_weights(rows, h), _linear_weights(cols, w)

        def fill(grid: NDArray) -> NDArray[np.float32]:
            """(H, W, C) bilinear fill of the grid's values (rows, then columns)."""
            by_row = across_rows @ grid.reshape(len(rows), -1).astype(_F32)  # (H, cols·C)
            return np.matmul(across_cols, by_row.reshape(h, len(cols), -1))

        return through_cloud(radiance, fill(tau)[..., 0], fill(background))

    def _daylight_paths(self, R: NDArray[np.float64]) -> fm.DaylightPaths:
        """The rays' daylight factors for camera rotation ``R`` (cached on its tilt: the
        down components of the rays change only when the camera's down axis does)."""
        key = R[2].tobytes()
        if self._paths is None or self._paths[0] != key:
            down = np.einsum("ij,j->i", self.geometry.dirs_cam, R[2]).astype(_F32)
            self._paths = (key, fm.DaylightPaths.of(down, self.config.water))
        return self._paths[1]

    def _rays(self, R: NDArray[np.float64], pixels: NDArray[np.intp] | None) -> _Rays:
        """What the formation needs of the rays of ``pixels`` (None: every pixel) for the
        camera rotation ``R``; the coarse grid's is kept between frames (for one tilt)."""
        paths = self._daylight_paths(R)
        geo = self.geometry
        if pixels is None:
            return _Rays(geo.dirs_cam, geo.cos_axis, geo.cell_of_pixel, paths)
        coarse = self._grid is not None and pixels is self._grid.coarse
        if coarse and self._coarse_rays is not None and self._coarse_rays[0] is paths:
            return self._coarse_rays[1]
        rays = _Rays(np.take(geo.dirs_cam, pixels, axis=0), np.take(geo.cos_axis, pixels),
                     np.take(geo.cell_of_pixel, pixels), paths.take(pixels))
        if coarse:
            self._coarse_rays = (paths, rays)
        return rays

    def _light(self, hits: RayHits, range_m: NDArray[np.float32], rays: _Rays,
               origin: NDArray[np.float64], R: NDArray[np.float64],
               albedo_table: NDArray[np.float32], textures: SceneTextures | None
               ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """(N, 3) radiance reaching the camera along ``rays`` without forward scatter —
        direct light and both veils — and (N, 3) the forward-scatter source
        J·(exp(−G·r) − exp(−c·r)): the stages of :mod:`.formation`. Hits on a textured
        material take their albedo from its texture (:mod:`.textures`)."""
        cfg, geo, water = self.config, self.geometry, self.config.water
        paths = rays.paths
        if self._fused is not None:
            albedo_rows = None  # the kernel renders ripples; pictures come from here
            if textures is not None and textures.sharp(hits.material).any():
                albedo_rows = self._albedo(None, hits, rays, origin, R, albedo_table,
                                           textures, textures.sharp)
            return fused.light_of_rays(
                self._fused, hits.distance, hits.material, hits.normal, albedo_table,
                textures, albedo_rows, rays.dirs_cam, paths.down, paths.coefficient,
                paths.x, rays.cells, origin, R, cfg.sun_radiance,
                fm.veil_scale(float(origin[2]), water, cfg.sun_radiance))
        hit = np.flatnonzero(hits.material >= 0)
        r_hit = range_m[hit]
        albedo = self._albedo(hit, hits, rays, origin, R, albedo_table, textures,
                              None if textures is None else textures.textured)
        normal_ned = np.take(hits.normal, hit, axis=0).astype(_F32)
        depth_hit = np.take(paths.down, hit) * r_hit + _F32(origin[2])
        source = fm.daylight_on_surface(albedo, depth_hit, -normal_ned[:, 2], water,
                                        cfg.sun_radiance)
        if cfg.lamps:
            points_cam = np.take(rays.dirs_cam, hit, axis=0).astype(_F32) * r_hit[:, None]
            normals_cam = np.einsum("ij,jk->ik", normal_ned, R.astype(_F32))
            source += fm.lamplight_on_surface(albedo, points_cam, normals_cam, cfg.lamps,
                                              water)
        total = fm.sun_veiling(paths, range_m, float(origin[2]), water, cfg.sun_radiance)
        direct = fm.attenuate(source, r_hit, water.c)
        fs = np.zeros_like(total)
        if cfg.forward_scatter and cfg.forward_scatter_spread > 0.0:
            fs[hit] = fm.attenuate(source, r_hit, water.a + water.b_b) - direct
        total[hit] += direct
        if geo.backscatter_table is not None:
            total += fm.lamp_backscatter(geo, rays.cells, range_m)
        return total, fs

    @staticmethod
    def _albedo(rows: NDArray[np.intp] | None, hits: RayHits, rays: _Rays,
                origin: NDArray[np.float64], R: NDArray[np.float64],
                albedo_table: NDArray[np.float32], textures: SceneTextures | None,
                textured: Callable[[NDArray[np.int32]], NDArray[np.bool_]] | None
                ) -> NDArray[np.float32]:
        """(N, 3) albedo of the hits ``rows`` (None: every ray; a miss reads any row):
        the material's, or its texture's at the hit point where ``textured`` (of the
        materials) says so."""
        material = hits.material if rows is None else np.take(hits.material, rows)
        albedo = np.take(albedo_table, material, axis=0)
        if textures is None or textured is None:
            return albedo
        on = np.flatnonzero(textured(material))
        if len(on):
            ray = on if rows is None else np.take(rows, on)
            points = origin + np.einsum("ij,kj->ik", np.take(rays.dirs_cam, ray, axis=0), R) \
                * np.take(hits.distance, ray)[:, None]
            albedo[on] = textures.albedo(np.take(albedo, on, axis=0), np.take(material, on),
                                         np.take(hits.body, ray), points)
        return albedo
