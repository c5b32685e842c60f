"""Sonar perception speed, and the real-time factor of the sonar-trail mission.

Targets on one core (issue 15): perception (detect → blobs → track → classify) ≤ 1.5 ms
per P900-45 ping; the sonar-only trail mission (``track_and_trail_sonar.yaml``) ≥ 10×
real time.

Perception is timed on pings recorded from the cluttered mission (the ROV trailing the
diver among pilings and a second swimmer: the busiest images the project ships), replayed
in order through a fresh :class:`~uhrisim.perception.pipeline.SonarPerception` each pass.
The mission runs without hooks (no recording, no metrics) after a warm-up, once as the
scenario is written (label images on, for the metrics) and once with label images off
(what a user who does not score the detections pays).

Rates are per wall-clock second and per CPU second of this process (OpenCV on one
thread); the targets are judged on CPU time (the wall rate drops with the machine's
load).
"""

from __future__ import annotations

import time
from typing import Any

import cv2

from uhrisim.perception.pipeline import SonarPerception
from uhrisim.scenario.load import ScenarioFile, load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Simulation

TARGET_MS_PER_PING = 1.5
TARGET_RTF = 10.0
WARM_UP_S = 2.0


def recorded_pings(seconds: float) -> list[Any]:
    """Pings of the cluttered sonar-trail mission from t = 30 s (the trail under way)."""
    source = load_scenario(shipped_scenario("track_and_trail_sonar_clutter.yaml"))
    pings = []
    with Simulation(source) as sim:
        sim.run(30.0)
        while sim.t < 30.0 + seconds:
            frame = sim.step()
            pings.extend(frame.pings.values())
    return pings


def perception_times(pings: list[Any], passes: int) -> tuple[float, float]:
    """(wall ms, CPU ms) per ping: best pass of ``passes``."""
    best_wall = best_cpu = float("inf")
    for _ in range(passes):
        perception = SonarPerception()
        w0, c0 = time.perf_counter(), time.process_time()
        for ping in pings:
            perception.process(ping)
        best_wall = min(best_wall, (time.perf_counter() - w0) * 1e3 / len(pings))
        best_cpu = min(best_cpu, (time.process_time() - c0) * 1e3 / len(pings))
    return best_wall, best_cpu


def mission_rtf(source: ScenarioFile, seconds: float) -> dict[str, float]:
    with Simulation(source) as sim:
        sim.run(WARM_UP_S)
        w0, c0 = time.perf_counter(), time.process_time()
        sim.run(seconds)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return {"simulated_s": seconds, "real_time_factor": seconds / wall,
            "real_time_factor_cpu": seconds / cpu}


def without_labels(source: ScenarioFile) -> ScenarioFile:
    """``source`` with every sonar's label images off."""
    scenario = source.scenario
    agents = tuple(a.model_copy(update={"sensors": tuple(
        s.model_copy(update={"labels": False}) for s in a.sensors)}) for a in scenario.agents)
    return ScenarioFile(scenario.model_copy(update={"agents": agents}), source.path,
                        source.lines)


def run(quick: bool = False) -> dict[str, Any]:
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # one core, as the targets state
    try:
        pings = recorded_pings(4.0 if quick else 20.0)
        wall_ms, cpu_ms = perception_times(pings, 1 if quick else 3)
        seconds = 5.0 if quick else 60.0
        source = load_scenario(shipped_scenario("track_and_trail_sonar.yaml"))
        labelled = mission_rtf(source, seconds)
        plain = mission_rtf(without_labels(source), seconds)
    finally:
        cv2.setNumThreads(threads)
    return {
        "perception": {"pings": len(pings), "shape": list(pings[0].polar.shape),
                       "ms_per_ping": wall_ms, "ms_per_ping_cpu": cpu_ms,
                       "target_ms": TARGET_MS_PER_PING,
                       "meets_target": cpu_ms <= TARGET_MS_PER_PING},
        "mission_labels_on": {**labelled, "target": TARGET_RTF,
                              "meets_target": labelled["real_time_factor_cpu"] >= TARGET_RTF},
        "mission_labels_off": {**plain, "target": TARGET_RTF,
                               "meets_target": plain["real_time_factor_cpu"] >= TARGET_RTF},
    }
