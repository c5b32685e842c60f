"""``make docs-figures`` (docs/make_figures.py) writes the README's demo paragraph from
the run's metrics.json: the numbers a user reads are the run's, in the README's words."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def load_script():
    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "docs" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


METRICS = {"simulated_s": 600.0, "seed": 1, "time_to_acquire_s": 16.9, "collisions": 0,
           "range_error_m": {"rms": 0.1012, "p95_abs": 0.1849},
           "bearing_error_deg": {"rms": 12.61, "p95_abs": 20.0},
           "depth_error_m": {"rms": 0.002, "p95_abs": 0.0049, "max_abs": 0.0052},
           "min_separation_m": 1.8812}


def test_the_demo_paragraph_says_the_runs_numbers():
    text = load_script().demo_paragraph(METRICS)
    assert text == (
        "The paper's mission, 600 simulated seconds, seed 1 (`out/demo/metrics.json`): the "
        "ROV acquires the trail after 16.9 s and then holds it with a range error of 0.10 m "
        "RMS (p95 0.18 m), a bearing error of 12.6° RMS, the diver's depth within 5.2 mm, "
        "a minimum separation of 1.88 m and no collision.")


def test_the_readme_has_the_section_and_it_is_replaced_in_place():
    script = load_script()
    readme = (ROOT / "README.md").read_text()
    assert readme.count(script.START) == 1 and readme.count(script.END) == 1
    new = script.replace_demo_numbers(readme, METRICS)
    assert script.demo_paragraph(METRICS) in " ".join(new.split())
    assert new.split(script.START)[0] == readme.split(script.START)[0]
    assert new.split(script.END)[1] == readme.split(script.END)[1]
    with pytest.raises(SystemExit, match="no <!-- demo-metrics"):
        script.replace_demo_numbers("no markers here", METRICS)
