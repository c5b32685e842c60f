"""Every sonar preset renders the test tank (``scenarios/sonar_tank.yaml``) and the paper's
pier (Figs 12-14), with images a sonar user would recognise (issue 31): the debris and the
pilings brighter than the floor where the sonar's range and absorption let it see them,
no black pixel inside the fan, a floor that is not flat with range.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from uhrisim.sensors.sonar import PRESETS, SonarConfig, get_preset
from uhrisim.sensors.sonar.stats import image_stats, object_label_image
from uhrisim.viz.sonar_figures import (
    make_sonar_presets,
    make_sonar_tank,
    scene_pings,
    tank_frames,
)
from uhrisim.world.paper_scenes import pier_scene

pytestmark = pytest.mark.slow  # every preset through two scenes: minutes of CPU


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_every_preset_renders_the_tank(preset: str) -> None:
    pings, mask, background = tank_frames(3, preset=preset, fan_width_px=256)
    spec = get_preset(preset)
    assert pings[0].polar.shape[1] == spec.n_beams
    fans = [p.fan_u8 for p in pings]
    labels = [object_label_image(p.label_fan, background) for p in pings]
    stats = image_stats(fans, labels, mask, n_range_bins=10)
    # Debris in the fan of every frame (the 30° ARIS fans see the tire and the can), and
    # brighter than the floor around it; speckle like real frames' (std/mean 0.3–0.5);
    # nothing black inside the fan (the black level and the noise).
    assert stats["frames_with_objects"] == 3
    assert stats["median_object_ratio"] > 1.3
    assert 0.25 < stats["median_background_cv"] < 0.5
    assert stats["max_zero_fraction"] == 0.0
    inner = cv2.erode(mask.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # (the fan's
    assert min(int(f[inner].min()) for f in fans) >= spec.display_black_level  # edge blends)
    # The floor after the TVG is not flat with range (the lit floor from 5 m on).
    r = np.array(stats["range_profile"]["range_px"]) / pings[0].fan_px_per_m
    floor = np.array(stats["range_profile"]["relative_brightness"])[r > 5.0]
    assert (floor.max() - floor.min()) / floor.mean() > 0.05


@pytest.fixture(scope="module")
def pier():
    return pier_scene()


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_every_preset_renders_the_pier(pier, preset: str) -> None:
    phys, paper_mode = scene_pings(pier, "approach", 30.0, preset)
    spec = get_preset(preset)
    window = min(30.0, spec.max_range_m)
    assert phys.bin_ranges_m[-1] == pytest.approx(window, abs=spec.range_resolution_m)
    assert paper_mode.fan_u8.max() == 255  # the paper's image: hits and white fan lines
    piling = pier.scene.label_id("piling")
    lab = phys.label_polar
    assert (lab == piling).any()  # some piling lies in every preset's fan and window
    u8 = phys.polar_u8
    assert u8.min() >= spec.display_black_level
    # Where the pilings are close enough that the receiver's TVG still undoes the two-way
    # spreading and absorption (below its largest gain), they stand out of the rest (the
    # floor, or the water where the window ends before the beam meets the floor).
    cfg = SonarConfig(preset=preset, range_max_m=window)
    r_piling = float(np.min(np.broadcast_to(phys.bin_ranges_m[:, None], lab.shape)[lab == piling]))
    law = 40 * math.log10(r_piling) + 2 * cfg.alpha_db_per_m * r_piling
    if law <= cfg.tvg_cap_db:
        assert u8[lab == piling].mean() > 1.5 * np.median(u8[lab != piling])
    else:  # 3 MHz at 14 m: ~65 dB of absorption, beyond what the receiver makes up
        assert preset == "ARIS3000-3MHz"


def test_figure_sonar_tank_for_a_preset(tmp_path: Path) -> None:
    paths = make_sonar_tank(tmp_path, n_frames=2, preset="M750d-1.2MHz")
    stats = json.loads((tmp_path / "tank_stats.json").read_text())
    assert stats["preset"] == "M750d-1.2MHz" and stats["frames"] == 2
    vendor = cv2.imread(str(tmp_path / "tank_vendor.png"))
    fan = cv2.imread(str(tmp_path / "tank_000_fan.png"), cv2.IMREAD_GRAYSCALE)
    assert vendor.shape[:2] == fan.shape and vendor.ndim == 3
    assert (tmp_path / "tank_vendor.png") in paths


def test_the_preset_gallery_has_every_preset(tmp_path: Path) -> None:
    paths = make_sonar_presets(tmp_path, n_frames=1)
    names = {p.name for p in paths}
    assert names == {f"tank_{n}.jpg" for n in PRESETS} | {"presets_tank.json"}
    table = json.loads((tmp_path / "presets_tank.json").read_text())
    assert set(table) == set(PRESETS)
    image = cv2.imread(str(tmp_path / "tank_ARIS3000-3MHz.jpg"))
    assert max(image.shape[:2]) == 320


def test_figure_preset_option_applies_to_the_sonar_figures_only(capsys) -> None:
    from uhrisim.cli import main

    assert main(["figure", "openloop", "--preset", "P900-45"]) == 2
    assert "--preset applies to sonar-tank" in capsys.readouterr().err
    assert main(["figure", "sonar-tank", "--preset", "P901"]) == 2
    assert "unknown sonar preset 'P901'" in capsys.readouterr().err
