"""The scenarios shipped inside the package (uhrisim.scenario.shipped): found through
importlib.resources, listed, copied with the files they name, refused clearly."""

from pathlib import Path

import pytest

import uhrisim
from uhrisim.cli import main
from uhrisim.core.errors import ConfigError
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import (
    copy_scenario,
    scenario_summary,
    scenarios_dir,
    shipped_scenario,
    shipped_scenarios,
)


def test_the_shipped_folder_is_inside_the_package_and_every_scenario_loads():
    assert scenarios_dir().parent.resolve() == Path(uhrisim.__file__).parent.resolve()
    names = shipped_scenarios()
    assert "track_and_trail.yaml" in names and "batch/sweep_trail_gains.yaml" in names
    for name in names:
        if not name.startswith("batch/"):
            assert load_scenario(shipped_scenario(name)).scenario.duration > 0, name
        assert scenario_summary(shipped_scenario(name)), f"{name} says nothing about itself"


def test_a_name_without_yaml_and_an_unknown_name():
    assert shipped_scenario("sonar_tank") == shipped_scenario("sonar_tank.yaml")
    with pytest.raises(ConfigError, match=r"no shipped scenario named 'nope'; available: .*"
                                          r"track_and_trail\.yaml"):
        shipped_scenario("nope")


def test_copy_takes_the_files_the_scenario_names_and_keeps_relative_paths(tmp_path):
    written = copy_scenario("batch/sweep_trail_gains", tmp_path)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in written) == [
        "batch/sweep_trail_gains.yaml", "track_and_trail.yaml", "videoray_trail.bhv"]
    assert (tmp_path / "track_and_trail.yaml").read_text() == \
        shipped_scenario("track_and_trail").read_text()
    moos = copy_scenario("moos_external_helm", tmp_path / "moos")
    assert {p.name for p in moos} >= {"moos_external_helm_videoray.moos",
                                      "launch_moos_external_helm.sh"}


def test_copy_refuses_to_overwrite(tmp_path, capsys):
    copy_scenario("track_and_trail", tmp_path)
    assert main(["scenarios", "copy", "track_and_trail", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'track_and_trail.yaml'} exists" in err and "Traceback" not in err


def test_cli_lists_and_prints_paths(capsys):
    assert main(["scenarios"]) == 0
    listing = capsys.readouterr().out
    assert all(name.removesuffix(".yaml") in listing for name in shipped_scenarios())
    assert main(["scenarios", "path", "sonar_tank"]) == 0
    assert capsys.readouterr().out.strip() == str(shipped_scenario("sonar_tank"))
