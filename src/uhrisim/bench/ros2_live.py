"""Benchmark of a live ``uhrisim run --ros2`` as a ROS user meets it (issue 30): the rate
at which a **best-effort** subscriber in another process receives every topic, and how
long the run takes to exit after SIGINT or SIGTERM.

``uhrisim bench ros2_live [--json]``: scenarios/ros2_external_helm.yaml (the VideoRay,
15 Hz sonar, 10 Hz odometry and /clock; paced at real time) in its own process, as
``uhrisim run ... --ros2``; a plain-rclpy listener (:mod:`uhrisim.bench._ros2_listener`)
subscribes best effort to every topic the bridge publishes for the ROV and the world.
The rates are counted over ``RATE_WINDOW_S`` wall seconds of the first run, and every
message it received is compared with what the run published (metrics.json: only this
listener subscribes, so every message written was written for it). Each run is
then stopped by a signal (SIGINT and SIGTERM in turn), timed from the signal to the
process's exit; a run still alive ``HANG_S`` after its signal gets SIGABRT, on which
Python's faulthandler (``PYTHONFAULTHANDLER=1``) prints every thread's stack: the
benchmark reports it (the stop's target is 2 s, the escalation of ``ros2 launch`` 5 s).
"""

from __future__ import annotations

import json
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

#: Wall seconds over which the rates are counted.
RATE_WINDOW_S = 10.0
#: A stop that takes longer than this (s) is a hang: its stacks are dumped.
HANG_S = 20.0
#: The rates the scenario publishes at (Hz).
EXPECTED_HZ = {"/clock": 10.0, "/tf": 10.0, "/videoray/odom": 10.0, "/videoray/pose": 10.0,
               **{f"/videoray/sonar/{k}": 15.0 for k in ("polar", "fan", "points",
                                                           "image", "pose")}}


def _topics() -> list[tuple[str, str, str]]:
    """``(topic, type, "sensor")``: best-effort subscriptions to every measured topic."""
    from uhrisim.ros.topics import GLOBAL_TOPICS, agent_topics

    types = {f"/{key}": kind for key, (kind, _qos) in GLOBAL_TOPICS.items()}
    types |= {f"/videoray/{key}": kind for key, kind, _qos in agent_topics(("sonar",))}
    return [(topic, types[topic], "sensor") for topic in EXPECTED_HZ]


def _one_run(scenario: Path, domain: int, signum: int, rates: bool,
             work: Path) -> dict[str, Any]:
    from uhrisim.bench._ros2_listener import Listener

    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "PYTHONFAULTHANDLER": "1"}
    err_path = work / f"run-{domain}-{signum}.stderr"
    with err_path.open("w") as err:
        run = subprocess.Popen([sys.executable, "-m", "uhrisim", "run", str(scenario),
                                "--ros2", "-q", "--out", str(work / f"out-{domain}")],
                               env=env, stdout=subprocess.DEVNULL, stderr=err)
        out: dict[str, Any] = {}
        try:
            with Listener(_topics(), domain) as listener:
                deadline = time.monotonic() + 120.0
                while listener.counts()["/clock"] == 0:  # discovered and running
                    if run.poll() is not None or time.monotonic() > deadline:
                        raise RuntimeError(f"the run did not start: {err_path}")
                    time.sleep(0.2)
                time.sleep(1.0)
                if rates:
                    first, t0 = listener.counts(), time.monotonic()
                    time.sleep(RATE_WINDOW_S)
                    last, t1 = listener.counts(), time.monotonic()
                    out["rates_hz"] = {topic: round((last[topic] - first[topic]) / (t1 - t0), 2)
                                       for topic in EXPECTED_HZ}
                out |= _stop(run, signum, err_path)
                if rates:  # every message the run wrote (only this listener subscribed)
                    received = listener.counts()
                    metrics = json.loads((work / f"out-{domain}" / "metrics.json").read_text())
                    published = metrics["ros2"]["published"]
                    out["delivered"] = {topic: f"{received[topic]}/{published.get(topic, 0)}"
                                        for topic in EXPECTED_HZ}
                    out["real_time_factor"] = metrics["real_time_factor"]
            out["bag_complete"] = (work / f"out-{domain}" / "metadata.yaml").exists()
        finally:
            if run.poll() is None:
                run.kill()
                run.wait()
    return out


def _stop(run: subprocess.Popen, signum: int, err_path: Path) -> dict[str, Any]:
    """Send ``signum`` to ``run`` and time its exit (its stacks dumped after HANG_S)."""
    out: dict[str, Any] = {}
    sent = time.monotonic()
    run.send_signal(signum)
    try:
        run.wait(timeout=HANG_S)
    except subprocess.TimeoutExpired:
        run.send_signal(signal.SIGABRT)  # faulthandler: every thread's stack
        run.wait(timeout=30.0)
        out["hang_stacks"] = err_path.read_text()[-6000:]
    out["stop_s"] = round(time.monotonic() - sent, 3)
    out["exit_status"] = run.returncode
    return out


def run(quick: bool = False, stops: int | None = None) -> dict[str, Any]:
    """Measure; see the module docstring. ``stops``: runs stopped (default 10; quick 2)."""
    try:
        import rclpy  # noqa: F401
    except ImportError as error:
        return {"skipped": str(error)}
    from uhrisim.bridges.ros2.spec import apply_env_defaults
    from uhrisim.scenario.shipped import shipped_scenario

    apply_env_defaults()
    os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="uhrisim-roslog-"))
    scenario = shipped_scenario("ros2_external_helm.yaml")
    n = stops if stops is not None else (2 if quick else 10)
    work = Path(tempfile.mkdtemp(prefix="uhrisim-bench-ros2-live-"))
    domains = random.SystemRandom().sample(range(1, 101), n)
    runs = [_one_run(scenario, domains[k], (signal.SIGINT, signal.SIGTERM)[k % 2], k == 0,
                     work) for k in range(n)]
    result: dict[str, Any] = {"scenario": scenario.name, "expected_hz": EXPECTED_HZ,
                              "best_effort_rates_hz": runs[0].get("rates_hz"),
                              "received_of_published": runs[0].get("delivered"),
                              "real_time_factor": runs[0].get("real_time_factor")}
    for k, name in enumerate(("SIGINT", "SIGTERM")):
        mine = runs[k::2]
        times = [r["stop_s"] for r in mine]
        result[name] = {"runs": len(mine), "stop_s_median": statistics.median(times),
                        "stop_s_max": max(times), "over_2_s": sum(t > 2.0 for t in times),
                        "hangs": sum("hang_stacks" in r for r in mine),
                        "exit_status": sorted({r["exit_status"] for r in mine}),
                        "bags_complete": sum(r["bag_complete"] for r in mine)}
    hangs = [r["hang_stacks"] for r in runs if "hang_stacks" in r]
    if hangs:
        result["first_hang_stacks"] = hangs[0]
    return result
