"""Overhead of the live bridges on the track-and-trail mission's real-time factor.

The mission runs free (no pacing, no sonar, no recording) for the same simulated time
three ways: no bridge; with the ROS 2 bridge publishing odometry, helm and scene on a
private loopback domain; with the MOOS bridge posting NAV_*/NODE_REPORT at 10 Hz to a
test MOOSDB on 127.0.0.1. Target (issue 6): each bridge costs under 20 % of the RTF.
"""

from __future__ import annotations

import os
import random
import tempfile
from collections.abc import Callable
from typing import Any

from uhrisim.bench.mission import mission_rtf
from uhrisim.sim.hooks import Hook

TARGET_OVERHEAD = 0.20


def _rtf(hooks: list[Hook], seconds: float) -> float:
    return mission_rtf(seconds, sonar=False, hooks=hooks)


def _with_ros2(seconds: float) -> float | str:
    try:
        from uhrisim.bridges.ros2 import Ros2BridgeHook
    except ImportError as error:  # the ros2 extra is optional
        return f"skipped: {error}"
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="uhrisim-roslog-"))
    domain = random.SystemRandom().randint(1, 101)
    return _rtf([Ros2BridgeHook(domain_id=domain, node_name="uhrisim_bench")], seconds)


def _with_moos(seconds: float) -> float:
    from uhrisim.bridges.moos.hook import MoosAgentLink, MoosBridgeHook
    from uhrisim.bridges.moos.testdb import spawn

    with spawn(community="bench") as db:
        links = [MoosAgentLink("videoray", port=db.port), MoosAgentLink("diver", port=db.port)]
        return _rtf([MoosBridgeHook(links, time_source="sim", strict=True)], seconds)


def run(quick: bool = False) -> dict[str, Any]:
    seconds = 5.0 if quick else 60.0
    base = _rtf([], seconds)
    result: dict[str, Any] = {"simulated_s": seconds, "rtf_without_bridge": base}
    runners: dict[str, Callable[[float], float | str]] = {"ros2": _with_ros2,
                                                          "moos": _with_moos}
    for name, runner in runners.items():
        rtf = runner(seconds)
        if isinstance(rtf, str):
            result[name] = {"status": rtf}
            continue
        overhead = 1.0 - rtf / base
        result[name] = {"rtf": rtf, "overhead": overhead, "target": TARGET_OVERHEAD,
                        "meets_target": overhead < TARGET_OVERHEAD}
    return result
