"""Silt clouds: Stokes settling, mass conservation while spreading, ray integrals."""

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.world import seafloor
from uhrisim.world import silt as sl

FLOOR_DEPTH = 15.0


def flat_floor(north, east):
    return np.full(np.broadcast(np.asarray(north), np.asarray(east)).shape, FLOOR_DEPTH)


def cloud(**kw):
    return sl.SiltCloud(sl.SiltParams(**kw), flat_floor)


def test_stokes_speed_of_medium_silt_by_hand():
    # (2650 - 1025) * 9.80665 * (20e-6)^2 / (18 * 1.08e-3) = 3.279e-4 m/s (0.33 mm/s)
    assert sl.stokes_speed(20e-6) == pytest.approx(3.279e-4, rel=1e-3)
    # d^2 law: 63 um settles (63/20)^2 = 9.9 times faster
    assert sl.stokes_speed(63e-6) / sl.stokes_speed(20e-6) == pytest.approx((63 / 20) ** 2)
    # and Stokes holds there: grain Reynolds number below 0.5
    assert sl.stokes_speed(63e-6) * 63e-6 / (1.08e-3 / 1025) < 0.5


def test_footfall_source_strength():
    assert sl.SiltParams().footfall_mass_kg == pytest.approx(0.32 * 0.13 * 1e-3 * 500)  # 21 g


def test_layers_settle_at_their_stokes_speeds_and_mass_is_conserved():
    c = cloud()
    c.release(0.0, (0.0, 0.0, FLOOR_DEPTH), mass_kg=0.02)
    w = c.params.settling_speeds
    m0 = 0.02 * np.array(c.params.mass_fractions)
    for t in (0.0, 100.0, 300.0, 600.0):
        expected = m0 * np.maximum(1.0 - w * t / 0.3, 0.0)
        np.testing.assert_allclose(c.suspended_kg(t), expected, rtol=1e-12)
        np.testing.assert_allclose(c.suspended_kg(t) + c.deposited_kg(t), m0, rtol=1e-12)
    # the top of the medium-silt layer, 300 s after the release, just above and below it
    t = 300.0
    top = 0.3 - w * t  # per class
    at = lambda h: c.concentration([(0.0, 0.0, FLOOR_DEPTH - h)], t)[0]  # noqa: E731
    below, above = at(top[1] - 1e-3), at(top[1] + 1e-3)
    sigma2 = 0.2 ** 2 + 2 * 2e-4 * t
    fine_and_medium = (m0[0] + m0[1]) / (2 * math.pi * sigma2 * 0.3)
    assert below == pytest.approx(fine_and_medium, rel=1e-9)
    assert above == pytest.approx(m0[0] / (2 * math.pi * sigma2 * 0.3), rel=1e-9)


def test_spreading_conserves_the_suspended_mass():
    """The concentration integrated over a 3-D grid equals the suspended mass at every
    time while the puff spreads (K = 0.01 m²/s: sigma grows from 0.2 to 1.1 m)."""
    c = cloud(diffusivity_m2s=0.01)
    c.release(0.0, (2.0, -1.0, FLOOR_DEPTH), mass_kg=0.05)
    c.release(20.0, (2.5, -1.0, FLOOR_DEPTH), mass_kg=0.02)
    x = np.linspace(-4.0, 8.0, 121)
    y = np.linspace(-7.0, 5.0, 121)
    h = (np.arange(60) + 0.5) * (0.3 / 60)
    xx, yy, hh = np.meshgrid(x, y, h, indexing="ij")
    pts = np.column_stack([xx.ravel(), yy.ravel(), FLOOR_DEPTH - hh.ravel()])
    cell = (x[1] - x[0]) * (y[1] - y[0]) * (0.3 / 60)
    for t in (25.0, 60.0):
        total = c.concentration(pts, t).sum() * cell
        assert total == pytest.approx(c.suspended_kg(t).sum(), rel=5e-3)


def test_path_integral_through_the_centre_has_the_gaussian_answer():
    """A horizontal ray at mid-layer through the centre: sum over classes in the layer of
    M_c / (sqrt(2 pi) sigma H0)."""
    c = cloud()
    c.release(0.0, (0.0, 0.0, FLOOR_DEPTH), mass_kg=0.03)
    t = 50.0
    sigma = math.sqrt(0.2 ** 2 + 2 * 2e-4 * t)
    h = 0.1
    in_layer = 0.3 - c.params.settling_speeds * t >= h
    m = 0.03 * np.array(c.params.mass_fractions)[in_layer].sum()
    got = c.path_integral((-3.0, 0.0, FLOOR_DEPTH - h), (1.0, 0.0, 0.0), 6.0, t, samples=600)
    assert got == pytest.approx(m / (math.sqrt(2 * math.pi) * sigma * 0.3), rel=1e-4)
    # a ray above the layer sees nothing
    assert c.path_integral((-3.0, 0.0, FLOOR_DEPTH - 0.5), (1.0, 0.0, 0.0), 6.0, t) == 0.0


def test_the_cloud_drifts_with_the_current_and_lies_on_a_sloped_floor():
    floor = seafloor.sloped(10.0, 0.2, direction_deg=0.0, extent=30.0)
    c = sl.SiltCloud(sl.SiltParams(current_ne=(0.05, 0.0)), floor.depth_at)
    c.release(0.0, (0.0, 0.0, float(floor.depth_at(0.0, 0.0))))
    t = 40.0  # the centre is now 2 m north, where the floor is 0.4 m deeper
    def at(n):
        return c.concentration([(n, 0.0, float(floor.depth_at(n, 0.0)) - 0.05)], t)[0]
    assert at(2.0) > at(1.5) > at(0.5)
    assert at(2.0 + 0.3) == pytest.approx(at(2.0 - 0.3), rel=1e-9)  # symmetric about it


def test_what_the_sensors_get():
    assert sl.beam_attenuation(0.01) == pytest.approx(5.0)  # 10 g/m³ x 0.5 m²/g
    sv1 = sl.volume_backscatter_db(0.1, 900e3)
    assert sl.volume_backscatter_db(0.2, 900e3) - sv1 == pytest.approx(10 * math.log10(2))
    assert sl.volume_backscatter_db(0.1, 1800e3) - sv1 == pytest.approx(40 * math.log10(2))
    # order of magnitude: 0.1 kg/m³ of 20 um silt at 900 kHz, about -62 dB
    assert -66.0 < float(sv1) < -58.0
    assert sl.volume_backscatter_db(0.0, 900e3) == -math.inf
    with pytest.raises(ConfigError, match="outside the Rayleigh regime"):
        sl.volume_backscatter_db(0.1, 900e3, diameter_m=500e-6)


def test_bad_parameters():
    with pytest.raises(ConfigError, match="add up to 1"):
        sl.SiltParams(mass_fractions=(0.5, 0.4, 0.3))
    with pytest.raises(ConfigError, match="silt is 2-63"):
        sl.SiltParams(diameters_m=(1e-4, 2e-5, 3e-5))


def test_closed_form_ray_integrals_match_the_sampled_path_integral():
    c = cloud()
    for k in range(12):  # a walk of footfalls, released over 6 s
        c.release(0.5 * k, (0.3 * k, 0.1 * k, FLOOR_DEPTH), mass_kg=0.02)
    origin = np.array([-2.0, 0.5, FLOOR_DEPTH - 0.2])
    rng = np.random.default_rng(3)
    d = rng.normal(size=(40, 3)) * (1.0, 1.0, 0.15)
    d[0] = (1.0, 0.1, 0.02)
    d[1] = (0.0, 0.0, 1.0)  # straight down: no horizontal motion
    d /= np.linalg.norm(d, axis=1)[:, None]
    ends = np.full(len(d), 8.0)
    ends[1] = 0.2
    for t in (3.0, 200.0):
        slow = np.array([c.path_integral(origin, di, e, t, 4000)
                         for di, e in zip(d, ends, strict=True)])
        fast = c.ray_integrals(origin, d, ends, t, np.ones(3))
        assert slow.max() > 0.1
        np.testing.assert_allclose(fast, slow, rtol=2e-3, atol=1e-6 * slow.max())
        # linear in the per-class weights, and per range bin the bins add up to the ray
        by_class = [c.ray_integrals(origin, d, ends, t, w) for w in np.eye(3)]
        np.testing.assert_allclose(sum(by_class), fast, rtol=1e-12)
        ray, _, value = c.ray_integrals(origin, d, ends, t, np.ones(3),
                                        edges=np.linspace(0, 8, 161))
        np.testing.assert_allclose(np.bincount(ray, value, minlength=len(d)), fast,
                                   rtol=1e-9, atol=1e-12)


def _identical(a, b):
    return (a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
            and np.array_equal(np.signbit(a), np.signbit(b)))


def test_erf_bound_only_under_a_double_signature(monkeypatch):
    """scipy's fused erf is bound by its capsule's C signature: the double variant says
    so, and a fused index whose capsule is another signature (the complex one) or none
    falls back to the numpy path."""
    if sl.numba_module() is None:
        pytest.skip("numba not installed")
    from scipy.special import cython_special

    capsules = cython_special.__pyx_capi__
    assert sl._capsule_name(capsules[sl._ERF_FUSED]).startswith("double (double")
    for other in ("__pyx_fuse_0erf", "no_such_erf"):
        monkeypatch.setattr(sl, "_ERF_FUSED", other)
        assert sl._compiled_ray_integrals.__wrapped__() is None


def test_compiled_ray_integrals_are_the_numpy_path_bit_for_bit():
    """The compiled ray walk against the numpy path (the reference): random clouds on a
    sloped floor, rays from above, inside and below the layers, flat and vertical rays,
    signed zeros in the directions, whole and per range bin."""
    if sl._compiled_ray_integrals() is None:
        pytest.skip("numba not installed")
    rng = np.random.default_rng(11)
    for case in range(12):
        c = sl.SiltCloud(sl.SiltParams(current_ne=(0.01 * case, -0.005)),
                         lambda n, e: FLOOR_DEPTH + 0.05 * np.asarray(n) - 0.02 * np.asarray(e))
        for k in range(int(rng.integers(1, 30))):
            c.release(0.7 * k, (rng.normal(0, 1.5), rng.normal(0, 1.5), FLOOR_DEPTH))
        origin = np.array([rng.normal(0, 2), rng.normal(0, 2),
                           FLOOR_DEPTH - rng.choice([0.05, 0.2, 1.5, -0.1])])
        d = rng.normal(size=(300, 3)) * (1.0, 1.0, rng.choice([0.05, 0.3, 1.0]))
        d[:8] = ((1.0, 0.0, 0.0), (-0.0, 1.0, 0.0), (0.0, -0.0, 1.0), (0.0, 0.0, -1.0),
                 (1.0, 1.0, -0.0), (-1.0, 0.5, 1e-13), (0.3, -0.0, -0.2), (0.0, 0.0, 0.0))
        d[8:] /= np.linalg.norm(d[8:], axis=1)[:, None]
        ends = rng.choice([0.5, 3.0, 10.0, 1e4], size=len(d))
        t = float(rng.choice([0.0, 5.0, 60.0, 400.0]))
        w = rng.uniform(0.1, 10.0, 3)
        fast = c.ray_integrals(origin, d, ends, t, w)
        slow = c.ray_integrals(origin, d, ends, t, w, compiled=False)
        assert _identical(fast, slow), case
        edges = np.linspace(rng.choice([0.0, 0.5]), 10.0, int(rng.integers(2, 120)))
        fast = c.ray_integrals(origin, d, ends, t, w, edges=edges)
        slow = c.ray_integrals(origin, d, ends, t, w, edges=edges, compiled=False)
        assert all(_identical(f, s) for f, s in zip(fast, slow, strict=True)), case
