"""Smoke test of ``uhrisim bench record`` in quick mode: shape and sanity of the numbers.

No wall-clock thresholds here (speed is for the benchmark to print); what is checked
is internal consistency: the three Odometry encoders agree byte for byte, counts match
the configuration, and the uncompressed sonar file is at least the raw image bytes.
"""

from __future__ import annotations

import json

from uhrisim.bench.record import run


def test_quick_bench_reports_consistent_numbers() -> None:
    r = run(quick=True)
    json.dumps(r)  # JSON-serialisable
    assert r["config"]["quick"] is True
    assert r["odometry_encoder"]["identical_bytes"] is True
    odo = r["odometry_zstd"]
    # each call: /<agent>/odom, /<agent>/pose and /tf (issue 16: the live topics)
    assert odo["messages"] == 3 * odo["calls"] and odo["calls_per_s"] > 0
    raw = r["sonar_uncompressed"]
    # Uncompressed: the file carries every image byte (plus headers, points, tf, odom).
    assert raw["compression_ratio"] <= 1.0
    assert r["sonar_zstd"]["compression_ratio"] > 1.0  # speckle images still compress
    assert isinstance(r["meets_target"], bool)
    assert set(r["targets"]) == {"odometry_calls_per_s", "sonar_pings_per_s"}
