"""Real-time factor of the salvage mission (``scenarios/salvage_team.yaml``: a scuba diver
working through its orders, the VideoRay carrying and handing over a light), without
sensors and with the VideoRay's sonar and camera.

Targets on one core (issue 25): >= 100x real time without sensors, >= 5x with the
P900-45 at 15 Hz and a 320x240 camera at 10 Hz (those of ``scenarios/camera_trail.yaml``,
added to the VideoRay here). The loop runs without hooks (no recording). Without sensors
the whole mission is timed (its phases cost differently: swimming, working at the
flange, waiting for the lift); with sensors a stretch of it, from ``SENSOR_START_S``
(the diver at work, the VideoRay on station). Also reported: the weighted-boots variant
(``scenarios/salvage_team_boots.yaml``), the whole mission without sensors, and with
them from ``BOOTS_START_S``, when the sensors look through the silt of some 20
footfalls.

Rates are per wall second and per CPU second of this process; the targets are judged on
the CPU rate (a shared machine slows the wall rate). One core includes numpy's BLAS: the
benchmark runs with ``OPENBLAS_NUM_THREADS=1`` (:mod:`uhrisim.bench.camera` says why),
in a child process of its own when it was not set so before numpy was loaded.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Any

import yaml

from uhrisim.scenario.load import ScenarioFile, validate_data
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Simulation

TARGETS = {"without_sensors": 100.0, "with_sensors": 5.0, "boots_without_sensors": 100.0,
           "boots_with_sensors": 5.0}
SCENARIO = "salvage_team.yaml"
BOOTS = "salvage_team_boots.yaml"
#: the mission's orders are done by 238 s
MISSION_S = 238.0
#: where the timed stretch with sensors starts (s): the diver at the flange
SENSOR_START_S = 40.0
#: where the boots variant's timed stretch starts (s): silt stirred, the diver at work
BOOTS_START_S = 150.0

#: the sensors of scenarios/camera_trail.yaml, on the VideoRay
SENSORS = [
    {"type": "sonar", "preset": "P900-45", "rate_hz": 15, "range_min_m": 0.5,
     "range_max_m": 10, "rays_per_beam": 32, "mount_position_frd": [0.2, 0.0, 0.0],
     "tilt_deg": 5},
    {"type": "camera", "preset": "videoray-pro4", "rate_hz": 10, "width": 320,
     "height": 240, "water": {"jerlov": "1C"}, "lamps_on": True, "tilt_deg": 5},
]


def salvage(sensors: bool, scenario: str = SCENARIO) -> ScenarioFile:
    """A shipped salvage scenario, with :data:`SENSORS` on the VideoRay if asked."""
    path = shipped_scenario(scenario)
    data = yaml.safe_load(path.read_text())
    if sensors:
        rov = next(a for a in data["agents"] if a["name"] == "rov1")
        rov["sensors"] = SENSORS
    return ScenarioFile(validate_data(data, str(path)), path)


def team_rates(sensors: bool, start_s: float, seconds: float, scenario: str = SCENARIO
               ) -> tuple[float, float]:
    """Simulated seconds per wall second and per CPU second of ``seconds`` of the mission
    from ``start_s`` (the first ``start_s`` run untimed, at least 1 s: caches, first
    frames)."""
    with Simulation(salvage(sensors, scenario), raycast_sensors=sensors) as sim:
        sim.run(max(start_s, 1.0))
        wall, cpu = time.perf_counter(), time.process_time()
        sim.run(seconds)
        return seconds / (time.perf_counter() - wall), seconds / (time.process_time() - cpu)


def _rtf(key: str, sensors: bool, start_s: float, seconds: float,
         scenario: str = SCENARIO) -> dict[str, Any]:
    wall_rtf, cpu_rtf = team_rates(sensors, start_s, seconds, scenario)
    return {"scenario": scenario, "from_s": max(start_s, 1.0), "simulated_s": seconds,
            "wall_s": seconds / wall_rtf, "cpu_s": seconds / cpu_rtf, "real_time_factor": wall_rtf,
            "real_time_factor_cpu": cpu_rtf, "target": TARGETS[key],
            "meets_target": cpu_rtf >= TARGETS[key]}


def run(quick: bool = False) -> dict[str, Any]:
    if os.environ.get("OPENBLAS_NUM_THREADS") != "1":  # (read when numpy was loaded)
        child = subprocess.run([sys.executable, "-m", __name__, *(["--quick"] if quick else [])],
                               env=os.environ | {"OPENBLAS_NUM_THREADS": "1"}, check=True,
                               stdout=subprocess.PIPE, text=True)
        return json.loads(child.stdout)
    sensed_s = 2.0 if quick else 10.0
    return {"physics_rate_hz": 60, "openblas_num_threads": "1",
            "without_sensors": _rtf("without_sensors", False, 1.0,
                                    20.0 if quick else MISSION_S - 1.0),
            "with_sensors": _rtf("with_sensors", True, SENSOR_START_S, sensed_s),
            "boots_without_sensors": _rtf("boots_without_sensors", False, 1.0,
                                          20.0 if quick else MISSION_S - 1.0, BOOTS),
            "boots_with_sensors": _rtf("boots_with_sensors", True, BOOTS_START_S, sensed_s,
                                       BOOTS)}


if __name__ == "__main__":  # run(): in a process with one BLAS thread
    sys.stdout.write(json.dumps(run(quick="--quick" in sys.argv[1:])) + "\n")
