"""Overhead of the live bridges on the track-and-trail mission's real-time factor.

The mission runs free (no pacing, no sonar, no recording) for the same simulated time
three ways: no bridge; with the ROS 2 bridge publishing odometry, helm and scene on a
private loopback domain; with the MOOS bridge posting NAV_*/NODE_REPORT at 10 Hz to a
test MOOSDB on 127.0.0.1. Target (issue 6): each bridge costs under 20 % of the RTF.

Overhead = 1 - RTF(with bridge) / RTF(without). Both rates are measured, as in the
mission benchmark: simulated seconds per wall second and per CPU second of the
simulation process (all its threads: the bridges' I/O and DDS threads included; the
test MOOSDB, a separate process standing in for a real MOOSDB, is not). The three runs
are repeated in turn (``repeats``) and the medians compared, since one shared core
makes single runs noisy; the target is judged on the CPU rates, like the mission's.
"""

from __future__ import annotations

import os
import random
import statistics
import tempfile
from collections.abc import Callable
from typing import Any

from uhrisim.bench.mission import mission_rates
from uhrisim.sim.hooks import Hook

TARGET_OVERHEAD = 0.20

Rates = tuple[float, float]  # simulated seconds per wall second, per CPU second


def _rates(hooks: list[Hook], seconds: float) -> Rates:
    return mission_rates(seconds, sonar=False, hooks=hooks)


def _without(seconds: float) -> Rates:
    return _rates([], seconds)


def _with_ros2(seconds: float) -> Rates | str:
    try:
        from uhrisim.bridges.ros2 import Ros2BridgeHook
    except ImportError as error:  # the ros2 extra is optional
        return f"skipped: {error}"
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="uhrisim-roslog-"))
    domain = random.SystemRandom().randint(1, 101)
    return _rates([Ros2BridgeHook(domain_id=domain, node_name="uhrisim_bench")], seconds)


def _with_moos(seconds: float) -> Rates:
    from uhrisim.bridges.moos.hook import MoosAgentLink, MoosBridgeHook
    from uhrisim.bridges.moos.testdb import spawn

    with spawn(community="bench") as db:
        links = [MoosAgentLink("videoray", port=db.port), MoosAgentLink("diver", port=db.port)]
        return _rates([MoosBridgeHook(links, time_source="sim", strict=True)], seconds)


def run(quick: bool = False, repeats: int | None = None) -> dict[str, Any]:
    seconds = 5.0 if quick else 60.0
    repeats = (1 if quick else 7) if repeats is None else max(1, int(repeats))
    runners: dict[str, Callable[[float], Rates | str]] = {
        "without": _without, "ros2": _with_ros2, "moos": _with_moos}
    samples: dict[str, list[Rates]] = {name: [] for name in runners}
    skipped: dict[str, str] = {}
    for _ in range(repeats):
        for name, runner in runners.items():
            if name in skipped:
                continue
            rates = runner(seconds)
            if isinstance(rates, str):
                skipped[name] = rates
            else:
                samples[name].append(rates)

    def median(name: str, k: int) -> float:
        return statistics.median(r[k] for r in samples[name])

    base_wall, base_cpu = median("without", 0), median("without", 1)
    result: dict[str, Any] = {
        "simulated_s": seconds, "repeats": repeats,
        "rtf_without_bridge": base_wall, "rtf_cpu_without_bridge": base_cpu,
        "cpu_ms_per_simulated_s_without_bridge": 1e3 / base_cpu,
    }
    for name in ("ros2", "moos"):
        if name in skipped:
            result[name] = {"status": skipped[name]}
            continue
        wall, cpu = median(name, 0), median(name, 1)
        overhead_cpu = 1.0 - cpu / base_cpu
        result[name] = {
            "rtf": wall, "overhead": 1.0 - wall / base_wall,
            "rtf_cpu": cpu, "overhead_cpu": overhead_cpu,
            "cpu_ms_per_simulated_s": 1e3 / cpu - 1e3 / base_cpu,
            "overhead_cpu_runs": [1.0 - r[1] / base_cpu for r in samples[name]],
            "target": TARGET_OVERHEAD, "meets_target": overhead_cpu < TARGET_OVERHEAD,
        }
    return result
