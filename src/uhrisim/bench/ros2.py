"""Benchmark of the ROS 2 bridge: cost of each publish call, sustainable message rates,
and the share of one CPU core the bridge takes in a 15 Hz sonar + 10 Hz odometry loop.

``uhrisim bench ros2 [--json]`` prints :func:`run`'s dict. Sizes: a BlueView P900-45
polar image (256 beams x 2000 range bins of 2.54 cm, ~50 m; docs/reference/sonar.md), a
600 x 1000 fan image (10 px/m, the paper's scale) and a 4096-point cloud.

The full run starts one external subscriber process (plain rclpy, loopback discovery,
a private random domain id) so that the calls are timed with a matched reader, which is
when DDS actually serializes and sends; ``quick=True`` times the calls without it.
"""

from __future__ import annotations

import json
import os
import random
import sys
import tempfile
import time
from typing import Any

import numpy as np

#: Loop the overhead target refers to (the paper's sonar rate and a 10 Hz nav topic).
SONAR_HZ = 15.0
ODOM_HZ = 10.0
#: Target: the bridge takes under 5 % of one core in that loop.
TARGET_OVERHEAD_FRACTION = 0.05

POLAR_SHAPE = (2000, 256)
FAN_SHAPE = (600, 1000)
N_POINTS = 4096

def _time_calls(fn, n: int) -> dict[str, float]:
    """Per-call wall time of ``fn(k)`` for k in range(n): median, p95, mean (µs)."""
    dts = np.empty(n)
    for k in range(n):
        t0 = time.perf_counter()
        fn(k)
        dts[k] = time.perf_counter() - t0
    us = dts * 1e6
    return {
        "calls": n,
        "median_us": float(np.median(us)),
        "p95_us": float(np.percentile(us, 95)),
        "mean_us": float(us.mean()),
    }


def _sustained(fn, seconds: float) -> tuple[int, float]:
    k, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        fn(k)
        k += 1
    return k, time.perf_counter() - t0


def run(quick: bool = False) -> dict[str, Any]:
    """Measure the bridge; see the module docstring. Returns a JSON-serialisable dict."""
    from uhrisim.bridges.ros2 import apply_env_defaults

    apply_env_defaults()  # what Ros2Bridge.start() does too: loopback discovery
    domain = random.SystemRandom().randint(1, 101)
    agent = f"bench_{random.SystemRandom().randrange(16**6):06x}"
    with tempfile.TemporaryDirectory(prefix="uhrisim-ros-log-") as log_dir:
        saved = os.environ.get("ROS_LOG_DIR")
        os.environ["ROS_LOG_DIR"] = saved or log_dir  # no log files in the home folder
        try:
            return _run(quick, domain, agent)
        finally:
            if saved is None:
                os.environ.pop("ROS_LOG_DIR", None)


def _run(quick: bool, domain: int, agent: str) -> dict[str, Any]:
    from uhrisim.bridges.ros2 import AgentBridgeSpec, Ros2Bridge
    from uhrisim.bridges.ros2.topics import QOS_SENSOR, QOS_STATE

    from ._ros2_listener import Listener, qos_label

    rng = np.random.default_rng(0)
    polar = rng.integers(0, 256, POLAR_SHAPE, dtype=np.uint8)
    fan = rng.integers(0, 256, FAN_SHAPE, dtype=np.uint8)
    pts = rng.uniform(-10, 10, (N_POINTS, 3))
    inten = rng.uniform(0, 1, N_POINTS)
    pos, vel = np.array([3.0, 4.0, 2.0]), np.array([0.5, 0.0, 0.0])

    n_nav, n_sonar = (300, 20) if quick else (3000, 200)
    sustain_s = 0.0 if quick else 1.5

    # every call serialises and writes, subscribed or not: the costs of the calls
    bridge = Ros2Bridge([AgentBridgeSpec(agent)], node_name=f"uhrisim_{agent}", domain_id=domain,
                        publish_unsubscribed=True)
    gated = Ros2Bridge(
        [AgentBridgeSpec(f"{agent}_g", sonars=(), odom_rate_hz=ODOM_HZ)],
        node_name=f"uhrisim_{agent}_g", domain_id=domain, publish_clock=False,
        publish_unsubscribed=True,
    )
    bridge.start()
    gated.start()
    sub: Listener | None = None
    out: dict[str, Any] = {}
    try:
        pose = (pos, np.eye(3))

        def nav(k: int) -> None:  # a new time: /clock, odometry, pose and /tf
            bridge.write_clock(k * 1e-3)
            bridge.write_odometry(agent, k * 1e-3, pos, 0.1 * k, vel, 0.0)

        def sonar(k: int) -> None:  # a new time: /clock and the three sonar products
            bridge.write_clock(k * 1e-3)
            bridge.write_sonar(agent, "sonar", k * 1e-3, polar, fan, pts, inten, pose)

        def nav_throttled(k: int) -> None:  # 1 kHz ticks, 10 Hz gate: mostly not due
            if gated.odometry_due(f"{agent}_g", k * 1e-3):
                gated.write_odometry(f"{agent}_g", k * 1e-3, pos, 0.1, vel, 0.0)

        def clock(k: int) -> None:  # a new simulation time every call
            bridge.write_clock(1e3 + k * 1e-3)

        no_sub = {
            "write_odometry": _time_calls(nav, n_nav),
            "write_sonar": _time_calls(sonar, n_sonar),
            "write_odometry_throttled_tick": _time_calls(nav_throttled, n_nav),
            "write_clock": _time_calls(clock, n_nav),
        }
        out["without_subscriber"] = no_sub
        with_sub: dict[str, Any] | None = None
        sustained: dict[str, Any] | None = None
        if not quick:
            odom_topic, polar_topic = f"/{agent}/odom", f"/{agent}/sonar/polar"
            sub = Listener([(odom_topic, "nav_msgs/msg/Odometry", qos_label(QOS_STATE)),
                            *[(f"/{agent}/sonar/{key}", kind, qos_label(QOS_SENSOR))
                              for key, kind in (("polar", "sensor_msgs/msg/Image"),
                                                ("fan", "sensor_msgs/msg/Image"),
                                                ("points", "sensor_msgs/msg/PointCloud2"))]],
                           domain)
            end = time.monotonic() + 20.0
            topics = [odom_topic, polar_topic]
            while not all(bridge.subscriber_count(t) > 0 for t in topics):
                if time.monotonic() > end:
                    raise RuntimeError("bench subscriber was not discovered within 20 s")
                time.sleep(0.02)
            time.sleep(0.5)
            with_sub = {
                "write_odometry": _time_calls(nav, n_nav),
                "write_sonar": _time_calls(sonar, n_sonar),
            }
            c0 = sub.counts()
            k_nav, s_nav = _sustained(nav, sustain_s)
            time.sleep(0.3)
            c1 = sub.counts()
            k_son, s_son = _sustained(sonar, sustain_s)
            time.sleep(0.5)
            c2 = sub.counts()
            sonar_bytes = polar.nbytes + fan.nbytes + 16 * N_POINTS
            sustained = {
                "odom_published_per_s": k_nav / s_nav,
                "odom_delivered_fraction": (c1[odom_topic] - c0[odom_topic]) / max(k_nav, 1),
                "sonar_sets_published_per_s": k_son / s_son,
                "sonar_publish_MB_per_s": k_son * sonar_bytes / s_son / 1e6,
                "sonar_polar_delivered_fraction":
                    (c2[polar_topic] - c1[polar_topic]) / max(k_son, 1),
                "seconds_each": sustain_s,
            }
            out["with_external_subscriber"] = with_sub
            out["sustained"] = sustained
        basis = with_sub if with_sub is not None else no_sub
        nav_us, sonar_us = basis["write_odometry"]["mean_us"], basis["write_sonar"]["mean_us"]
        frac = (SONAR_HZ * sonar_us + ODOM_HZ * nav_us) * 1e-6
        out["loop_overhead"] = {
            "sonar_hz": SONAR_HZ,
            "odom_hz": ODOM_HZ,
            "basis": "with_external_subscriber" if with_sub is not None else "without_subscriber",
            "fraction_of_one_core": frac,
            "target_fraction": TARGET_OVERHEAD_FRACTION,
            "meets_target": bool(frac < TARGET_OVERHEAD_FRACTION),
        }
        out["config"] = {
            "polar_shape": list(POLAR_SHAPE),
            "fan_shape": list(FAN_SHAPE),
            "points": N_POINTS,
            "sonar_set_bytes": int(polar.nbytes + fan.nbytes + 16 * N_POINTS),
            "quick": quick,
            "rmw": "rmw_fastrtps_cpp (Fast DDS), ROS_AUTOMATIC_DISCOVERY_RANGE="
            + os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", ""),
            "sensor_qos": "best effort, keep last 2",
        }
        out["meets_target"] = out["loop_overhead"]["meets_target"]
    finally:
        if sub is not None:
            sub.close()
        bridge.close()
        gated.close()
    return out


if __name__ == "__main__":  # pragma: no cover - manual use
    print(json.dumps(run(quick="--quick" in sys.argv), indent=2))
