"""A recording process killed with SIGKILL leaves a file readable up to its last chunk.

The child writes odometry forever with small chunks (values are a known function of
the message index); the test kills it once the file has grown past a few chunks.
Expected: the reader (uhrisim.record.reader) reports a truncated file, decodes every
message it returns, and the messages are exactly the first n ticks with no gaps; the
``mcap`` non-seeking reader (independent) yields the same messages before it hits the
cut. ``rosbags`` cannot open such a file (it requires the end magic), see the module
docstring of uhrisim.record.reader.
"""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.exceptions import EndOfFile
from mcap.reader import NonSeekingReader

from uhrisim.record import iter_messages, read_odometry, summarize

SRC = Path(__file__).resolve().parents[2] / "src"
#: Seconds after which a writer that has not written 120 kB is taken as hung (a loaded
#: machine starts Python and imports uhrisim in well under a minute).
HUNG_WRITER_S = 600.0

CHILD = """
import sys
from uhrisim.record import McapRecorder
rec = McapRecorder(sys.argv[1], chunk_size=4096)
i = 0
while True:  # killed from outside
    t = 0.05 * i
    rec.write_odometry("rov", t, (0.01 * i, -0.02 * i, 1.0 + 0.001 * i), 0.0, (0.5, 0, 0), 0.0)
    rec.write_odometry("diver", t, (5.0, 0.03 * i, 2.0), 1.0, (0.2, 0, 0), 0.0)
    i += 1
"""


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX SIGKILL")
def test_sigkill_half_way_leaves_a_readable_file(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(path)], env=env)
    try:
        deadline = time.monotonic() + HUNG_WRITER_S  # only against a writer that hangs
        while not (path.exists() and path.stat().st_size > 120_000):
            assert proc.poll() is None, "writer process died on its own"
            assert time.monotonic() < deadline, f"writer hung: too little in {HUNG_WRITER_S} s"
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL

    data = path.read_bytes()
    assert not data.endswith(b"\x89MCAP0\r\n") or len(data) < 16  # no footer magic

    summary = summarize(path)
    assert summary.truncated and summary.complete_chunks > 10
    n_rov = summary.topics["/rov/odom"][1]
    n_div = summary.topics["/diver/odom"][1]
    assert n_rov > 0 and n_rov - 1 <= n_div <= n_rov  # rov then diver within each tick

    # Every returned message decodes; the tracks are the first n ticks, without gaps.
    decoded = list(iter_messages(path))
    assert len(decoded) == sum(c for _, c in summary.topics.values())
    tracks = read_odometry(path)
    rov = tracks["rov"]
    i = np.arange(n_rov)
    np.testing.assert_allclose(rov.t, 0.05 * i, atol=1e-9)
    np.testing.assert_allclose(rov.x_north, 0.01 * i, atol=1e-12)
    np.testing.assert_allclose(rov.y_east, -0.02 * i, atol=1e-12)
    np.testing.assert_allclose(rov.depth, 1.0 + 0.001 * i, atol=1e-12)
    np.testing.assert_allclose(tracks["diver"].y_east, 0.03 * np.arange(n_div), atol=1e-12)
    np.testing.assert_allclose(tracks["diver"].yaw, 1.0, atol=1e-12)

    # Independent check: mcap's streaming reader yields the same messages, then fails.
    theirs = []
    with pytest.raises(EndOfFile):
        for _s, ch, msg in NonSeekingReader(io.BytesIO(data)).iter_messages(
            log_time_order=False
        ):
            theirs.append((ch.topic, msg.log_time, msg.data))
    ours = [(m.topic, m.log_time_ns) for m in decoded]
    assert [(t, lt) for t, lt, _ in theirs] == ours
