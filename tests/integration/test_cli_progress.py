"""Nothing runs silent (issue 32): off a terminal (a pipe, a log, CI) ``uhrisim run``
writes one-line progress with simulated time, real-time factor and time left, ending at
the whole duration; ``--quiet`` writes none; ``uhrisim view`` says that it is indexing
the recording, and when it is done. The commands run in their own process, their stderr
a pipe, as in a CI log."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "track_and_trail.yaml"
LINE = re.compile(r"^track_and_trail: (\d+)/20 s simulated \((\d+) %\)"
                  r"(, [0-9.]+x real time(, about \d+ (s|min \d\d s) left)?)?$")


def uhrisim(*args: str | Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "uhrisim", *map(str, args)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)


def test_run_off_a_terminal_writes_progress_lines_and_view_says_it_is_indexing(tmp_path):
    done = uhrisim("run", SCENARIO, "--duration", "20", "--no-raycast-sensors",
                   "--no-figures", "--out", tmp_path / "run")
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("track_and_trail:")]
    assert lines and all(LINE.match(line) for line in lines), lines
    assert LINE.match(lines[-1]).group(1, 2) == ("20", "100")
    assert "x real time" in lines[-1]
    simulated = [int(LINE.match(line).group(1)) for line in lines]
    assert simulated == sorted(simulated)

    quiet = uhrisim("run", SCENARIO, "--duration", "2", "--no-raycast-sensors", "--quiet",
                    "--no-figures", "--out", tmp_path / "quiet")
    assert quiet.returncode == 0 and "s simulated" not in quiet.stderr

    recording = tmp_path / "run" / "recording.mcap"
    view = subprocess.Popen([sys.executable, "-m", "uhrisim", "view", str(recording),
                             "--port", "0"], stderr=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        assert view.stderr is not None
        first = view.stderr.readline()
        second = view.stderr.readline()
    finally:
        view.terminate()
        view.wait(timeout=60)
    assert re.match(rf"indexing {re.escape(str(recording))} \(\d+ MB\)", first), first
    assert re.match(r"indexed in [0-9.]+ s", second), second
