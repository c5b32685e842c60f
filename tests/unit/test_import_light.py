"""Importing the command line and the runner stays light: every ``uhrisim`` process (each
``uhrisim run`` of the tests, each batch worker) pays for it, and one that reads a scenario
and stops at an error should not load the world's meshes (trimesh, with scipy), OpenCV or
the recording's mcap. They are imported where a run is built (docs/layout.md)."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("trimesh", "scipy.spatial", "cv2", "mcap", "matplotlib")


def test_the_cli_runner_and_scenario_loader_import_no_heavy_library():
    code = ("import json, sys\n"
            "import uhrisim.app.runner, uhrisim.cli, uhrisim.scenario.load\n"
            f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert json.loads(done.stdout) == [], done.stdout


def test_the_simulation_loads_opencv_only_for_sonar_contacts():
    # perception (OpenCV) is imported where an agent takes its contacts from its sonar
    # (sim/sonar_contacts.py); a run without a sonar never needs it
    code = ("import json, sys\n"
            "import uhrisim.sim.simulation\n"
            "print(json.dumps('cv2' in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert json.loads(done.stdout) is False
