"""Overhead of the live bridges on the track-and-trail mission's real-time factor.

The mission runs free (no pacing, no recording) for the same simulated time with and
without a bridge, and the overhead is ``1 - RTF(with bridge) / RTF(without)``
(target, issue 6: under 20 %). Cases:

* with the P900-45 sonar at 15 Hz (the mission as flown, as ``uhrisim demo`` runs it):
  the ROS 2 bridge with nobody subscribed (``ros2``: unread topics are not written, and
  what they would carry is not computed), with a listener process on the topics an
  outside planner or controller reads (``ros2_navigation_listener``: odometry, poses,
  ``/tf`` and ``/tf_static``, the sonar's pose, the helm's desired values and mode,
  ``/clock``), and with a listener on every topic, the polar and fan images, the
  ProjectedSonarImage, the hits, the helm decisions and community postings included
  (``ros2_listener``: each ping's fan image is formed and ~0.8 MB of pixels a ping are
  handed to DDS); the MOOS bridge posting NAV_* and
  NODE_REPORT of both agents at 10 Hz to a test MOOSDB on 127.0.0.1 (``moos``);
* without the sonar, a stress case: the loop then costs only a few ms of CPU per
  simulated second (a few hundred times real time), so every message counts. The same
  cases but the navigation listener (without a sonar it would read what
  ``ros2_listener`` reads).

Both rates are measured, as in the mission benchmark: simulated seconds per wall second
and per CPU second of the simulation process (all its threads: the bridges' I/O and
DDS threads included; the listener and the test MOOSDB, separate processes standing in
for the user's nodes, are not). The runs of a case are repeated in turn and the medians
compared, since the shared machine makes single runs noisy; the target is judged on the
CPU rates, like the mission's.
"""

from __future__ import annotations

import os
import random
import statistics
import tempfile
import time
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any, Literal

from uhrisim.bench.mission import WARM_UP_S, mission_rates
from uhrisim.sim.simulation import BaseHook, Hook

TARGET_OVERHEAD = 0.20
#: Agents of the shipped mission, and the one carrying the sonar.
AGENTS = ("videoray", "diver")
SONAR_AGENT = "videoray"

Rates = tuple[float, float]  # simulated seconds per wall second, per CPU second
#: A case: makes the hooks of one run inside an ExitStack (processes, bridges), or says
#: why it cannot run.
Case = Callable[[ExitStack, bool], list[Hook] | str]


def _ros2_environment() -> str | None:
    """Loopback discovery and a log folder for ROS 2; why not, if the extra is missing."""
    try:
        import rclpy  # noqa: F401
    except ImportError as error:  # the ros2 extra is optional
        return f"skipped: {error}"
    from uhrisim.bridges.ros2.spec import apply_env_defaults

    apply_env_defaults()  # now, not at bridge start: the listener process inherits it
    os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="uhrisim-roslog-"))
    return None


class _AwaitListener(BaseHook):
    """Placed after the ROS 2 hook: at start, waits until the listener is matched on
    every topic, so the measured run publishes to it from its first tick."""

    def __init__(self, ros_hook: Any, topics: list[str]) -> None:
        self._ros_hook, self._topics = ros_hook, topics

    def on_start(self, sim: Any) -> None:
        del sim
        if not self._ros_hook.bridge.wait_for_subscribers(self._topics, timeout_s=30.0):
            raise RuntimeError("bench: the ROS 2 listener was not discovered within 30 s")
        time.sleep(0.3)  # the graph shows the reader a little before the writer matches it


#: Topics of an agent (:func:`uhrisim.ros.topics.agent_topics`) a navigation listener leaves
#: out: the sonar's bulk products and the helm's audit trail (every behavior's share in
#: each decision, every community posting).
NOT_NAVIGATION_KEYS = frozenset({"sonar/polar", "sonar/fan", "sonar/points", "sonar/image",
                                 "helm/decision", "vars"})


class _Ros2Case:
    """The ROS 2 bridge, alone (``listener=None``) or with a listener process on every
    topic it publishes (``"every"``) or on what an outside planner reads (``"navigation"``:
    odometry, poses, ``/tf``, the sonar's pose, the helm's desired values and mode,
    ``/clock``);
    notes how many messages the listener received in each run (warm-up included)."""

    def __init__(self, listener: Literal["every", "navigation"] | None) -> None:
        self.listener = listener
        self.received: list[int] = []

    def __call__(self, stack: ExitStack, sonar: bool) -> list[Hook] | str:
        why_not = _ros2_environment()
        if why_not is not None:
            return why_not
        from uhrisim.bridges.ros2 import Ros2BridgeHook
        from uhrisim.bridges.ros2.bridge import message_class
        from uhrisim.bridges.ros2.topics import qos_for
        from uhrisim.ros.topics import GLOBAL_TOPICS, agent_topics

        from ._ros2_listener import Listener, qos_label

        domain = random.SystemRandom().randint(1, 101)
        hook = Ros2BridgeHook(domain_id=domain, node_name="uhrisim_bench", publish_scene=False)
        if self.listener is None:
            return [hook]
        wanted = [(key, *GLOBAL_TOPICS[key]) for key in ("clock", "tf", "tf_static")]
        for name in AGENTS:
            sonars = ("sonar",) if sonar and name == SONAR_AGENT else ()
            wanted += [(f"{name}/{key}", kind, qos) for key, kind, qos in agent_topics(sonars)
                       if self.listener == "every" or key not in NOT_NAVIGATION_KEYS]
        topics = []
        for topic, kind, qos in wanted:
            try:  # the types whose packages are built (uhrisim.bridges.ros2.interfaces)
                message_class(kind)
            except ImportError:
                continue
            topics.append((f"/{topic}", kind, qos_label(qos_for(qos))))
        listener = stack.enter_context(Listener(topics, domain))
        # closed after the run (last in, first out): count what arrived first
        stack.callback(lambda: self.received.append(sum(listener.counts().values())))
        return [hook, _AwaitListener(hook, [t for t, _, _ in topics])]


def _moos(stack: ExitStack, sonar: bool) -> list[Hook]:
    del sonar
    from uhrisim.bridges.moos.hook import MoosAgentLink, MoosBridgeHook
    from uhrisim.bridges.moos.testdb import spawn

    db = stack.enter_context(spawn(community="bench"))
    links = [MoosAgentLink(name, port=db.port) for name in AGENTS]
    return [MoosBridgeHook(links, time_source="sim", strict=True)]


def _without(stack: ExitStack, sonar: bool) -> list[Hook]:
    del stack, sonar
    return []


def _compare(cases: dict[str, Case], sonar: bool, seconds: float, repeats: int
             ) -> dict[str, Any]:
    """Runs every case ``repeats`` times in turn (``"without"`` first); the medians."""
    samples: dict[str, list[Rates]] = {name: [] for name in cases}
    skipped: dict[str, str] = {}
    for _ in range(repeats):
        for name, case in cases.items():
            if name in skipped:
                continue
            with ExitStack() as stack:
                hooks = case(stack, sonar)
                if isinstance(hooks, str):
                    skipped[name] = hooks
                    continue
                samples[name].append(mission_rates(seconds, sonar=sonar, hooks=hooks))

    def median(name: str, k: int) -> float:
        return statistics.median(r[k] for r in samples[name])

    base_wall, base_cpu = median("without", 0), median("without", 1)
    out: dict[str, Any] = {
        "simulated_s": seconds, "repeats": repeats, "sonar": sonar,
        "rtf_without_bridge": base_wall, "rtf_cpu_without_bridge": base_cpu,
        "cpu_ms_per_simulated_s_without_bridge": 1e3 / base_cpu,
    }
    for name in cases:
        if name == "without":
            continue
        if name in skipped:
            out[name] = {"status": skipped[name]}
            continue
        wall, cpu = median(name, 0), median(name, 1)
        overhead_cpu = 1.0 - cpu / base_cpu
        out[name] = {
            "rtf": wall, "overhead": 1.0 - wall / base_wall,
            "rtf_cpu": cpu, "overhead_cpu": overhead_cpu,
            "cpu_ms_per_simulated_s": 1e3 / cpu - 1e3 / base_cpu,
            "overhead_cpu_runs": [1.0 - r[1] / base_cpu for r in samples[name]],
            "target": TARGET_OVERHEAD, "meets_target": overhead_cpu < TARGET_OVERHEAD,
        }
    return out


def run(quick: bool = False, repeats: int | None = None) -> dict[str, Any]:
    seconds, sonar_seconds = (5.0, 2.0) if quick else (60.0, 20.0)
    repeats = (1 if quick else 7) if repeats is None else max(1, int(repeats))
    listening = {"ros2_listener": _Ros2Case(listener="every")}
    result = _compare({"without": _without, "ros2": _Ros2Case(listener=None), **listening,
                       "moos": _moos},
                      sonar=False, seconds=seconds, repeats=repeats)
    listening_sonar = {"ros2_navigation_listener": _Ros2Case(listener="navigation"),
                       "ros2_listener": _Ros2Case(listener="every")}
    result["with_sonar"] = _compare({"without": _without, "ros2": _Ros2Case(listener=None),
                                     **listening_sonar, "moos": _moos},
                                    sonar=True, seconds=sonar_seconds,
                                    repeats=max(1, (repeats + 1) // 2))
    for out, cases, simulated in ((result, listening, seconds),
                                  (result["with_sonar"], listening_sonar, sonar_seconds)):
        for name, case in cases.items():
            if case.received and isinstance(out.get(name), dict):
                # messages that reached the listener per simulated second (warm-up included)
                out[name]["listener_received_per_simulated_s"] = (
                    statistics.median(case.received) / (simulated + WARM_UP_S))
    return result
