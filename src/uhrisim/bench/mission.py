"""Real-time factor of the paper's track-and-trail mission, with and without the sonar.

Targets on one core (issue 27; issue 5 asked 10x / 100x): >= 40x real time with the
P900-45 at 15 Hz, >= 500x without sonar. The loop runs without hooks (no recording),
after a 2 s warm-up.

Both rates are printed: simulated seconds per wall second and per CPU second of this
process. On a shared machine the wall rate drops with the load; the CPU rate is what one
core delivers, and the targets are judged on it.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Hook, Simulation

TARGETS = {"with_sonar": 40.0, "without_sonar": 500.0}
#: Simulated seconds run before the timed ones: caches, first pings, bridge connections.
WARM_UP_S = 2.0


def mission_rates(
    seconds: float, sonar: bool, hooks: Sequence[Hook] = ()
) -> tuple[float, float]:
    """Simulated seconds per wall second and per CPU second (this process, all threads) of
    the mission, after a warm-up of :data:`WARM_UP_S`."""
    with Simulation(load_scenario(shipped_scenario()), raycast_sensors=sonar, hooks=hooks) as sim:
        sim.run(WARM_UP_S)
        wall, cpu = time.perf_counter(), time.process_time()
        sim.run(seconds)
        return seconds / (time.perf_counter() - wall), seconds / (time.process_time() - cpu)


def _rtf(sonar: bool, seconds: float) -> dict[str, Any]:
    wall_rtf, cpu_rtf = mission_rates(seconds, sonar)
    key = "with_sonar" if sonar else "without_sonar"
    return {"simulated_s": seconds, "wall_s": seconds / wall_rtf, "cpu_s": seconds / cpu_rtf,
            "real_time_factor": wall_rtf, "real_time_factor_cpu": cpu_rtf,
            "target": TARGETS[key], "meets_target": cpu_rtf >= TARGETS[key]}


def run(quick: bool = False) -> dict[str, Any]:
    seconds = 5.0 if quick else 60.0
    return {"scenario": shipped_scenario().name, "physics_rate_hz": 60,
            "with_sonar": _rtf(True, seconds), "without_sonar": _rtf(False, seconds)}
