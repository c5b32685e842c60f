"""A ping's three sonar images reach a best-effort subscriber with the default settings
of its own process (issue 30): the simulator applies uhrisim's Fast DDS profile (an 8 MiB
shared-memory segment; src/uhrisim/bridges/ros2/fastdds_profile.xml), without which a
ping's images exceed Fast DDS's 512 kB default and best-effort readers lose messages.

The simulation (scenarios/ros2_external_helm.yaml, its P900-45 at 15 Hz) runs here paced
at real time; tests/support/ros2_stamps_listener.py, in its own process without
``FASTDDS_DEFAULT_PROFILES_FILE``, keeps every stamp it receives on ``sonar/polar``,
``fan`` and ``image``. It keeps a history deeper than it may lag on a loaded machine (the
sensor-data QoS's 5 messages are 333 ms at 15 Hz), and is stopped only once it has taken
every ping published (or 30 s on), so what is counted is the transport's loss, not a busy
listener's. Loss is counted by stamps — every ping after the first one received on a topic
must arrive, less than 1 % missing — never by a wall-clock rate.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

pytest.importorskip("rclpy")
pytest.importorskip("marine_acoustic_msgs")

from tests.support.children import Child
from uhrisim.bridges.ros2.hook import Ros2BridgeHook
from uhrisim.bridges.ros2.spec import FASTDDS_PROFILE
from uhrisim.ros.messages import stamp_ns
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.pacing import Pacer
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "ros2_external_helm.yaml"
TOPICS = {"/videoray/sonar/polar": "image", "/videoray/sonar/fan": "image",
          "/videoray/sonar/image": "sonar"}
PINGS = 150  # 10 s of pings at 15 Hz


def test_best_effort_subscriber_gets_every_sonar_image(ros_env: int, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("FASTDDS_DEFAULT_PROFILES_FILE", raising=False)  # the user's side
    listener = Child("ros2_stamps_listener.py",
                     [a for t, kind in TOPICS.items() for a in ("--topic", f"{t}={kind}")],
                     tmp_path)
    hook = Ros2BridgeHook(domain_id=ros_env, node_name="uhrisim_large")
    sim = Simulation(load_scenario(SCENARIO), raycast_sensors=True, hooks=[hook])
    pings: list[int] = []
    try:
        sim.start()
        assert os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(FASTDDS_PROFILE)
        listener.expect("READY", timeout=300.0)
        assert hook.bridge.wait_for_subscribers(list(TOPICS), 120.0)
        pacer = Pacer(real_time_factor=1.0)
        pacer.reset(sim.t)
        deadline = time.monotonic() + 600.0
        while len(pings) < PINGS:
            assert time.monotonic() < deadline
            frame = sim.step()
            if "videoray/sonar" in frame.pings:
                pings.append(stamp_ns(frame.t, "test"))
            pacer.wait(frame.t)
        stamps = listener.result(timeout=60.0, counts=dict.fromkeys(TOPICS, len(pings)))
    finally:
        sim.close()
        if listener.proc.poll() is None:
            listener.proc.kill()
    for topic in TOPICS:
        got = set(stamps[topic])
        assert got <= set(pings) and got, topic
        expected = [t for t in pings if t >= min(got)]
        lost = [pings.index(t) for t in expected if t not in got]
        assert len(expected) > 0.8 * PINGS and len(lost) < 0.01 * len(expected), (
            f"{topic}: pings {lost} of {len(pings)} lost")
