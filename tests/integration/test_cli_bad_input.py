"""The command line with bad input: one line on stderr, exit status 2, nothing started.

Issue 20's reproducers: options that are not finite or out of range, output folders that
cannot be written, messages with square brackets (never read as Rich markup), a missing
optional extra, metrics that must stay strict JSON, a failure that cleanup must not mask.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tests.support.cli import one_line_error
from uhrisim.app import runner as run_module
from uhrisim.app.runner import run_scenario, strict_json
from uhrisim.cli import app
from uhrisim.sim.simulation import BaseHook

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "track_and_trail.yaml"
cli = CliRunner()


@pytest.mark.parametrize(
    ("args", "parts"),
    [
        (["--duration", "nan"], ["--duration must be a finite number of seconds > 0", "nan"]),
        (["--duration", "inf"], ["--duration must be", "inf"]),
        (["--duration", "-5"], ["--duration must be", "-5.0"]),
        (["--duration", "0"], ["--duration must be"]),
        (["--seed", "-1"], ["--seed must be an integer >= 0, got -1"]),
        (["--rtf", "-1"], ["--rtf must be a finite number >= 0"]),
        (["--rtf", "nan"], ["--rtf must be"]),
        (["--port", "70000"], ["--port must be in 0..65535"]),
    ],
)
def test_run_options_are_checked_before_anything_starts(tmp_path, args, parts):
    out = tmp_path / "run"
    result = cli.invoke(app, ["run", str(SCENARIO), "--out", str(out), "--quiet", *args])
    one_line_error(result, *parts)
    assert not out.exists()


def test_output_folders_that_cannot_be_written(tmp_path):
    a_file = tmp_path / "taken"
    a_file.write_text("x")
    result = cli.invoke(app, ["run", str(SCENARIO), "--out", str(a_file), "--quiet",
                              "--duration", "1", "--no-raycast-sensors"])
    one_line_error(result, f"{a_file}: the output folder is a file")
    result = cli.invoke(app, ["run", str(SCENARIO), "--out", "/proc/uhrisim-out", "--quiet",
                              "--duration", "1", "--no-raycast-sensors"])
    one_line_error(result, "/proc/uhrisim-out: cannot write the run's outputs here")


def test_brackets_in_messages_are_text_not_markup(tmp_path):
    missing = tmp_path / "x[bold]y[/].yaml"
    one_line_error(cli.invoke(app, ["validate", str(missing)]),
                   f"{missing}: scenario file not found")
    bad = tmp_path / "s.yaml"
    bad.write_text("name: x\nagents:\n  - {name: rov, model: videoray, driver: none, "
                   "sensors: [{preset: 'P900[red]'}]}\n  - {name: d, model: diver, "
                   "driver: none, \"a[b]\": 1}\n")
    line = one_line_error(cli.invoke(app, ["validate", str(bad)]))
    assert "a[b]" in line or "P900[red]" in line


def test_an_install_hint_keeps_its_brackets(capsys):
    from uhrisim.cli import report_error

    report_error('pip install "uhrisim[viewer]"')
    assert 'pip install "uhrisim[viewer]"' in capsys.readouterr().err


def test_a_missing_extra_is_one_line_naming_it(tmp_path):
    # rclpy made unimportable in a child process: the scenario's ROS 2 bridge is on
    code = ("import sys; sys.modules['rclpy'] = None; from uhrisim.cli import app; "
            "app(prog_name='uhrisim')")
    scenario = ROOT / "scenarios" / "ros2_external_helm.yaml"
    child = subprocess.run(
        [sys.executable, "-c", code, "run", str(scenario), "--out", str(tmp_path / "o"),
         "--duration", "1", "--quiet", "--no-raycast-sensors"],
        capture_output=True, text=True, timeout=120,
        env={**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"},
    )
    assert child.returncode == 2, child.stderr
    lines = [line for line in child.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and 'pip install "uhrisim[ros2]"' in lines[0], child.stderr


def test_metrics_are_strict_json(tmp_path):
    assert strict_json({"a": math.inf, "b": [math.nan, 1.0], "c": {"d": -math.inf}}) == {
        "a": None, "b": [None, 1.0], "c": {"d": None}}
    result = run_scenario(SCENARIO, tmp_path, duration=2.0, raycast_sensors=False)

    def refuse(name: str) -> None:
        raise AssertionError(f"metrics.json holds {name}")

    data = json.loads((tmp_path / "metrics.json").read_text(), parse_constant=refuse)
    assert data["completed"] is True and result.metrics is not None


class _Boom(BaseHook):
    def on_tick(self, frame) -> None:
        if frame.t > 0.5:
            raise RuntimeError("boom in a hook")


def test_a_failed_run_is_not_masked_by_a_failing_cleanup(tmp_path, monkeypatch, caplog):
    def broken_outputs(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(run_module, "_write_outputs", broken_outputs)
    with pytest.raises(RuntimeError, match="boom in a hook"):
        run_scenario(SCENARIO, tmp_path, duration=2.0, raycast_sensors=False, extra_hooks=[_Boom()])
    assert "could not all be written" in caplog.text and "No space left" in caplog.text
