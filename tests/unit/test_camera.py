"""The underwater camera: physics of the image formation, geometry, labels, config errors.

Coefficients are the documented ones (docs/camera.md, water types table: Droske et al.,
SIGGRAPH 2023 Courses, RGB reductions of Solonenko & Mobley, Appl. Opt. 54 (2015)),
written out here so that a wrong table in the code fails the test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, WaterOptics, jerlov, measured
from uhrisim.sensors.camera.reference import reference_radiance
from uhrisim.world import primitives as prim
from uhrisim.world.materials import Material
from uhrisim.world.paper_scenes import add_diver, pier_scene
from uhrisim.world.scene import Scene

# docs/camera.md water table: (a, b) per channel R, G, B in 1/m, molecular share of b
DOCUMENTED = {
    "IB": ((0.309, 0.054, 0.015), (0.045, 0.054, 0.070), 0.06),
    "1C": ((0.316, 0.067, 0.105), (0.274, 0.372, 0.526), 0.005),
    "3C": ((0.508, 0.052, 0.161), (0.904, 1.071, 1.532), 0.003),
    "9C": ((0.398, 0.349, 0.995), (2.347, 3.180, 4.496), 0.0),
}
GREY = Material("grey-card", 0.1, (0.5, 0.5, 0.5))
CAMERA_DEPTH = 10.0


def _hg(cos_t: float, g: float) -> float:
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cos_t) ** 1.5)


def _documented_optics(name: str):
    """c, b, K_d and the smoothed phase at 90° from the documented numbers and formulas."""
    a, b, w = (np.array(v) if i < 2 else v for i, v in enumerate(DOCUMENTED[name]))
    g = 0.924
    bp = (1 - g) / (2 * g) * ((1 + g) / math.sqrt(1 + g * g) - 1)  # HG back fraction
    bb = b * (0.5 * w + (1 - w) * bp)
    kd = 1.0395 * (a + bb)  # Gordon (1989), sun at the zenith
    p90 = 0.5 * (w * _hg(0.0, 0.0) + (1 - w) * _hg(0.0, g)) + 0.125 / math.pi
    return a + b, b, kd, p90


def _wall_scene(range_m: float) -> Scene:
    """A large grey wall whose face is ``range_m`` north of the camera, facing it."""
    scene = Scene()
    wall = prim.box((1.0, 40.0, 40.0), (range_m + 0.5, 0.0, CAMERA_DEPTH))
    scene.add_static(wall, "wall", GREY)
    return scene


def _camera(water: WaterOptics, **kw) -> UnderwaterCamera:
    cfg = dict(width=9, height=7, hfov_deg=40.0, water=water, mount_position_frd=(0, 0, 0),
               tilt_deg=0.0, noise=False, exposure=1.0, sampling="full")
    cfg.update(kw)
    return UnderwaterCamera(CameraConfig(**cfg), np.random.default_rng(1))


def _centre_radiance(scene: Scene, camera: UnderwaterCamera) -> np.ndarray:
    frame = camera.capture(scene.raycaster(), (0.0, 0.0, CAMERA_DEPTH), np.eye(3), 0.0)
    return frame.radiance[3, 4].astype(float)  # the pixel on the optical axis


@pytest.mark.parametrize("name", sorted(DOCUMENTED))
def test_grey_target_colour_follows_exp_minus_c_r(name):
    """A daylit grey wall: received = J·exp(−c·r) + veiling light, per channel, with the
    documented coefficients; the log-slope of the direct part is −c."""
    c, b, kd, p90 = _documented_optics(name)
    camera = _camera(jerlov(name), lamps_on=False, forward_scatter=False)
    light = np.exp(-kd * CAMERA_DEPTH)  # L(z)/L0
    j = 0.5 * light * 0.5  # albedo 0.5, a vertical wall gets (1 + 0)/2 of the daylight
    ranges = np.array([0.25, 0.5, 1.0, 2.0]) * (3.0 / float(c.max()))
    direct = []
    for r in ranges:
        got = _centre_radiance(_wall_scene(r), camera)
        veil = math.pi * b * p90 * light * (1 - np.exp(-c * r)) / c
        np.testing.assert_allclose(got, j * np.exp(-c * r) + veil, rtol=2e-5)
        direct.append(got - veil)
    slope = np.polyfit(ranges, np.log(np.array(direct)), 1)[0]
    np.testing.assert_allclose(slope, -c, rtol=1e-3)


def _open_water_mean(water: WaterOptics, **kw) -> np.ndarray:
    camera = _camera(water, width=33, height=25, hfov_deg=70.0, **kw)
    frame = camera.capture(Scene().raycaster(), (0.0, 0.0, kw.pop("depth", CAMERA_DEPTH)),
                           np.eye(3), 0.0)
    assert np.all(frame.labels == -1)
    return frame.radiance.reshape(-1, 3).mean(axis=0).astype(float)


def test_lamp_backscatter_grows_with_turbidity_and_lamp_power():
    dark = dict(sun_radiance=0.0, forward_scatter=False)
    veil = [_open_water_mean(jerlov(n), **dark) for n in ("IB", "II", "III")]
    assert np.all(np.diff(np.array(veil), axis=0) > 0), veil
    coastal = [_open_water_mean(jerlov(n), **dark) for n in ("1C", "3C", "7C", "9C")]
    assert np.all(np.diff(np.array(coastal).sum(axis=1)) > 0), coastal
    one = _open_water_mean(jerlov("1C"), lamp_power=1.0, **dark)
    two = _open_water_mean(jerlov("1C"), lamp_power=2.0, **dark)
    assert np.all(one > 0)
    np.testing.assert_allclose(two, 2.0 * one, rtol=1e-5)  # single scattering: linear
    assert np.all(_open_water_mean(jerlov("1C"), lamps_on=False, **dark) == 0.0)


def test_daylight_veil_grows_with_turbidity_near_the_surface():
    """Looking level just below the surface, the veil tends to π·b·p̃·L₀/c: more
    scattering per attenuation, more veil (deeper down, turbid water also dims the
    daylight, so there it need not grow)."""
    lit = dict(lamps_on=False, forward_scatter=False)
    means = []
    for name in ("IB", "II", "III"):
        camera = _camera(jerlov(name), width=33, height=25, **lit)
        frame = camera.capture(Scene().raycaster(), (0.0, 0.0, 0.01), np.eye(3), 0.0)
        means.append(frame.radiance[12, 16])  # on the axis: level
    assert np.all(np.diff(np.array(means), axis=0) > 0), means


def _diver_scene():
    ps = pier_scene(with_diver=True)
    ps.scene.set_pose("diver", (3.0, 0.4, 3.4), rot_z(0.5), 1.0)
    return ps.scene


@pytest.mark.slow
def test_depth_image_is_the_ray_cast_distance_and_labels_the_scene_objects():
    scene = _diver_scene()
    cfg = CameraConfig(width=48, height=36, hfov_deg=70.0, water=jerlov("IB"),
                       mount_position_frd=(0.2, 0.0, 0.0), tilt_deg=10.0, noise=False,
                       sampling="full")
    camera = UnderwaterCamera(cfg, np.random.default_rng(0))
    body_R = rot_z(0.1)
    frame = camera.capture(scene.raycaster(), (0.0, 0.0, 3.0), body_R, 2.5)
    # Independent rays: K⁻¹ (u, v, 1) in the optical frame (x right, y down, z forward),
    # to the camera frame (forward, right, down), mount tilt (pitch −10°), then body yaw.
    K = cfg.intrinsics
    v, u = np.mgrid[0:36, 0:48]
    opt = np.linalg.solve(K, np.stack([u.ravel(), v.ravel(), np.ones(u.size)]))
    cam = np.stack([opt[2], opt[0], opt[1]], axis=1)
    cam /= np.linalg.norm(cam, axis=1, keepdims=True)
    t = math.radians(10.0)
    tilt = np.array([[math.cos(t), 0, -math.sin(t)], [0, 1, 0], [math.sin(t), 0, math.cos(t)]])
    R = body_R @ tilt
    origin = np.array([0.0, 0.0, 3.0]) + body_R @ np.array([0.2, 0.0, 0.0])
    np.testing.assert_allclose(frame.rotation_ned_from_camera, R, atol=1e-12)
    ref = scene.raycaster("reference").cast(origin, cam @ R.T, cfg.max_range_m)
    hit = ref.hit.reshape(36, 48)
    assert hit.mean() > 0.5
    np.testing.assert_array_equal(np.isfinite(frame.range_m), hit)
    np.testing.assert_allclose(frame.range_m[hit], ref.distance.reshape(36, 48)[hit],
                               rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(frame.depth_m[hit], (ref.distance * cam[:, 0]).reshape(36, 48)[hit],
                               rtol=1e-6, atol=1e-5)
    assert np.all(np.isnan(frame.depth_m[~hit]))
    np.testing.assert_array_equal(frame.labels, ref.label.reshape(36, 48))
    names = frame.label_names
    assert {names[i] for i in np.unique(frame.labels[frame.labels >= 0])} == {
        "seafloor", "piling", "diver"}
    # the diver's centre projects onto a pixel labelled "diver"
    p_cam = R.T @ (np.array([3.0, 0.4, 3.4]) + rot_z(0.5) @ [0.55, 0, 0] - origin)
    uv = K @ np.array([p_cam[1], p_cam[2], p_cam[0]]) / p_cam[0]
    assert names[frame.labels[round(uv[1]), round(uv[0])]] == "diver"


def test_fast_formation_matches_the_slow_reference():
    """Lamps, daylight and both veils, pixel by pixel with numerical integrals."""
    scene = Scene()
    scene.add_static(prim.box((40.0, 40.0, 1.0), (0.0, 0.0, 6.5)), "seafloor", GREY)
    add_diver(scene, "diver", (2.2, 0.2, 4.2), 60.0)
    cfg = CameraConfig(width=16, height=12, hfov_deg=70.0, water=jerlov("3C"),
                       tilt_deg=20.0, forward_scatter=False, noise=False, exposure=1.0,
                       max_range_m=12.0, sampling="full")
    camera = UnderwaterCamera(cfg, np.random.default_rng(0))
    frame = camera.capture(scene.raycaster(), (0.0, 0.0, 4.0), np.eye(3), 0.0)
    origin, R = frame.position_ned, frame.rotation_ned_from_camera
    hits = scene.raycaster().cast(origin, camera.geometry.dirs_cam @ R.T, cfg.max_range_m)
    ref = reference_radiance(cfg, hits, origin, R, scene.materials, steps=4000)
    assert len(set(hits.label.tolist())) == 3  # floor, diver and open water in view
    np.testing.assert_allclose(frame.radiance, ref, rtol=0.03, atol=1e-4 * float(ref.max()))


@pytest.mark.slow
def test_adaptive_sampling_matches_one_ray_per_pixel():
    """Adaptive sampling (rays on every second pixel, more at edges and creases) against
    a ray per pixel, on the pier with the diver: the same labels almost everywhere, depth
    within 1 % where they agree, and the picture within a few levels."""
    scene = _diver_scene()
    frames = {}
    for sampling in ("full", "adaptive"):
        camera = UnderwaterCamera(
            CameraConfig(width=160, height=120, water=jerlov("1C"), tilt_deg=10.0,
                         noise=False, exposure=2.0, sampling=sampling),
            np.random.default_rng(0))
        frames[sampling] = camera.capture(scene.raycaster(), (0.0, 0.0, 3.0), np.eye(3), 0.0)
    assert camera.last_exact_fraction < 0.5  # most of the picture was interpolated
    full, fast = frames["full"], frames["adaptive"]
    agree = full.labels == fast.labels
    assert agree.mean() > 0.99
    hit = agree & (full.labels >= 0)
    np.testing.assert_allclose(fast.depth_m[hit], full.depth_m[hit], rtol=0.01)
    assert np.all(np.isnan(fast.depth_m[full.labels < 0]) | ~agree[full.labels < 0])
    diff = np.abs(fast.rgb.astype(int) - full.rgb.astype(int))
    assert diff[agree].mean() < 1.0 and np.percentile(diff[agree], 99) <= 6


def test_forward_scatter_blurs_more_with_range_and_keeps_energy():
    """A sharp-edged target: farther away (and in more turbid water) the forward-scatter
    term spreads further; the blur redistributes light without making any."""
    from uhrisim.sensors.camera import formation as fm

    water = jerlov("7C")
    src = np.zeros((256, 256, 3), np.float32)
    src[112:144, 112:144] = 1.0
    # σ = 0.01·b_G·r·f: 2.4 px at 1 m, 19 px at 8 m (f = 100 px, b_G = 2.394 /m)
    near = fm.forward_scatter(src, np.full((256, 256), 1.0, np.float32), water, 0.01, 100.0)
    far = fm.forward_scatter(src, np.full((256, 256), 8.0, np.float32), water, 0.01, 100.0)
    for img in (near, far):
        np.testing.assert_allclose(img.sum(axis=(0, 1)), src.sum(axis=(0, 1)), rtol=0.02)
    assert far[104, 128, 1] > near[104, 128, 1] > 0.0  # light spilled past the edge
    assert near[128, 128, 1] > far[128, 128, 1]


def test_same_seed_same_image_and_noise_is_shot_noise():
    scene = _wall_scene(2.0)
    frames = []
    for seed in (5, 5, 6):
        camera = UnderwaterCamera(
            CameraConfig(width=64, height=48, water=jerlov("IB"), mount_position_frd=(0, 0, 0),
                         lamps_on=False, exposure=10.0, forward_scatter=False),
            np.random.default_rng(seed))
        frames.append(camera.capture(scene.raycaster(), (0, 0, CAMERA_DEPTH), np.eye(3), 0.0))
    np.testing.assert_array_equal(frames[0].rgb, frames[1].rgb)
    assert not np.array_equal(frames[0].rgb, frames[2].rgb)


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: CameraConfig(width=0), "camera.width"),
        (lambda: CameraConfig(height=-4), "camera.height"),
        (lambda: CameraConfig(hfov_deg=180.0), "camera.hfov_deg"),
        (lambda: CameraConfig(hfov_deg=200.0), "camera.hfov_deg"),
        (lambda: CameraConfig(K=((0, 0, 1), (0, 1, 1), (0, 0, 1))), "camera.K"),
        (lambda: measured((0.3, -0.1, 0.2)), "water.attenuation"),
        (lambda: WaterOptics("mine", (0.1, 0.1, -0.1), (0.1, 0.1, 0.1)), "absorption"),
        (lambda: jerlov("5C"), "water.jerlov"),
        (lambda: CameraConfig(preset="gopro"), "camera.preset"),
    ],
)
def test_bad_parameters_are_one_line_errors_naming_the_field(make, field):
    with pytest.raises(ConfigError) as info:
        make()
    message = str(info.value)
    assert field in message and "\n" not in message


def test_full_intrinsics_give_the_same_rays_as_the_field_of_view():
    by_fov = CameraConfig(width=64, height=48, hfov_deg=70.0)
    f = 32.0 / math.tan(math.radians(35.0))
    by_k = CameraConfig(width=64, height=48, K=((f, 0, 31.5), (0, f, 23.5), (0, 0, 1)))
    assert by_k.hfov_deg == pytest.approx(70.0)
    np.testing.assert_allclose(by_fov.intrinsics, by_k.intrinsics)
    rng = np.random.default_rng(0)
    np.testing.assert_allclose(UnderwaterCamera(by_k, rng).geometry.dirs_cam,
                               UnderwaterCamera(by_fov, rng).geometry.dirs_cam)
    # a principal point off centre turns the central ray off the optical axis
    shifted = CameraConfig(width=64, height=48, K=((f, 0, 40.0), (0, f, 23.5), (0, 0, 1)))
    d = UnderwaterCamera(shifted, rng).geometry.dirs_cam.reshape(48, 64, 3)[24, 40]
    assert d[1] == pytest.approx(0.0, abs=1e-12) and d[0] < 1.0  # pixel 40 is on the axis


def test_a_camera_pose_that_is_not_finite_is_named():
    """The camera's casts skip the ray checks (its own rays are valid by construction),
    so a pose with NaN is refused by the camera, by name."""
    camera = UnderwaterCamera(CameraConfig(width=8, height=6), np.random.default_rng(0))
    scene = Scene()
    with pytest.raises(ConfigError, match=r"UnderwaterCamera\.capture.*finite"):
        camera.capture(scene.raycaster(), np.array([0.0, np.nan, 1.0]), np.eye(3), 0.0)
