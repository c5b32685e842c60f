"""A plain ``pip install`` runs the main things (issue 32): the wheel built from this
source, installed (not editable) into a fresh venv and run from a folder outside the
checkout, finds its scenarios, helm files and data with ``importlib.resources``.

Offline and quick: the wheel is built with the test venv's setuptools (no build
isolation, no index) and installed with ``--no-deps``; the fresh venv sees the test venv's
site-packages (numpy, gymnasium, ...) through a ``.pth`` path line, which adds the folder
without running its ``.pth`` files, so the checkout's editable install stays invisible.
"""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _run(*command: str | Path, cwd: Path) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    done = subprocess.run([str(c) for c in command], cwd=cwd, env=env, text=True,
                          capture_output=True)
    assert done.returncode == 0, f"{command} failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(bin folder of a fresh venv holding the installed wheel, a work folder outside the
    checkout)."""
    root = tmp_path_factory.mktemp("wheel")
    source = root / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "src", source / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    _run(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "--no-index", "-q", "-w", root / "dist", source, cwd=root)
    wheel = next((root / "dist").glob("uhrisim-*.whl"))
    venv = root / "venv"
    _run(sys.executable, "-m", "venv", "--without-pip", venv, cwd=root)
    bin_dir = venv / "bin"
    purelib = _run(bin_dir / "python", "-c", "import sysconfig; print(sysconfig.get_path("
                   "'purelib'))", cwd=root).strip()
    Path(purelib, "uhrisim_test_venv.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    _run(sys.executable, "-m", "pip", "--python", bin_dir / "python", "install", "--no-deps",
         "--no-index", "-q", wheel, cwd=root)
    work = root / "work"
    work.mkdir()
    where = _run(bin_dir / "python", "-c", "import uhrisim; print(uhrisim.__file__)", cwd=work)
    assert Path(where.strip()).is_relative_to(Path(purelib)), where  # the wheel, not the checkout
    return bin_dir, work


def test_demo_runs_from_the_installed_wheel(installed):
    bin_dir, work = installed
    _run(bin_dir / "uhrisim", "demo", "--duration", "30", "--out", "demo", cwd=work)
    metrics = json.loads((work / "demo" / "metrics.json").read_text())
    assert metrics["simulated_s"] == 30.0 and metrics["collisions"] == 0
    assert metrics["min_separation_m"] > 0.5
    for name in ("recording.mcap", "sonar_strip.png", "openloop/openloop_track.png"):
        assert (work / "demo" / name).stat().st_size > 1000, name


def test_gymnasium_episode_and_a_figure_from_the_installed_wheel(installed):
    bin_dir, work = installed
    episode = ("import gymnasium, uhrisim.envs, numpy as np\n"
               "env = gymnasium.make('uhrisim/TrailDiverState-v0', time_limit_s=10.0)\n"
               "obs, _ = env.reset(seed=3)\n"
               "steps, done = 0, False\n"
               "while not done:\n"
               "    obs, r, term, trunc, info = env.step(np.zeros(env.action_space.shape,"
               " np.float32))\n"
               "    steps, done = steps + 1, term or trunc\n"
               "print(steps, trunc, np.all(np.isfinite(obs)))\n")
    steps, truncated, finite = _run(bin_dir / "python", "-c", episode, cwd=work).split()
    assert int(steps) > 1 and truncated == "True" and finite == "True"
    _run(bin_dir / "uhrisim", "figure", "sonar-tank", "--out", "fig", cwd=work)
    stats = json.loads((work / "fig" / "tank_stats.json").read_text())
    assert stats, "empty tank statistics"
    assert (work / "fig" / "tank_panel.png").stat().st_size > 10_000


def test_shipped_scenario_copies_validate_and_run_outside_the_checkout(installed):
    bin_dir, work = installed
    listing = _run(bin_dir / "uhrisim", "scenarios", cwd=work)
    assert "track_and_trail" in listing and "sonar_tank" in listing
    _run(bin_dir / "uhrisim", "scenarios", "copy", "track_and_trail", "mine", cwd=work)
    assert sorted(p.name for p in (work / "mine").iterdir()) == [
        "track_and_trail.yaml", "videoray_trail.bhv"]
    checked = _run(bin_dir / "uhrisim", "validate", "mine/track_and_trail.yaml", cwd=work)
    assert "OK" in checked
