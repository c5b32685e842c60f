"""The compiled image formation (:mod:`uhrisim.sensors.camera.fused`) held to the numpy
stages of :mod:`uhrisim.sensors.camera.formation` (the reference, run with numba off).

The stated tolerance (docs/camera.md, the module's text): the sensor's bytes are the
same; the radiance within a few float32 units in the last place (libm's exponentials
against numpy's); 8-bit frames within one grey level, mean below 0.01 level; depth,
range and labels the same to the bit; same seed, same noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.core.compiled import numba_module
from uhrisim.core.frames import rot_z
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, fused, jerlov
from uhrisim.sensors.camera import formation as fm
from uhrisim.world import primitives as prim
from uhrisim.world.materials import Material, RippleTexture
from uhrisim.world.paper_scenes import add_diver
from uhrisim.world.scene import Scene
from uhrisim.world.slate import MarkerSlate

pytestmark = pytest.mark.skipif(not fused.available(),
                                reason="numba is off (not installed, or UHRISIM_NUMBA=0)")

DEPTH = 4.0
RIPPLED = Material("rippled sand", 0.02, (0.45, 0.40, 0.30), RippleTexture())


@pytest.fixture(scope="module")
def scene() -> Scene:
    """Rippled floor, the articulated diver, a slate with a marker, open water above."""
    scene = Scene()
    scene.add_static(prim.box((40.0, 40.0, 1.0), (0.0, 0.0, DEPTH + 2.5)), "seafloor", RIPPLED)
    add_diver(scene, "diver", (2.4, 0.3, DEPTH + 0.4), 150.0)
    slate = MarkerSlate(3)
    scene.add_dynamic("slate", slate.mesh(), "slate", slate.material(),
                      position_ned=(1.6, -0.4, DEPTH), rotation=rot_z(np.pi))
    return scene


def _pair(monkeypatch: pytest.MonkeyPatch, **kw) -> tuple[UnderwaterCamera, UnderwaterCamera]:
    """(compiled, numpy) cameras of one configuration and seed."""
    cfg = CameraConfig(**{"width": 64, "height": 48, "water": jerlov("1C"), "tilt_deg": 10.0,
                          "lamps_on": True, "max_range_m": 10.0, **kw})
    compiled = UnderwaterCamera(cfg, np.random.default_rng(7))
    with monkeypatch.context() as patch:
        patch.setattr(fused, "available", lambda: False)
        reference = UnderwaterCamera(cfg, np.random.default_rng(7))
    assert compiled._fused is not None and reference._fused is None
    return compiled, reference


@pytest.mark.parametrize("kw", [
    {"sampling": "adaptive"},  # the loop's camera: noise, auto exposure, forward scatter
    {"sampling": "full", "sun_radiance": 0.0, "exposure": 3.0, "noise": False},
    {"sampling": "full", "lamps_on": False, "forward_scatter": False, "tilt_deg": -20.0},
], ids=["adaptive", "night-lamps", "daylight-looking-up"])
def test_compiled_frames_match_the_numpy_stages(monkeypatch, scene, kw):
    compiled, reference = _pair(monkeypatch, **kw)
    caster = scene.raycaster()
    for step in range(2):  # the second frame draws the next noise offset
        rotation = rot_z(0.1 * step)
        new = compiled.capture(caster, (0.0, 0.0, DEPTH), rotation, 0.1 * step)
        ref = reference.capture(caster, (0.0, 0.0, DEPTH), rotation, 0.1 * step)
        assert len(np.unique(ref.labels)) >= 3  # diver, slate and water or floor in view
        np.testing.assert_allclose(new.radiance, ref.radiance, rtol=1e-5,
                                   atol=1e-6 * float(ref.radiance.max()))
        diff = np.abs(new.rgb.astype(int) - ref.rgb.astype(int))
        assert diff.max() <= 1 and diff.mean() < 0.01
        for name in ("range_m", "depth_m", "labels"):
            np.testing.assert_array_equal(getattr(new, name), getattr(ref, name))
        assert new.gain == pytest.approx(ref.gain, rel=1e-5)
        # adaptive sampling's compiled cell test picks the same pixels to cast
        assert compiled.last_exact_fraction == reference.last_exact_fraction


def test_compiled_sensor_is_the_numpy_sensor_to_the_byte():
    """Gain, shot and read noise, clipping and the sRGB curve, over the whole range."""
    rng = np.random.default_rng(2)
    radiance = rng.uniform(-0.1, 1.4, (48, 64, 3)).astype(np.float32)
    noise = rng.standard_normal((48, 64, 3), dtype=np.float32)
    cfg, lut = CameraConfig(full_well_e=5000.0, read_noise_e=9.0), fm.srgb_lut()
    for draws in (noise, None):
        np.testing.assert_array_equal(fused.expose(radiance, 0.8, cfg, draws, lut),
                                      fm.expose(radiance.copy(), 0.8, cfg, draws, lut))


def test_compiled_sand_ripples_are_ripple_factor():
    """The ripples' SIMD sines (fdlibm's polynomials) against libm's, and the per-ray
    factors against :func:`ripple_factor`, near the origin and far from it (where the
    kernel falls back to libm's sines)."""
    rng = np.random.default_rng(3)
    x = rng.uniform(-fused.SINE_LIMIT, fused.SINE_LIMIT, 4000)
    ripple_factors = fused._compiled()[2]  # (registers the helpers with numba)
    sines = numba_module().njit(lambda v, q: np.array([fused._sine(a, q) for a in v]))
    np.testing.assert_allclose(sines(x, 0), np.sin(x), rtol=0, atol=2.3e-16)
    np.testing.assert_allclose(sines(x, 1), np.cos(x), rtol=0, atol=2.3e-16)
    texture = RippleTexture(wavelength_m=0.05)
    kind, constants = np.array([1, 0], np.int8), np.array([texture.constants(), [0.0] * 6])
    for spread in (30.0, 4.0e4):  # the second passes SINE_LIMIT
        dirs = rng.normal(size=(500, 3))
        dirs /= np.linalg.norm(dirs, axis=1)[:, None]
        distance = rng.uniform(0.5, 8.0, 500)
        material = rng.integers(-1, 2, 500).astype(np.int32)
        origin, rotation = np.array([spread, -spread, 3.0]), rot_z(0.7)
        factor = ripple_factors(distance, material, kind, constants, dirs, origin,
                                      rotation, np.empty(500, np.float32))
        points = origin + (dirs @ rotation.T) * distance[:, None]
        rippled = material == 0
        expected = np.ones(500, np.float32)
        expected[rippled] = texture.factor(points[rippled])
        np.testing.assert_allclose(factor, expected, rtol=1e-6)


def test_compiled_rotation_is_einsums_to_the_bit():
    """The camera's rays are turned to NED, and the coarse hits' normals to the camera
    frame, by :func:`fused.rotated`; the casts (range, depth, labels) and adaptive
    sampling's cells stay the numpy path's only if it gives einsum's bits."""
    rng = np.random.default_rng(4)
    rows = rng.normal(size=(5000, 3))
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    np.testing.assert_array_equal(fused.rotated(rows, rotation),
                                  np.einsum("ij,kj->ik", rows, rotation))
    np.testing.assert_array_equal(fused.rotated(rows, rotation, transposed=True),
                                  np.einsum("ij,jk->ik", rows, rotation))


def test_simd_exponentials_round_to_float32_as_the_true_value():
    """The veil's SIMD e^x − 1 (and the e^x under it), on float32 arguments from tiny to
    past float32's range, rounded to float32: the true value's float32 rounding (numpy's
    float64 expm1/exp rounded), every one of them here; the clipped ends give −1 and inf."""
    fused._compiled()  # (registers the helpers with numba)
    rng = np.random.default_rng(5)
    x = np.concatenate([-rng.exponential(4.0, 20000), rng.uniform(-1e-4, 1e-4, 2000),
                        rng.uniform(-1e-9, 1e-9, 200), rng.uniform(-110.0, 90.0, 2000),
                        [0.0, -0.0, -np.inf, -200.0, 200.0, np.inf]]).astype(np.float32)
    njit = numba_module().njit
    expm1 = njit(lambda v: np.array([np.float32(fused._expm1(float(a))) for a in v]))
    exp = njit(lambda v: np.array([np.float32(fused._exp(float(a))) for a in v]))
    wide = x.astype(np.float64)
    with np.errstate(over="ignore"):
        np.testing.assert_array_equal(expm1(x), np.expm1(wide).astype(np.float32))
        np.testing.assert_array_equal(exp(x), np.exp(wide).astype(np.float32))
