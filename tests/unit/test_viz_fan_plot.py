"""Sonar fans drawn for reading (uhrisim.viz.fan_plot, the run's sonar strip): metric
axes, labelled range arcs and bearings, a colour bar of the display level, and a crop
that holds the diver at its pixel position."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from uhrisim.viz.fan_plot import LEVEL_LABEL, FanView, crop_window, draw_fan, in_sonar_plane
from uhrisim.viz.figures import subplots
from uhrisim.viz.mission_figures import plot_sonar_strip

PX_PER_M = 30.0
RANGE_M = 10.0
HALF_FOV_DEG = 22.5


def fan_with_blob(target: tuple[float, float]) -> FanView:
    """A 10 m, 45° fan of level 40 with a bright (250) 0.3 m disc at ``target``."""
    h = int(RANGE_M * PX_PER_M) + 1
    w = 2 * int(RANGE_M * math.sin(math.radians(HALF_FOV_DEG)) * PX_PER_M) + 1
    view = FanView(np.zeros((h, w), np.uint8), PX_PER_M, ((w - 1) / 2, h - 0.5),
                   HALF_FOV_DEG, RANGE_M)
    col, row = np.meshgrid(np.arange(w), np.arange(h))
    x, y = (col - view.apex[0]) / PX_PER_M, (view.apex[1] - row) / PX_PER_M
    inside = (np.hypot(x, y) <= RANGE_M) & (np.abs(np.degrees(np.arctan2(x, y))) <= 22.5)
    view.image[inside] = 40
    view.image[np.hypot(x - target[0], y - target[1]) < 0.3] = 250
    return view


@pytest.mark.parametrize("target", [(0.4, 2.0), (-1.5, 6.0), (3.6, 8.9)])
def test_the_crop_holds_the_diver_at_its_pixel_position(target):
    view = fan_with_blob(target)
    x0, x1, y0, y1 = crop_window(view, target)
    assert x1 - x0 == pytest.approx(5.0) and y1 - y0 == pytest.approx(5.0)
    assert x0 <= target[0] <= x1 and y0 <= target[1] <= y1
    left, right, bottom, top = view.extent
    assert left <= x0 and x1 <= right and max(bottom, 0) <= y0 and y1 <= top
    col, row = view.pixel_of(*target)
    assert view.image[round(row), round(col)] == 250  # the blob is where the diver is


def test_no_target_or_one_out_of_range_shows_the_whole_fan():
    view = fan_with_blob((0.0, 3.0))
    whole = (*view.extent[:2], 0.0, view.extent[3])
    assert crop_window(view, None) == pytest.approx(whole)
    assert crop_window(view, (0.0, 14.0)) == pytest.approx(whole)


def test_a_point_in_the_sonar_plane_keeps_its_slant_range_and_bearing():
    class Ping:  # a sonar at 2 m depth heading east, level (x forward, y starboard, z down)
        position_ned = np.array([10.0, 5.0, 2.0])
        rotation_ned_from_sonar = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0],
                                            [0.0, 0.0, 1.0]])

    # 3 m east (ahead), 1 m south (starboard), 1 m deeper
    starboard, forward = in_sonar_plane(Ping, np.array([9.0, 8.0, 3.0]))
    assert math.hypot(starboard, forward) == pytest.approx(math.sqrt(11.0))
    assert math.degrees(math.atan2(starboard, forward)) == pytest.approx(
        math.degrees(math.atan2(1.0, 3.0)))


def test_the_fan_has_metric_axes_labelled_arcs_and_bearings_and_a_colour_bar():
    fig, ax = subplots(1, 1, figsize=(5, 5), layout="constrained")
    view = fan_with_blob((0.0, 5.0))
    draw_fan(ax, view)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("starboard (m)", "forward (m)")
    texts = {t.get_text() for t in ax.texts}
    assert {"2 m", "4 m", "6 m", "8 m", "10 m"} <= texts
    assert {"-22°", "+22°", "-10°", "+0°", "+10°"} <= texts
    bars = [a for a in fig.axes if a is not ax]
    assert len(bars) == 1 and bars[0].get_ylabel() == LEVEL_LABEL
    assert bars[0].get_ylim() == (0.0, 255.0)
    assert ax.get_ylim() == pytest.approx((0.0, view.extent[3]))  # apex to the far edge
    assert view.extent[3] == pytest.approx(RANGE_M, abs=2 / PX_PER_M)


def test_the_strip_is_large_and_shows_the_diver(tmp_path):
    targets = [(0.3 * k - 0.8, 2.0 + k) for k in range(6)]
    rows = {"rov/sonar (P900-45)": [(10.0 * k, fan_with_blob(t), t)
                                    for k, t in enumerate(targets)]}
    path = plot_sonar_strip(rows, tmp_path / "sonar_strip.png")
    image = cv2.imread(str(path))
    assert image.shape[1] >= 2400 and image.shape[0] >= 400  # six 3.6-inch panels at 120 dpi
    # each panel is a 5 m crop: the bright disc (0.6 m across) spans many pixels
    bright = (image.min(axis=2) > 200).sum()
    assert bright > 6 * 100
