"""The ROV's lamps add light where they point (issue 32): at night depth the diver 1.5 m
ahead is lit with the lamps on and black with them off, in radiance and in the image a
user sees (auto exposure); by day, at one exposure, the lamps brighten the diver; their
light falls off with distance; and the camera figure exposes each lamps-on/off pair
alike so that its panels compare."""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.core.frames import rot_z
from uhrisim.core.rng import component_rng
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.viz.camera_figures import CAMERA_DEPTH, diver_scene, render_pair


def diver_light(distance: float, lamps: bool, sun: float, exposure="auto", water="3C"):
    """(mean radiance on the diver, mean 8-bit level on the diver) of one frame."""
    camera = UnderwaterCamera(
        CameraConfig(width=240, height=180, water=jerlov(water), tilt_deg=5.0,
                     mount_position_frd=(0.0, 0.0, 0.0), lamps_on=lamps, sun_radiance=sun,
                     exposure=exposure, noise=False),
        component_rng(1, "test/lamps"))
    frame = camera.capture(diver_scene(distance).raycaster(), (0.0, 0.0, CAMERA_DEPTH),
                           rot_z(0.0), 0.0)
    diver = frame.labels == frame.label_names.index("diver")
    assert diver.sum() > 100
    return float(frame.radiance[diver].mean()), float(frame.rgb[diver].mean())


def test_at_night_the_lamps_light_the_diver_and_without_them_it_is_black():
    radiance_on, level_on = diver_light(1.5, lamps=True, sun=0.0)
    radiance_off, level_off = diver_light(1.5, lamps=False, sun=0.0)
    assert radiance_off == 0.0 and level_off == 0.0
    assert radiance_on > 0.1 and level_on > 80.0


def test_by_day_at_one_exposure_the_lamps_brighten_the_diver():
    on, off = (diver_light(1.5, lamps, 1.0, exposure=2.0)[0] for lamps in (True, False))
    assert on > 3.0 * off


def test_the_lamps_light_falls_off_with_distance_in_clear_water():
    """At night in clear water (Jerlov IB) all the light is the lamps': on the diver it
    falls from 1.5 to 3 to 5 m (inverse square, attenuation, the beam's cone; what stays
    at 5 m is mostly the lamps' own backscatter in front of the diver)."""
    light = [diver_light(d, True, 0.0, exposure=2.0, water="IB")[0] for d in (1.5, 3.0, 5.0)]
    assert light[0] > 3.0 * light[1] > 0 and light[1] > light[2] > 0
    assert light[0] / light[2] > 5.0


def test_the_figure_exposes_a_lamps_pair_alike_and_lamps_on_is_brighter():
    on, off = render_pair("3C", 1.5)
    assert on.gain == pytest.approx(off.gain)
    diver = on.labels == on.label_names.index("diver")
    assert np.mean(on.rgb[diver]) > np.mean(off.rgb[diver]) + 20.0
