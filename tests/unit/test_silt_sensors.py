"""A silt cloud seen by the sensors: the camera loses contrast behind it (Koschmieder's
law, docs/camera.md), the sonar hears its volume backscatter; both recover as it
settles (the cloud's own physics: tests/unit/test_world_silt.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.support.analytic_sonar import AnalyticCaster
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.sensors.sonar import ECHOES_ONLY, ImagingSonar, SonarConfig
from uhrisim.world import primitives as prim
from uhrisim.world import silt as sl
from uhrisim.world.materials import Material
from uhrisim.world.scene import Scene

FLOOR = 12.0
EYE = np.array([0.0, 0.0, FLOOR - 0.15])  # 15 cm over the floor, in the fresh layer
PUFF_NORTH = 1.5


def floor(north, east):
    return np.full(np.broadcast(np.asarray(north), np.asarray(east)).shape, FLOOR)


def puff() -> sl.SiltCloud:
    """One footfall's worth of silt in front of the sensors (released at t = 0)."""
    cloud = sl.SiltCloud(sl.SiltParams(), floor)
    cloud.release(0.0, (PUFF_NORTH, 0.0, FLOOR), mass_kg=0.002)
    return cloud


def test_camera_contrast_behind_the_cloud_follows_koschmieder_and_recovers():
    # A white panel 3 m ahead, behind the cloud; the centre pixel (on the medium grid)
    # sees it. Its contrast against open water (same frame, target removed) is what the
    # cloud leaves of it: exp(-tau), tau from the slow sampled integral of the cloud.
    panel = Scene()
    panel.add_static(prim.box((0.1, 1.0, 1.0), (3.05, 0.0, EYE[2])), "panel",
                     Material("white", 0.1, (0.9, 0.9, 0.9)))
    water = Scene()
    water.add_static(prim.box((0.1, 0.1, 0.1), (0.0, 0.0, 100.0)), "far", Material("x", 0.1))
    cfg = CameraConfig(width=17, height=17, hfov_deg=30.0, water=jerlov("1C"),
                       mount_position_frd=(0, 0, 0), tilt_deg=0.0, noise=False,
                       exposure=1.0, sampling="full")
    camera = UnderwaterCamera(cfg, np.random.default_rng(1))
    cloud = puff()

    def contrast(t: float | None) -> float:
        medium = None if t is None else sl.SiltMedium(cloud, t)
        on, off = (camera.capture(s.raycaster(), EYE, np.eye(3), 0.0, medium=medium)
                   .radiance[8, 8].astype(float) for s in (panel, water))
        return float(np.mean((on - off) / off))

    clear = contrast(None)
    assert clear > 0.5
    taus = {}
    for t in (1.0, 300.0, 1800.0):
        integral = cloud.path_integral(EYE, (1.0, 0.0, 0.0), 3.0, t, samples=3000)
        taus[t] = float(sl.beam_attenuation(integral))
        assert contrast(t) / clear == pytest.approx(math.exp(-taus[t]), rel=2e-3)
    # a fresh 2 g puff hides 99.9 % of the contrast; it settles and spreads
    assert taus[1.0] > 6.0 and taus[1.0] > taus[300.0] > taus[1800.0] > 0.0
    assert contrast(6000.0) == pytest.approx(clear, rel=1e-9)  # all of it on the floor


def test_sonar_hears_the_cloud_above_the_water_and_less_as_it_settles():
    # the water's own volume reverberation (S_v = -70 dB) the only diffuse term, a display
    # range wide enough that it is not clipped (the P900's post-TVG noise would hide it)
    cfg = SonarConfig(range_min_m=0.5, range_max_m=5.0, tilt_deg=0.0, speckle=False,
                      mount_position_frd=(0.0, 0.0, 0.0), rays_per_beam=16,
                      **(ECHOES_ONLY | {"volume_scattering_db": -70.0,
                                        "dynamic_range_db": 250.0}))
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    caster = AnalyticCaster(floor_z=None)
    level = np.eye(3)
    cloud = puff()
    water = sonar.ping(caster, EYE, level, 0.0).polar
    r = sonar.geometry.bin_centres
    cells = (np.abs(r - PUFF_NORTH) < 0.2)[:, None] & (
        np.abs(sonar.geometry.beam_angles) < math.radians(3.0))[None, :]
    elsewhere = (r > 3.5)[:, None] & np.ones(water.shape[1], bool)[None, :]

    def excess(t: float) -> float:
        polar = sonar.ping(caster, EYE, level, t, medium=sl.SiltMedium(cloud, t)).polar
        np.testing.assert_allclose(polar[elsewhere], water[elsewhere], atol=1e-6)  # not there
        return float(np.mean(polar[cells] - water[cells]))

    fresh, later, settled = excess(1.0), excess(600.0), excess(6000.0)
    # display scale 0..1 over dynamic_range_db: the fresh puff is > 5 dB over the water
    assert water[cells].min() > 0.0 and fresh * cfg.dynamic_range_db > 5.0
    assert fresh > later > 0.0 and settled == 0.0
