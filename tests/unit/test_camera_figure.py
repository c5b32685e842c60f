"""``uhrisim figure camera``: the diver fades with turbidity and distance (contrast table)."""

from __future__ import annotations

import csv

import pytest

from uhrisim.viz.camera_figures import make_camera


@pytest.mark.slow
def test_camera_figure_contrast_falls_with_turbidity_and_distance(tmp_path):
    files = make_camera(tmp_path)
    assert (tmp_path / "camera_grid.png").stat().st_size > 50_000
    assert len([f for f in files if f.name.startswith("camera_") and f.suffix == ".png"]) == 13
    with open(tmp_path / "camera_contrast.csv") as f:
        rows = list(csv.DictReader(f))
    contrast = {(r["water"], r["distance_m"], r["lamps"]): float(r["contrast_g"]) for r in rows}
    for distance in ("1.5", "5"):
        for lamps in ("true", "false"):
            clear, coastal, turbid = (contrast[(w, distance, lamps)]
                                      for w in ("clear", "coastal", "turbid"))
            assert clear > coastal > turbid, (distance, lamps)
    for water in ("clear", "coastal", "turbid"):
        for lamps in ("true", "false"):
            assert contrast[(water, "1.5", lamps)] > contrast[(water, "5", lamps)]
    # in turbid water close up, the ROV's lamps still help more than their veil hurts
    assert contrast[("turbid", "1.5", "true")] > contrast[("turbid", "1.5", "false")]
