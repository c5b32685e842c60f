"""Textures in the camera: a slate's printed marker reaches the pixels through the whole
image formation, the slow reference agrees, adaptive sampling keeps the print sharp, and
a scene whose textured object is out of view renders bit for bit as before."""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.sensors.camera.reference import reference_radiance
from uhrisim.world import primitives as prim
from uhrisim.world.bodies import Part
from uhrisim.world.materials import SAND, Material, PlanarTexture
from uhrisim.world.paper_scenes import add_diver
from uhrisim.world.scene import Scene
from uhrisim.world.slate import MarkerSlate

DEPTH = 5.0
FACING_CAMERA = rot_z(np.pi)  # the slate's printed face (+x) turned towards a camera at north 0


def _slate_scene(slate: MarkerSlate, north: float = 1.2, body: bool = True) -> Scene:
    scene = Scene()
    scene.add_static(prim.box((40.0, 40.0, 1.0), (0.0, 0.0, DEPTH + 3.5)), "seafloor", SAND)
    add_diver(scene, "diver", (north + 0.6, 0.5, DEPTH + 0.3), 180.0)
    if body:
        scene.add_dynamic("slate", slate.mesh(), "slate", slate.material(),
                          position_ned=(north, 0.0, DEPTH), rotation=FACING_CAMERA)
    else:  # the same board as static geometry, posed in NED
        mesh = slate.mesh()
        mesh.apply_transform(prim.pose_matrix((north, 0.0, DEPTH), rotation=FACING_CAMERA))
        scene.add_static(mesh, "slate", _static_material(slate, north))
    return scene


def _static_material(slate: MarkerSlate, north: float) -> Material:
    """The slate's material with its picture moved into NED (for a static board)."""
    tex = slate.material().texture
    assert tex is not None
    to_ned = prim.pose_matrix((north, 0.0, DEPTH), rotation=FACING_CAMERA)
    moved = PlanarTexture(tex.image, tuple(to_ned[:3, :3] @ tex.origin + to_ned[:3, 3]),
                          tuple(to_ned[:3, :3] @ tex.right), tuple(to_ned[:3, :3] @ tex.down),
                          tex.width_m, tex.height_m, tex.tolerance_m)
    return Material("static slate", 0.1, (slate.white,) * 3, moved)


def _camera(**kw) -> UnderwaterCamera:
    cfg = dict(width=40, height=30, hfov_deg=20.0, water=jerlov("1C"), tilt_deg=0.0,
               mount_position_frd=(0.0, 0.0, 0.0), noise=False, exposure=1.0,
               forward_scatter=False, sampling="full", max_range_m=12.0)
    cfg.update(kw)
    return UnderwaterCamera(CameraConfig(**cfg), np.random.default_rng(3))


@pytest.mark.parametrize("body", [True, False], ids=["dynamic", "static"])
def test_printed_marker_matches_the_slow_reference(body):
    """Lamps, daylight and both veils on a slate's print, pixel by pixel against the slow
    reference (which reads the texel with its own scalar arithmetic)."""
    slate = MarkerSlate(7, texels_per_cell=4)
    scene = _slate_scene(slate, body=body)
    camera = _camera(water=jerlov("3C"))
    frame = camera.capture(scene.raycaster(), (0.0, 0.0, DEPTH), np.eye(3), 0.0)
    origin, R = frame.position_ned, frame.rotation_ned_from_camera
    hits = scene.raycaster().cast(origin, camera.geometry.dirs_cam @ R.T, 12.0)
    ref = reference_radiance(camera.config, hits, origin, R, scene.materials, steps=2000,
                             bodies=scene.bodies)
    np.testing.assert_allclose(frame.radiance, ref, rtol=0.03, atol=1e-4 * float(ref.max()))
    on_slate = frame.labels == frame.label_names.index("slate")
    assert on_slate.sum() > 300
    grey = frame.radiance[..., 1][on_slate]
    # black print and white board both in view (the veil of 3C water lifts the black)
    assert grey.max() > 2.0 * grey.min()


def test_texture_goes_through_forward_scatter_and_noise():
    """The print reaches the 8-bit image with forward scatter and noise on: dark cells
    darker than the board's white in the sensor's output."""
    slate = MarkerSlate(3)
    camera = _camera(width=160, height=120, hfov_deg=40.0, noise=True, exposure="auto",
                     forward_scatter=True, sampling="adaptive")
    frame = camera.capture(_slate_scene(slate, north=1.5).raycaster(), (0.0, 0.0, DEPTH),
                           np.eye(3), 0.0)
    grey = frame.rgb.mean(axis=2)[frame.labels == frame.label_names.index("slate")]
    assert np.percentile(grey, 95) - np.percentile(grey, 5) > 60


def test_adaptive_sampling_casts_every_ray_on_a_print():
    """A cell with a corner on a textured material gets a ray per pixel: the adaptive
    image of the slate equals the full one there."""
    slate = MarkerSlate(11)
    scene = _slate_scene(slate, north=1.6)
    frames = {s: _camera(width=120, height=90, hfov_deg=30.0, sampling=s).capture(
        scene.raycaster(), (0.0, 0.0, DEPTH), np.eye(3), 0.0) for s in ("full", "adaptive")}
    full, fast = frames["full"], frames["adaptive"]
    on_slate = full.labels == full.label_names.index("slate")
    np.testing.assert_array_equal(fast.labels[on_slate], full.labels[on_slate])
    np.testing.assert_allclose(fast.radiance[on_slate], full.radiance[on_slate], rtol=1e-5)


@pytest.mark.parametrize("sampling", ["full", "adaptive"])
def test_an_unseen_textured_object_changes_no_bit(sampling):
    """The textured path runs only where a textured surface is seen: with the slate behind
    the camera the frame is the one without it, bit for bit (noise on)."""
    def frame(with_slate: bool):
        scene = Scene()
        scene.add_static(prim.box((40.0, 40.0, 1.0), (0.0, 0.0, DEPTH + 3.5)), "seafloor", SAND)
        add_diver(scene, "diver", (3.0, 0.4, DEPTH + 1.0), 150.0)
        if with_slate:
            slate = MarkerSlate(5)
            scene.add_dynamic("slate", slate.mesh(), "slate", slate.material(),
                              position_ned=(-2.0, 0.0, DEPTH))
        camera = _camera(width=96, height=72, hfov_deg=70.0, noise=True, exposure="auto",
                         forward_scatter=True, sampling=sampling, tilt_deg=15.0)
        return camera.capture(scene.raycaster(), (0.0, 0.0, DEPTH), np.eye(3), 0.0)

    plain, with_slate = frame(False), frame(True)
    assert "slate" not in {with_slate.label_names[i] for i in np.unique(with_slate.labels)
                           if i >= 0}
    np.testing.assert_array_equal(with_slate.rgb, plain.rgb)
    np.testing.assert_array_equal(with_slate.radiance, plain.radiance)


def test_uniform_picture_is_the_plain_material_bit_for_bit():
    """A picture of one albedo everywhere renders exactly as the material without it."""
    def frame(texture: bool):
        board = Material("board", 0.1, (0.3, 0.6, 0.2), PlanarTexture(
            np.full((4, 4, 3), (0.3, 0.6, 0.2), np.float32), (0.005, 0.2, -0.2),
            (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), 0.4, 0.4) if texture else None)
        scene = Scene()
        scene.add_dynamic("board", prim.box((0.01, 0.4, 0.4)), "board", board,
                          position_ned=(1.5, 0.0, DEPTH), rotation=FACING_CAMERA)
        return _camera().capture(scene.raycaster(), (0.0, 0.0, DEPTH), np.eye(3), 0.0)

    np.testing.assert_array_equal(frame(True).radiance, frame(False).radiance)


def test_texture_on_a_many_part_body_is_refused_with_one_line():
    slate = MarkerSlate(1)
    parts = [Part("board", slate.mesh(), material=slate.material()),
             Part("handle", prim.box((0.02, 0.02, 0.1), (0.0, 0.0, 0.2)))]
    scene = Scene()
    scene.add_dynamic("slate", parts, "slate", SAND, position_ned=(1.0, 0.0, DEPTH),
                      rotation=FACING_CAMERA)
    with pytest.raises(ConfigError, match="one-part body"):
        _camera().capture(scene.raycaster(), (0.0, 0.0, DEPTH), np.eye(3), 0.0)


@pytest.mark.parametrize("kw, match", [
    (dict(image=np.zeros((4, 4))), r"image must be \(rows, cols, 3\)"),
    (dict(image=np.full((2, 2, 3), 1.5)), "in \\[0, 1\\]"),
    (dict(down=(0.0, 1.0, 0.0)), "orthogonal unit vectors"),
    (dict(width_m=0.0), "width_m must be"),
])
def test_bad_texture_is_a_one_line_error(kw, match):
    args = dict(image=np.zeros((2, 2, 3)), origin=(0, 0, 0), right=(0.0, 1.0, 0.0),
                down=(0.0, 0.0, 1.0), width_m=1.0, height_m=1.0)
    args.update(kw)
    with pytest.raises(ConfigError, match=match):
        PlanarTexture(**args)


def test_bad_slate_is_a_one_line_error():
    with pytest.raises(ConfigError, match=r"marker_id must be an integer in \[0, 49\]"):
        MarkerSlate(50)
    with pytest.raises(ConfigError, match="unknown ArUco dictionary"):
        MarkerSlate(0, dictionary="DICT_NOPE")
