"""The fan-image statistics (``uhrisim sonar-stats``) on images whose numbers are known."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from uhrisim.cli import main
from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.stats import (
    apex_polar_coordinates,
    frame_stats,
    image_stats,
    load_frames,
    object_label_image,
)


def synthetic(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 64×64 'fan' (left 48 columns), background 100 ± uniform noise of half-width 50
    (std/mean = 50/√3/100 = 0.2887), an object block of 200, and zeros on 10 pixels."""
    rng = np.random.default_rng(seed)
    fan = np.zeros((64, 64), np.uint8)
    mask = np.zeros((64, 64), bool)
    mask[:, :48] = True
    fan[mask] = rng.integers(50, 151, mask.sum())  # 50..150 inclusive, mean 100
    labels = np.zeros((64, 64), np.uint16)
    labels[10:20, 10:20] = 3
    fan[10:20, 10:20] = 200
    fan[40, 30:40] = 0
    return fan, labels, mask


def test_frame_stats_on_known_numbers() -> None:
    fan, labels, mask = synthetic()
    s = frame_stats(fan, labels, mask)
    bg = fan[mask & (labels == 0)].astype(float)
    assert s.background_cv == pytest.approx(bg.std() / bg.mean())
    assert s.background_cv == pytest.approx(math.sqrt((101**2 - 1) / 12) / 100, abs=0.02)
    assert s.object_ratio == pytest.approx(200 / bg.mean())
    assert s.zero_fraction == pytest.approx(10 / mask.sum())
    assert (s.in_fan_px, s.object_px) == (64 * 48, 100)


def test_profiles_of_a_radial_ramp() -> None:
    # Brightness proportional to the distance from the bottom-centre apex: the range
    # profile is a straight line through the origin, the bearing profile flat-ish.
    r, bearing = apex_polar_coordinates((100, 101))
    mask = (r < 95) & (np.abs(bearing) < 40)
    fan = np.clip(r * 2.0, 0, 255).astype(np.uint8)
    labels = np.zeros(fan.shape, np.uint16)
    stats = image_stats([fan, fan], [labels, labels], mask, n_range_bins=8)
    x = np.array(stats["range_profile"]["range_px"])
    y = np.array(stats["range_profile"]["relative_brightness"])
    slope = y[-1] / x[-1]
    np.testing.assert_allclose(y, slope * x, rtol=0.08, atol=0.02)
    assert stats["median_object_ratio"] is None and stats["frames_with_objects"] == 0
    assert r[99, 50] == pytest.approx(0.5) and bearing[0, 100] > 0  # apex, + right


def test_object_label_image_keeps_objects_only() -> None:
    lab = np.array([[-1, 0, 1], [2, 0, 5]], np.int16)
    np.testing.assert_array_equal(object_label_image(lab, {0}), [[0, 0, 2], [3, 0, 6]])


def test_cli_reads_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for i in range(3):
        fan, labels, mask = synthetic(i)
        cv2.imwrite(str(tmp_path / f"f{i}_fan.png"), fan)
        cv2.imwrite(str(tmp_path / f"f{i}_labels.png"), labels)
    cv2.imwrite(str(tmp_path / "fan_mask.png"), mask.astype(np.uint8) * 255)
    assert main(["sonar-stats", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    fans, labs, m = load_frames(tmp_path)
    assert out == json.loads(json.dumps(image_stats(fans, labs, m)))
    assert out["frames"] == 3 and out["median_zero_fraction"] == pytest.approx(10 / (64 * 48))
    # Without a mask file the fan is the union of the non-zero pixels of the frames (the
    # 10 pixels that are zero in every frame fall out: pass a mask to count them).
    (tmp_path / "fan_mask.png").unlink()
    assert load_frames(tmp_path)[2].sum() == 64 * 48 - 10


def test_cli_bad_folders_are_one_line_errors(tmp_path: Path, capsys) -> None:
    assert main(["sonar-stats", str(tmp_path / "nope")]) == 2
    assert capsys.readouterr().err.strip().count("\n") == 0
    assert main(["sonar-stats", str(tmp_path)]) == 2  # no images
    cv2.imwrite(str(tmp_path / "a_fan.png"), np.zeros((8, 8), np.uint8))
    with pytest.raises(ConfigError, match="label image"):
        load_frames(tmp_path)
