"""Sonar figure builders write the promised files with the right content."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from uhrisim.viz.sonar_figures import make_sonar_torus


@pytest.mark.slow
def test_make_sonar_torus(tmp_path: Path) -> None:
    paths = make_sonar_torus(tmp_path)
    names = sorted(p.name for p in paths)
    assert names == sorted(
        [f"sonar_torus_{s}"
         for s in ("scene_top.png", "2013.png", "fan.png", "labels.png", "panel.png",
                   "polar.npy", "fan_colour.png", "labels_colour.png")] + ["fan_geometry.json"]
    )
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)
    # the pair sonar-stats reads: an 8-bit fan and 16-bit object labels (the torus, not
    # the floor), with the fans' scale beside them, so ranges come out in metres
    from uhrisim.sensors.sonar.stats import image_stats, load_frames, load_px_per_m

    labels = cv2.imread(str(tmp_path / "sonar_torus_labels.png"), cv2.IMREAD_UNCHANGED)
    assert labels.dtype == np.uint16 and set(np.unique(labels)) == {0, 2}  # torus: id 1 + 1
    px_per_m = load_px_per_m(tmp_path)
    stats = image_stats(*load_frames(tmp_path), px_per_m=px_per_m)
    ranges_m = np.array(stats["range_profile"]["range_m"])
    np.testing.assert_allclose(ranges_m, np.array(stats["range_profile"]["range_px"]) / px_per_m,
                               atol=1e-3)
    assert 19.0 < ranges_m[-1] < 20.0 and stats["median_object_ratio"] > 1.0
    polar = np.load(tmp_path / "sonar_torus_polar.npy")
    # 20 m window at 2.54 cm bins (ceil(20/0.0254) = 788) × 256 beams, display scale 0…1.
    assert polar.shape == (788, 256) and polar.dtype == np.float32
    assert polar.min() >= 0.0 and polar.max() <= 1.0
    img = cv2.imread(str(tmp_path / "sonar_torus_2013.png"), cv2.IMREAD_GRAYSCALE)
    # 2013 image: 10 px/m over 20 m, apex top-left with a white boundary line from it.
    assert img.shape[1] == 201 and img[0, 0] == 255


@pytest.mark.slow
def test_make_sonar_tank(tmp_path: Path) -> None:
    import json

    from uhrisim.sensors.sonar.stats import image_stats, load_frames, load_px_per_m
    from uhrisim.viz.sonar_figures import make_sonar_tank

    paths = make_sonar_tank(tmp_path, n_frames=3)
    names = {p.name for p in paths}
    assert {"tank_000_fan.png", "tank_002_labels.png", "fan_mask.png", "tank_stats.json",
            "tank_panel.png", "tank_vendor.png", "fan_geometry.json"} <= names \
        and len(paths) == 3 * 2 + 5  # fmt: skip
    stats = json.loads((tmp_path / "tank_stats.json").read_text())
    # The statistics written are those sonar-stats finds in the folder (PNG round trip).
    again = image_stats(*load_frames(tmp_path), px_per_m=load_px_per_m(tmp_path))
    assert stats["range_profile"] == again["range_profile"]
    assert 9.0 < stats["range_profile"]["range_m"][-1] < 10.0  # the tank's 10 m fan
    assert stats["median_background_cv"] == again["median_background_cv"]
    assert stats["median_object_ratio"] == again["median_object_ratio"]
    assert stats["real_frame_bands"]["median_background_cv"] == [0.34, 0.5]
    labels = cv2.imread(str(tmp_path / "tank_000_labels.png"), cv2.IMREAD_UNCHANGED)
    assert labels.dtype == np.uint16 and len(np.unique(labels)) >= 4  # background + objects
