"""Smoke test of the helm benchmark's report structure (no timing asserts)."""

from __future__ import annotations

import json

import pytest

from uhrisim.bench import helm as bench


def test_quick_bench_report_is_complete_and_json():
    r = bench.run(quick=True)
    json.dumps(r)
    assert set(r["cases"]) == {"1_behaviors", "3_behaviors", "10_behaviors"}
    for n, case in ((1, r["cases"]["1_behaviors"]), (10, r["cases"]["10_behaviors"])):
        assert case["behaviors"] == n and case["active_behaviors"] == n  # all really active
        assert case["decisions_per_s"] > 0
        assert case["core_fraction_at_4hz"] == pytest.approx(4.0 / case["decisions_per_s"])
        assert isinstance(case["meets_target"], bool)
    assert r["target"]["core_fraction_at_4hz_below"] == 0.01


def test_quick_mission_case_reports_both_helms():
    m = bench._measure_mission(quick=True)
    json.dumps(m)
    # both helms at 4 Hz over the timed 5 s of the quick run: every decision timed
    assert m["agents"] == ["diver", "videoray"] and m["decisions"] == 2 * 4 * 5
    assert m["decisions_per_s"] == pytest.approx(1e3 / m["ms_per_decision"])
    assert m["meets_target"] == (m["ms_per_decision"] <= m["target_ms_per_decision"])

