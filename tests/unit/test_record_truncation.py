"""Truncating a finished recording at any byte: the reader returns whole chunks only.

Provenance of the expectation: ``mcap``'s own non-seeking reader, run on the same
prefix, yields the messages of every complete chunk before it fails on the cut; ours
must return exactly those, never raise, and return everything on the whole file.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import NonSeekingReader, make_reader

from uhrisim.record import McapRecorder, iter_raw_messages, summarize


def mcap_prefix_messages(data: bytes) -> list[tuple[str, int, bytes]]:
    out = []
    try:
        for _s, ch, m in NonSeekingReader(io.BytesIO(data)).iter_messages(log_time_order=False):
            out.append((ch.topic, m.log_time, m.data))
    except Exception:  # the cut: EndOfFile, or a short chunk failing to decompress
        pass
    return out


@pytest.mark.slow
@pytest.mark.parametrize("compression", ["zstd", "none"])
def test_every_cut_reads_up_to_the_last_complete_chunk(tmp_path: Path, compression) -> None:
    full = tmp_path / "full.mcap"
    with McapRecorder(full, chunk_size=1500, compression=compression) as rec:
        for i in range(120):
            rec.write_odometry("rov", 0.1 * i, (0.1 * i, 0, 1), 0.0, (1, 0, 0), 0.0)
            if i % 10 == 0:
                rec.write_variable("rov", 0.1 * i, "MODE", f"M{i}", "helm")
    data = full.read_bytes()
    everything = [(c.topic, m.log_time, m.data) for _s, c, m in iter_raw_messages(full)]
    total = len(everything)
    assert total == 120 * 3 + 12  # odometry, pose and /tf per call; the variables
    cut_path = tmp_path / "cut.mcap"
    previous = 0
    # A sweep, plus the bytes either side of every chunk record's end.
    with full.open("rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    ends = [c.chunk_start_offset + c.chunk_length for c in chunks]
    cuts = sorted({*range(8, len(data), len(data) // 150), *(e - 1 for e in ends), *ends,
                   len(data) - 1})
    for cut in cuts:
        cut_path.write_bytes(data[:cut])
        ours = [(c.topic, m.log_time, m.data) for _s, c, m in iter_raw_messages(cut_path)]
        if compression == "zstd":
            assert ours == mcap_prefix_messages(data[:cut])
        assert ours == everything[: len(ours)]
        assert len(ours) >= previous  # more bytes never give fewer messages
        previous = len(ours)
        if len(ours) < total:  # a cut inside the data section is reported
            assert summarize(cut_path).truncated
    assert previous == total  # the data section is complete before the summary starts
    assert not summarize(full).truncated


def test_flush_period_bounds_what_a_crash_loses(tmp_path: Path) -> None:
    path = tmp_path / "periodic.mcap"
    rec = McapRecorder(path, chunk_size=10**9, flush_period_s=1.0)
    for i in range(35):  # 3.4 s of simulated time at 10 Hz
        rec.write_odometry("rov", 0.1 * i, (0, 0, 0), 0.0, (0, 0, 0), 0.0)
    # Not closed (as if killed): chunks were closed at t = 0, 1, 2, 3 s.
    counts = summarize(path).topics
    assert counts["/rov/odom"][1] == 31  # everything up to and including t = 3.0 s
    rec.close()
    assert summarize(path).topics["/rov/odom"][1] == 35


def test_recover_makes_a_truncated_file_readable_by_rosbags(tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    from uhrisim.record import read_odometry, recover

    full = tmp_path / "full.mcap"
    with McapRecorder(full, chunk_size=2000) as rec:
        for i in range(100):
            rec.write_odometry("rov", 0.1 * i, (0.1 * i, 0, 1), 0.0, (1, 0, 0), 0.0)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full.read_bytes()[: full.stat().st_size // 2])
    # (rosbags 0.11 refuses ``cut`` itself: "File end magic is invalid".)
    fixed = tmp_path / "fixed.mcap"
    n = recover(cut, fixed)
    assert n == sum(c for _, c in summarize(cut).topics.values()) > 0
    with AnyReader([fixed]) as reader:
        got = [(c.topic, t) for c, t, _raw in reader.messages()]
    assert got == [(c.topic, m.log_time) for _s, c, m in iter_raw_messages(cut)]
    np.testing.assert_array_equal(read_odometry(fixed)["rov"].t, read_odometry(cut)["rov"].t)
    assert not summarize(fixed).truncated
