"""``sonar-compare`` on synthetic frames of known statistics (tests/support/synthetic_fans.py):
each measure recovers the value the frames were made with, within its stated tolerance
(``docs/sonar.md``); a folder compared with itself differs by nothing."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tests.support import synthetic_fans as sf
from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.compare import (
    FanGeometry,
    compare_folders,
    emd_levels,
    js_divergence,
    k_shape,
    kl_divergence,
    lbp_riu2,
    load_frame_set,
    report_lines,
    speckle_statistics,
)


def frames_of(make, n: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [sf.to_fan(make(rng)) for _ in range(n)]


def measures(tmp_path: Path, a: list, b: list, geometry=None, **kw) -> dict:
    real = sf.write_folder(tmp_path / "real", a, kw.get("objects_a"))
    sim = sf.write_folder(tmp_path / "sim", b, kw.get("objects_b"))
    return compare_folders(real, sim, geometry)[0]["measures"]


def test_rayleigh_speckle_of_known_scale(tmp_path: Path) -> None:
    # σ = 40 grey levels: the fitted scale within 1 % (the 8-bit rounding is symmetric),
    # the KS statistic against the Rayleigh law below 0.01, and no K texture (ν ≥ 30,
    # the ratio by the local mean adds a little).
    folder = sf.write_folder(tmp_path / "r", frames_of(lambda r: sf.rayleigh(r, 40.0), 4, 1))
    stats = speckle_statistics(load_frame_set(folder))
    assert stats["rayleigh_scale"] == pytest.approx(40.0, rel=0.01)
    assert stats["ks_rayleigh"] < 0.01
    assert stats["k_shape"] >= 30.0


@pytest.mark.parametrize("nu", [1.0, 3.0])
def test_k_distributed_field_of_known_shape(tmp_path: Path, nu: float) -> None:
    # Amplitude √(G·X) with Gamma texture of shape ν: the log-moment estimate within 25 %
    # (the local-mean ratio and the 8-bit rounding), and the K law fits better than the
    # Rayleigh one, whose KS statistic shows the heavy tail.
    folder = sf.write_folder(tmp_path / f"k{nu}",
                             frames_of(lambda r: sf.k_field(r, nu, 40.0), 4, 2))  # fmt: skip
    stats = speckle_statistics(load_frame_set(folder))
    assert stats["k_shape"] == pytest.approx(nu, rel=0.25)
    assert stats["ks_k"] < 0.02 < stats["ks_rayleigh"]


def test_k_shape_estimator_on_exact_draws() -> None:
    # The estimator itself, without images: 10⁶ draws, ν within 3 %; exponential → ∞.
    rng = np.random.default_rng(3)
    for nu in (0.7, 2.0, 8.0):
        intensity = rng.gamma(nu, 1.0 / nu, 1_000_000) * rng.exponential(1.0, 1_000_000)
        assert k_shape(intensity) == pytest.approx(nu, rel=0.03)
    assert k_shape(rng.exponential(3.0, 1_000_000)) > 100.0


@pytest.mark.slow
@pytest.mark.parametrize(("std_range", "std_beams"), [(2.0, 3.0), (3.0, 5.0)])
def test_speckle_grain_of_known_width_in_resolution_cells(tmp_path, std_range, std_beams):
    # Grain FWHM 2√(2 ln 2)·s along each axis. Give the geometry a "pulse" and a "beam"
    # exactly that wide: the grain measures 1 resolution cell each way, within 10 %.
    frames = frames_of(lambda r: sf.grained(r, std_range, std_beams), 6, 4)
    width_deg = sf.FWHM_PER_STD * std_beams * sf.FOV_DEG / (sf.N_BEAMS - 1)
    pulse_m = sf.FWHM_PER_STD * std_range  # 1 px = 1 m: the range window is 0–SIZE m
    geometry = FanGeometry(sf.FOV_DEG, (0.0, float(sf.SIZE)), width_deg, pulse_m)
    m = measures(tmp_path, frames, frames, geometry)
    assert m["grain_range"]["real"] == pytest.approx(1.0, abs=0.1)
    assert m["grain_bearing"]["real"] == pytest.approx(1.0, abs=0.1)


@pytest.mark.slow
def test_grain_twice_as_wide_is_seen_twice_as_wide(tmp_path: Path) -> None:
    fine = frames_of(lambda r: sf.grained(r, 1.5, 2.5), 6, 5)
    coarse = frames_of(lambda r: sf.grained(r, 3.0, 5.0), 6, 6)
    m = measures(tmp_path, fine, coarse)
    ratio_range = m["grain_range"]["sim"] / m["grain_range"]["real"]
    ratio_bearing = m["grain_bearing"]["sim"] / m["grain_bearing"]["real"]
    assert ratio_range == pytest.approx(2.0, rel=0.1)
    assert ratio_bearing == pytest.approx(2.0, rel=0.1)
    assert m["grain_range"]["verdict"] == m["grain_bearing"]["verdict"] == "differs"
    assert m["lbp_js_divergence_bits"]["verdict"] == "differs"  # texture differs too


def test_a_folder_against_itself_differs_by_nothing(tmp_path: Path) -> None:
    frames = frames_of(lambda r: sf.k_field(r, 2.0, 40.0), 4, 7)
    rng = np.random.default_rng(8)
    objects = [rng.random(f.shape) < 0.01 for f in frames]
    folder = sf.write_folder(tmp_path / "same", frames, objects)
    report, _ = compare_folders(folder, folder)
    for key, m in report["measures"].items():
        assert m["difference"] == 0.0, key
        assert m["verdict"] == "match", key
    assert report["verdicts"]["match"] == len(report["measures"])


@pytest.mark.slow
def test_histogram_divergences_of_two_known_rayleigh_laws(tmp_path: Path) -> None:
    # σ = 40 against σ = 44: one law lies wholly above the other (F_44 ≤ F_40), so the
    # earth mover's distance is the difference of the means — of the frames' (exactly) and
    # of the laws, (44 − 40)·√(π/2) = 5.01 grey levels (within 5 %: ~200 k pixels each);
    # KL and JS are positive, JS symmetric and bounded by 1 bit.
    a = frames_of(lambda r: sf.rayleigh(r, 40.0), 4, 9)
    b = frames_of(lambda r: sf.rayleigh(r, 44.0), 4, 10)
    m = measures(tmp_path, a, b)
    inside = sf.fan_maps()[2]
    means = [np.mean([f[inside].mean() for f in frames]) for frames in (a, b)]
    assert m["emd_grey_levels"]["difference"] == pytest.approx(means[1] - means[0], rel=1e-5)
    assert m["emd_grey_levels"]["difference"] == pytest.approx(4 * math.sqrt(math.pi / 2),
                                                                rel=0.05)  # fmt: skip
    assert 0 < m["js_divergence_bits"]["difference"] < 1
    assert m["kl_divergence_bits"]["difference"] > 0
    assert m["rayleigh_scale"]["difference"] == pytest.approx(0.1, abs=0.01)
    assert m["emd_grey_levels"]["verdict"] == "differs"


def test_divergence_formulas() -> None:
    p = np.array([0.5, 0.5, 0.0])
    q = np.array([0.0, 0.5, 0.5])
    assert js_divergence(p, q) == pytest.approx(0.5)  # half the mass disjoint: ½ bit
    assert js_divergence(p, q) == pytest.approx(js_divergence(q, p))
    assert js_divergence(p, p) == 0.0 and kl_divergence(p, p) == pytest.approx(0.0, abs=1e-12)
    assert emd_levels(p, q) == pytest.approx(1.0)  # half the mass moved two levels
    assert emd_levels(np.array([1.0, 0, 0, 0]), np.array([0, 0, 0, 1.0])) == pytest.approx(3.0)


def test_lbp_codes_of_known_patterns() -> None:
    flat = np.full((5, 5), 7, np.uint8)
    assert (lbp_riu2(flat)[1:-1, 1:-1] == 8).all()  # every neighbour ≥ the centre
    peak = flat.copy()
    peak[2, 2] = 9
    assert lbp_riu2(peak)[2, 2] == 0  # a peak: no neighbour reaches it
    edge = np.tile(np.array([0, 0, 5, 5, 5], np.uint8), (5, 1))
    assert lbp_riu2(edge)[2, 2] == 5  # a vertical edge: 5 of 8 ≥, one run (uniform)
    cross = np.full((5, 5), 5, np.uint8)  # brighter left and right, darker above and below
    cross[2, 1] = cross[2, 3] = 9
    cross[1, 2] = cross[3, 2] = 0
    assert lbp_riu2(cross)[2, 2] == 9  # two runs of ones: 4 transitions, not uniform


def test_contrast_fractions_and_profiles_of_known_frames(tmp_path: Path) -> None:
    # Background 50, objects 100 (contrast 2), 10 pixels at 0 and 20 at 255 per frame;
    # the background flat across the fan and along range (profiles all 1).
    _, _, inside = sf.fan_maps()
    frames, objects = [], []
    ys, xs = np.nonzero(inside)
    for k in range(3):
        f = np.where(inside, 50, 0).astype(np.uint8)
        obj = np.zeros_like(inside)
        obj[200:210, 120:136] = True
        f[obj] = 100
        f[ys[k * 40 : k * 40 + 10], xs[k * 40 : k * 40 + 10]] = 0
        f[ys[-20:], xs[-20:]] = 255
        frames.append(f)
        objects.append(obj)
    folder = sf.write_folder(tmp_path / "known", frames, objects)
    report, curves = compare_folders(folder, folder)
    m = report["measures"]
    n = int(inside.sum())
    assert m["object_contrast"]["real"] == pytest.approx(2.0, rel=0.01)
    assert m["zero_fraction"]["real"] == pytest.approx(10 / n, rel=1e-5)  # (6 digits)
    assert m["saturated_fraction"]["real"] == pytest.approx(20 / n, rel=1e-5)
    profiles = curves["real"].profiles
    assert np.nanmax(np.abs(profiles["bearing"] - 1.0)) < 0.05
    assert np.nanmax(np.abs(profiles["range"][3:] - 1.0)) < 0.05


def test_report_lines_name_every_measure(tmp_path: Path) -> None:
    frames = frames_of(lambda r: sf.rayleigh(r, 40.0), 2, 11)
    folder = sf.write_folder(tmp_path / "a", frames)
    report, _ = compare_folders(folder, folder)
    text = "\n".join(report_lines(report))
    for key in report["measures"]:
        assert key in text
    assert f"{report['verdicts']['match']} match" in text


@pytest.mark.parametrize(("setup", "message"), [
    ("missing", "is not a folder"),
    ("empty", r"no \*\.png frames"),
    ("colour", "8-bit single-channel"),
    ("sizes", "first frame"),
    ("masks", "no object mask"),
])  # fmt: skip
def test_bad_folders_name_the_problem_and_the_file(tmp_path: Path, setup, message) -> None:
    import cv2

    folder = tmp_path / "f"
    if setup != "missing":
        folder.mkdir()
    frame = np.full((32, 32), 10, np.uint8)
    if setup == "colour":
        cv2.imwrite(str(folder / "a.png"), np.zeros((8, 8, 3), np.uint8))
    if setup == "sizes":
        cv2.imwrite(str(folder / "a.png"), frame)
        cv2.imwrite(str(folder / "b.png"), np.zeros((16, 16), np.uint8))
    if setup == "masks":
        cv2.imwrite(str(folder / "a.png"), frame)
        cv2.imwrite(str(folder / "a_mask.png"), frame)
        cv2.imwrite(str(folder / "b.png"), frame)
    with pytest.raises(ConfigError, match=message):
        load_frame_set(folder)


@pytest.mark.slow
def test_the_command_writes_its_report_text_json_and_figure(tmp_path: Path, capsys) -> None:
    import json

    from uhrisim.cli import main

    a = sf.write_folder(tmp_path / "a", frames_of(lambda r: sf.rayleigh(r, 40.0), 2, 12))
    b = sf.write_folder(tmp_path / "b", frames_of(lambda r: sf.rayleigh(r, 60.0), 2, 13))
    out = tmp_path / "out"
    assert main(["sonar-compare", str(a), str(b), "--fov", "90", "--range", "0:256",
                 "--out", str(out), "--json"]) == 0  # fmt: skip
    printed = json.loads(capsys.readouterr().out)
    written = json.loads((out / "report.json").read_text())
    assert printed == written
    assert written["geometry"]["real"]["fov_deg"] == 90.0
    assert written["grain_units"] == {"range": "m", "bearing": "deg"}
    assert written["measures"]["rayleigh_scale"]["verdict"] == "differs"
    assert "rayleigh_scale" in (out / "report.txt").read_text()
    assert (out / "compare.png").stat().st_size > 10_000
    # A preset gives the grain in resolution cells.
    assert main(["sonar-compare", str(a), str(a), "--preset", "P900-90", "--range", "0:10",
                 "--out", str(out)]) == 0  # fmt: skip
    assert "range resolution cells" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["--range", "5"], "--range must be MIN:MAX"),
    (["--range", "9:3"], "MIN < MAX"),
    (["--fov", "200"], "--fov must be in (0, 180)"),
    (["--preset", "P901"], "unknown sonar preset"),
    (["--preset", "P900-45", "--fov", "40"], "not both"),
])  # fmt: skip
def test_the_command_refuses_bad_options_in_one_line(tmp_path: Path, capsys, args, message):
    from uhrisim.cli import main

    a = sf.write_folder(tmp_path / "a", frames_of(lambda r: sf.rayleigh(r, 40.0), 1, 14))
    assert main(["sonar-compare", str(a), str(a), "--out", str(tmp_path / "o"), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
