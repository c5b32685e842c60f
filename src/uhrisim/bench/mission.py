"""Real-time factor of the paper's track-and-trail mission, with and without the sonar.

Targets on one core (issue 27; issue 5 asked 10x / 100x): >= 40x real time with the
P900-45 at 15 Hz, >= 500x without sonar. The loop runs without hooks (no recording),
after a 2 s warm-up and a discarded twin of the timed run that make every compiled kernel
ready (:func:`warm_up`): with a cold kernel cache (after any change to the package) the
kernels compile at their first use (the sonar's at the first ping that sees the diver,
the trail's once he is acquired, the ray caster's mesh pass later), which took most of a
short timed window (``--quick`` showed 1.3-1.5x with the sonar, 15-18x once warm) and
still a third of a long one (a fresh clone's first run read 27.6x, then 43-53x).

Both rates are printed: simulated seconds per wall second and per CPU second of this
process. On a shared machine the wall rate drops with the load; the CPU rate is what one
core delivers, and the targets are judged on it.

Where the CPU time goes is printed beside each rate: the helms' decisions and the sonar's
pings (each timed as it runs) and the rest of the loop per tick, split into its stages
(``stages_us_per_tick``: physics, controllers, truth contacts, NAV_* postings, each hook,
``quiet_ticks``, the stretches of ticks where only the agents move and their controllers
run, done in one compiled call each (:mod:`uhrisim.sim.quiet`; their physics and control
are not in the first two), and ``other``, the loop's own bookkeeping and what no stopwatch
covers). The stopwatches
cost about 0.3 us a call, a few percent of the rates. ``recorded`` runs the mission as
``uhrisim run`` does, with the recording (``recording:`` of the scenario) and the trail
metrics; it has no target.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from uhrisim.bench import Stopwatch
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Hook, Simulation

TARGETS = {"with_sonar": 40.0, "without_sonar": 500.0}
#: Simulated seconds run before the timed ones: caches, first pings, bridge connections.
WARM_UP_S = 2.0


def warm_up(sim: Simulation, seconds: float) -> None:
    """Make ready what the timed ``seconds`` of ``sim`` will use, then run
    :data:`WARM_UP_S` of it. A discarded twin of the mission (the same scenario, seed and
    sensors, no hooks) runs ``WARM_UP_S + seconds`` first: with a cold kernel cache (after
    any change to the package) each compiled kernel compiles at its first use, inside the
    timed stretch if the twin has not used it — the sonar's ray caster and echo
    accumulation at the first ping that sees the diver (~4 s in), the trail's coupled
    objective once he is acquired (~13 s), the ray caster's mesh pass when the fan first
    reaches a mesh (~21 s)."""
    with Simulation(sim.source, seed=sim.seed, raycast_sensors=sim.raycast_sensors) as twin:
        twin.run(WARM_UP_S + seconds)
    sim.run(WARM_UP_S)


def mission_rates(
    seconds: float, sonar: bool, hooks: Sequence[Hook] = ()
) -> tuple[float, float]:
    """Simulated seconds per wall second and per CPU second (this process, all threads) of
    the mission, after a warm-up of :data:`WARM_UP_S`."""
    with Simulation(load_scenario(shipped_scenario()), raycast_sensors=sonar, hooks=hooks) as sim:
        warm_up(sim, seconds)
        wall, cpu = time.perf_counter(), time.process_time()
        sim.run(seconds)
        return seconds / (time.perf_counter() - wall), seconds / (time.process_time() - cpu)


def _split_rates(seconds: float, sonar: bool, recorded: bool) -> dict[str, Any]:
    """The mission's rates after the warm-up, with the CPU seconds of its helm decisions
    and sonar pings (timed by stopwatches on the drivers and sonars, installed after the
    warm-up) and of the rest per tick; ``recorded``: with ``uhrisim run``'s recording and
    trail metrics."""
    from uhrisim.app.metrics import TrailMetrics  # only for the recorded case
    from uhrisim.record.hook import McapRecordingHook

    source = load_scenario(shipped_scenario())
    scenario = source.scenario
    with tempfile.TemporaryDirectory(prefix="uhrisim-bench-mission-") as folder:
        hooks: list[Hook] = []
        if recorded:
            hooks = [McapRecordingHook.for_scenario(scenario, Path(folder) / "recording.mcap"),
                     TrailMetrics(scenario.metrics)]
        with Simulation(source, raycast_sensors=sonar, hooks=hooks) as sim:
            warm_up(sim, seconds)
            helm = [_time(agent.driver, "tick") for agent in sim.agents.values()
                    if agent.driver is not None]
            pings = [_time(slot.sonar, "ping") for agent in sim.agents.values()
                     for slot in agent.sonars]
            stages = {"physics": _time(sim, "_advance"), "control": _time(sim, "_control"),
                      "contacts": _time(sim.contacts, "step"),
                      "navigation": _time(sim, "_post_nav")}
            if sim._quiet is not None and not hooks:  # quiet ticks in one call (sim/quiet.py)
                stages["quiet_ticks"] = _time(sim._quiet, "run")
            stages.update({f"hook_{type(hook).__name__}": _time(hook, "on_tick")
                           for hook in hooks})
            ticks = sim.tick
            wall, cpu = time.perf_counter(), time.process_time()
            sim.run(seconds)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            ticks = sim.tick - ticks
    helm_s, ping_s = sum(w.seconds for w in helm), sum(w.seconds for w in pings)
    decisions, n_pings = sum(w.calls for w in helm), sum(w.calls for w in pings)
    rest_s = cpu - helm_s - ping_s
    split = {name: 1e6 * w.seconds / ticks for name, w in stages.items()}
    split["other"] = 1e6 * (rest_s - sum(w.seconds for w in stages.values())) / ticks
    return {
        "simulated_s": seconds, "wall_s": wall, "cpu_s": cpu,
        "real_time_factor": seconds / wall, "real_time_factor_cpu": seconds / cpu,
        "helm_cpu_share": helm_s / cpu,
        "helm_ms_per_decision": 1e3 * helm_s / decisions if decisions else None,
        "sonar_cpu_share": ping_s / cpu,
        "sonar_ms_per_ping": 1e3 * ping_s / n_pings if n_pings else None,
        "rest_us_per_tick": 1e6 * rest_s / ticks,
        "stages_us_per_tick": {name: round(us, 2) for name, us in split.items()},
    }


def _time(owner: Any, method: str) -> Stopwatch:
    """Replace ``owner``'s ``method`` by a :class:`Stopwatch` of it; returns the watch."""
    watch = Stopwatch(getattr(owner, method))
    setattr(owner, method, watch)
    return watch


def _rtf(sonar: bool, seconds: float) -> dict[str, Any]:
    key = "with_sonar" if sonar else "without_sonar"
    rates = _split_rates(seconds, sonar, recorded=False)
    return {**rates, "target": TARGETS[key],
            "meets_target": rates["real_time_factor_cpu"] >= TARGETS[key],
            "recorded": _split_rates(seconds, sonar, recorded=True)}


def run(quick: bool = False) -> dict[str, Any]:
    seconds = 5.0 if quick else 60.0
    return {"scenario": shipped_scenario().name, "physics_rate_hz": 60,
            "with_sonar": _rtf(True, seconds), "without_sonar": _rtf(False, seconds)}
