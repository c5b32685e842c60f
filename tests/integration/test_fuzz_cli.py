"""Fuzzing the command line's values: whatever options a user types, ``uhrisim run`` and
``uhrisim validate`` either work (exit 0) or say what is wrong in one line (exit 2) -
never a traceback, never a hang."""

from __future__ import annotations

import contextlib
import io
import math
from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tests.support.time_limit import time_limit
from uhrisim.cli import main

SCENARIO = """\
name: cli-fuzz
duration: 1
world: {seafloor: {type: flat, depth: 8, extent: 30}}
agents:
  - {name: rov, model: videoray, driver: none, start: {depth: 1}}
recording: {odometry_rate_hz: 10}
"""

ODD = st.sampled_from(["nan", "inf", "-inf", "1e999", "", "abc", "[bold]", "0x10", "-0"])
# durations a valid run keeps short (<= 1 s simulated), or not valid at all
DURATIONS = st.one_of(st.floats(min_value=-1e6, max_value=1.0, allow_nan=False),
                      st.integers(-2**70, 0).map(str), ODD)
NUMBERS = st.one_of(st.floats(allow_nan=False, width=32), st.integers(-2**70, 2**70).map(str),
                    ODD)
OPTIONS = st.lists(st.one_of(
    st.tuples(st.just("--duration"), DURATIONS),
    st.tuples(st.just("--seed"), NUMBERS),
    st.tuples(st.just("--rtf"), st.one_of(st.floats(max_value=0.0, allow_nan=False), ODD)),
    st.tuples(st.just("--port"), NUMBERS),
    st.tuples(st.sampled_from(["--no-raycast-sensors", "--quiet", "--bogus", "-q"])),
    st.tuples(st.just("--out"), st.sampled_from(["taken", "ok[1]", "/proc/x", ""])),
), max_size=4)


@settings(max_examples=120, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(command=st.sampled_from(["run", "validate"]), options=OPTIONS)
def test_any_options_work_or_are_refused_in_one_line(tmp_path: Path, command, options):
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO)
    (tmp_path / "taken").write_text("a file where a folder should be")
    argv = [command, str(scenario)]
    for option in options:
        if option[0] == "--out" and option[1] and option[1] != "/proc/x":
            option = (option[0], str(tmp_path / option[1]))
        argv += list(option)
    if command == "run" and not any(o[0] == "--duration" for o in options):
        argv += ["--duration", "0.5"]  # a valid run stays short
    err = io.StringIO()
    with time_limit(30, str(argv)), contextlib.chdir(tmp_path), \
            contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(argv)  # "--out ''" is the folder we are in: tmp_path
    lines = [line for line in err.getvalue().splitlines() if line.strip()]
    if status == 2:
        assert len(lines) == 1 and lines[0].startswith("error: "), (argv, err.getvalue())
        event("refused")
    else:
        assert status == 0, (argv, err.getvalue())
        assert not any(line.startswith("error") for line in lines), err.getvalue()
        event("ran")


def test_an_accepted_duration_is_what_runs(tmp_path: Path):
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "out"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["run", str(scenario), "--duration", "0.5", "--out", str(out), "-q"]) == 0
    assert math.isclose(__import__("json").loads((out / "metrics.json").read_text())[
        "simulated_s"], 0.5, abs_tol=1e-9)
