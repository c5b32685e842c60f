"""The command line: help, figures, benchmarks as JSON, and errors as one line."""

import json

import pytest
from typer.testing import CliRunner

from uhrisim.bench import available
from uhrisim.cli import app

runner = CliRunner()


def test_help_lists_the_commands():
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    for command in ("run", "validate", "view", "figure", "bench", "demo"):
        assert command in result.output


def test_bench_prints_one_json_object_with_rates():
    result = runner.invoke(app, ["bench", "dynamics", "--quick", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    # rates and their ratio are printed; how fast is for `uhrisim bench`, not for a test
    # (a busy machine measures anything)
    assert data["single_vehicle_steps_per_s"] > 0
    for size in ("10", "100"):
        batch = data["batch"][size]
        assert batch["vehicle_steps_per_s"] == pytest.approx(batch["batch_steps_per_s"]
                                                             * int(size))
        assert batch["cost_vs_single_loop"] == pytest.approx(
            data["single_vehicle_steps_per_s"] / batch["batch_steps_per_s"] / int(size))
    assert isinstance(data["target"]["meets_target"], bool)


def test_every_issue_benchmark_is_registered():
    assert {"dynamics", "sonar", "helm", "mission", "bridges", "raycast", "viewer",
            "camera", "team"} <= set(
        available())


def test_unknown_names_fail_with_exit_status_2():
    assert runner.invoke(app, ["bench", "nope"]).exit_code == 2
    assert runner.invoke(app, ["figure", "nope"]).exit_code == 2


def test_figure_openloop_writes_its_files(tmp_path):
    result = runner.invoke(app, ["figure", "openloop", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "openloop.csv").is_file() and (tmp_path / "openloop_track.png").is_file()
