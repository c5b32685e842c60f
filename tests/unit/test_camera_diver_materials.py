"""The camera's articulated diver wears a material per part and the sea floor is rippled
sand (issue 32): a picture a camera user recognises. Checked in numbers:

* in one daylight frame of the diver (lamps on, clear water, 2 m), each part's label mask
  has its material's colour: the yellow cylinder's red and green well above its blue,
  the blue fins' blue above red, the gloves' red above blue, the dry suit darker than
  all of them; the part means lie far apart;
* the sonar sees the figure as before: every part material keeps its part's old
  reflectivity;
* the ripples: the floor's albedo along the ripples' normal has its spectral peak at
  1 / wavelength (for two wavelengths), its mean is the sand's, and along the crests it
  hardly changes; in a rendered frame the rippled floor varies where plain sand is flat.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.core.frames import rot_z
from uhrisim.dynamics.diver_body import DiverSkeleton
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.world import seafloor as sf
from uhrisim.world.diver_figure import diver_figure, figure_transforms
from uhrisim.world.materials import (
    ALUMINIUM,
    DIVER_PART_MATERIALS,
    NEOPRENE,
    SAND,
    SAND_RIPPLED,
    Material,
    RippleTexture,
)
from uhrisim.world.scene import Scene


@pytest.fixture(scope="module")
def camera():
    """One camera for every frame here (making one costs seconds)."""
    return UnderwaterCamera(
        CameraConfig(width=160, height=120, water=jerlov("IB"), lamps_on=True,
                     tilt_deg=20.0, noise=False, exposure=2.0),
        np.random.default_rng(0))


def _frame(camera: UnderwaterCamera, floor: Material, diver: bool = True):
    skeleton = DiverSkeleton()
    scene = Scene()
    scene.add_static(sf.flat(6.0, 20.0), "seafloor", floor)
    if diver:  # standing on the floor 2 m ahead, side on, arms a little out
        scene.add_dynamic("diver", diver_figure(skeleton, part_materials=DIVER_PART_MATERIALS),
                          "diver", NEOPRENE, np.array([2.0, 0.0, 5.0]), rot_z(math.pi / 2))
        q = skeleton.vector({"left_shoulder_abd": 0.5, "right_shoulder_abd": 0.5})
        scene.set_part_transforms("diver", figure_transforms(skeleton, q))
    return camera.capture(scene.raycaster(), (0.0, 0.0, 4.6), rot_z(0.0), 0.0)


@pytest.fixture(scope="module")
def diver_frame(camera):
    return _frame(camera, SAND_RIPPLED)


def _mean(frame, label: str) -> np.ndarray:
    mask = frame.labels == frame.label_names.index(label)
    assert mask.sum() > 20, f"{label}: {mask.sum()} px"
    return frame.radiance[mask].mean(axis=0)


def test_each_part_has_its_materials_colour(diver_frame):
    """Colour ratios of parts at the same range: the water tints them alike, so each
    part's ratio against the near-black suit's (which is the water's veil) shows its own
    colour: the yellow cylinder's (R+G)/2B, the blue fins' B/R, the tan gloves' R/B."""
    suit, tank, hand, fins = (_mean(diver_frame, name) for name in
                              ("diver", "diver/tank", "diver/hand", "diver/fins"))
    yellow = lambda c: (c[0] + c[1]) / (2 * c[2])  # noqa: E731
    assert yellow(tank) > 5 * yellow(suit) and yellow(tank) > 5 * yellow(hand)
    assert fins[2] / fins[0] > 2 * suit[2] / suit[0]
    assert hand[0] / hand[2] > 2 * suit[0] / suit[2] and hand[0] / hand[2] > 5 * fins[0] / fins[2]
    for part in (tank, hand, fins):
        assert part.sum() > 1.2 * suit.sum(), "the dry suit is not the darkest part"


def test_part_materials_keep_the_sonar_reflectivity():
    for label, material in DIVER_PART_MATERIALS.items():
        before = ALUMINIUM if label == "tank" or label == "helmet" else NEOPRENE
        assert material.reflectivity == before.reflectivity, label
    assert SAND_RIPPLED.reflectivity == SAND.reflectivity


@pytest.mark.parametrize("wavelength", [0.08, 0.15])
def test_the_ripples_albedo_peaks_at_its_wavelength(wavelength):
    texture = RippleTexture(wavelength_m=wavelength, direction_deg=30.0)
    a = math.radians(30.0)
    across = np.array([math.cos(a), math.sin(a), 0.0])
    along = np.array([-math.sin(a), math.cos(a), 0.0])
    step, n = 0.005, 4096  # 20 m at 5 mm
    s = np.arange(n) * step
    f_across = texture.factor(s[:, None] * across + np.array([0.0, 0.0, 6.0]))
    spectrum = np.abs(np.fft.rfft(f_across - f_across.mean()))
    freqs = np.fft.rfftfreq(n, step)
    peak = freqs[np.argmax(spectrum[1:]) + 1]
    assert peak == pytest.approx(1.0 / wavelength, rel=0.03)
    assert f_across.mean() == pytest.approx(1.0, abs=0.01)
    assert f_across.std() > 0.1
    # without meander and grain the albedo is constant along a crest
    straight = RippleTexture(wavelength_m=wavelength, direction_deg=30.0, meander_m=0.0,
                             grain=0.0)
    f_along = straight.factor(s[:400, None] * along + 0.3 * wavelength * across)
    assert np.ptp(f_along) < 1e-5 and np.ptp(straight.factor(s[:400, None] * across)) > 0.4
    albedo, on = texture.albedo_over(SAND.albedo_rgb, s[:, None] * across)
    assert on.all() and np.allclose(albedo.mean(axis=0), SAND.albedo_rgb, rtol=0.02)


def test_a_rendered_rippled_floor_varies_where_plain_sand_is_flat(camera):
    rows = slice(80, 115)  # the floor 1.5–3 m ahead, lit by the lamps
    plain = _frame(camera, SAND, diver=False).radiance[rows, 60:100].mean(axis=2)
    rippled = _frame(camera, SAND_RIPPLED, diver=False).radiance[rows, 60:100].mean(axis=2)
    # pixel to pixel along a row: the ripples change the light, plain sand hardly does
    assert np.abs(np.diff(rippled, axis=1)).mean() > 4 * np.abs(np.diff(plain, axis=1)).mean()
    assert rippled.mean() == pytest.approx(plain.mean(), rel=0.1)
