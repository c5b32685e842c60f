"""Benchmark: MCAP recording throughput (``uhrisim bench record``).

Measures, on this machine, single-threaded:

* odometry only: ``write_odometry`` calls/s (each writes /<agent>/odom, /<agent>/pose
  and /tf), MB/s;
* sonar: ``write_sonar`` pings/s with a 256 x 1181 polar image and a 512 x 400 fan
  image (the paper-era BlueView-like preset's sizes; speckle-like content, so zstd has
  realistic work), 200 hit points, compared with a 15 Hz ping rate (real-time factor);
* the hand-laid Odometry CDR encoder against mcap_ros2's schema-driven one (speedup).

Targets: odometry ≥ 10 000 calls/s (10 agents recorded at 100 Hz, at 10× real time);
sonar ≥ 60 pings/s (4× real time for one 15 Hz sonar). Per odometry call, most of the
time is now ``mcap``'s own ``add_message`` (three messages: /odom, /pose and /tf).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from mcap_ros2._dynamic import serialize_dynamic

from uhrisim.core.rng import component_rng
from uhrisim.record.mcap_recorder import McapRecorder
from uhrisim.ros import cdr
from uhrisim.ros.msgdefs import schema_text

ODOM_TARGET_CALLS_PER_S = 10_000.0
SONAR_TARGET_PINGS_PER_S = 60.0
SONAR_RATE_HZ = 15.0
POLAR_SHAPE = (256, 1181)
FAN_SHAPE = (512, 400)


def _speckle(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A sonar-like mono8 image: dark background, Rayleigh speckle, a few bright returns."""
    img = rng.rayleigh(12.0, size=shape)
    rows = rng.integers(0, shape[0], 6)
    img[rows, :] += 120.0
    return np.clip(img, 0, 255).astype(np.uint8)


def _bench_odometry(folder: Path, calls: int, compression: str) -> dict[str, Any]:
    path = folder / f"odom_{compression}.mcap"
    agents = ("rov", "diver")
    t0 = time.perf_counter()
    with McapRecorder(path, compression=compression) as rec:
        for i in range(calls):
            agent = agents[i % 2]
            rec.write_odometry(agent, 0.01 * (i // 2), (0.01 * i, 2.0, 3.0), 0.001 * i,
                               (0.5, 0.01, 0.0), 0.02)
        messages = sum(rec.message_counts.values())
    dt = time.perf_counter() - t0
    size = path.stat().st_size
    return {
        "calls": calls,
        "messages": messages,
        "seconds": dt,
        "calls_per_s": calls / dt,
        "messages_per_s": messages / dt,
        "file_mb": size / 1e6,
        "file_mb_per_s": size / 1e6 / dt,
        "bytes_per_call": size / calls,
    }


def _bench_sonar(folder: Path, pings: int, compression: str) -> dict[str, Any]:
    rng = component_rng(0, "bench/record")
    frames = [(_speckle(rng, POLAR_SHAPE), _speckle(rng, FAN_SHAPE)) for _ in range(4)]
    points = rng.normal(size=(200, 3)) * [10.0, 3.0, 1.0]
    inten = rng.uniform(size=200)
    pose = ((1.0, 2.0, 3.0), np.eye(3))
    path = folder / f"sonar_{compression}.mcap"
    t0 = time.perf_counter()
    with McapRecorder(path, compression=compression) as rec:
        for i in range(pings):
            t = i / SONAR_RATE_HZ
            polar, fan = frames[i % len(frames)]
            rec.write_odometry("rov", t, (0.1 * i, 0.0, 2.0), 0.0, (0.5, 0.0, 0.0), 0.0)
            rec.write_sonar("rov", "sonar", t, polar, fan, points, inten, pose)
    dt = time.perf_counter() - t0
    size = path.stat().st_size
    raw = POLAR_SHAPE[0] * POLAR_SHAPE[1] + FAN_SHAPE[0] * FAN_SHAPE[1]
    return {
        "pings": pings,
        "seconds": dt,
        "pings_per_s": pings / dt,
        "realtime_factor_at_15hz": pings / dt / SONAR_RATE_HZ,
        "image_mb_per_s_in": pings * raw / 1e6 / dt,
        "file_mb_per_s": size / 1e6 / dt,
        "compression_ratio": pings * raw / size,
        "file_mb_per_minute_at_15hz": size / pings * SONAR_RATE_HZ * 60 / 1e6,
    }


def _bench_encoder(n: int) -> dict[str, Any]:
    typename = "nav_msgs/msg/Odometry"
    ref = serialize_dynamic(typename, schema_text(typename))[typename]
    v = [1.0, 2.0, 3.0, 0.0, 0.0, 0.3, 0.95, 0.5, 0.0, 0.0, 0.0, 0.0, 0.1]
    msg = {
        "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "rov/odom"},
        "child_frame_id": "rov/base_link",
        "pose": {"pose": {"position": dict(zip("xyz", v[0:3], strict=True)),
                          "orientation": dict(zip("xyzw", v[3:7], strict=True))},
                 "covariance": [0.0] * 36},
        "twist": {"twist": {"linear": dict(zip("xyz", v[7:10], strict=True)),
                            "angular": dict(zip("xyz", v[10:13], strict=True))},
                  "covariance": [0.0] * 36},
    }
    t0 = time.perf_counter()
    for _ in range(n):
        fast = cdr.encode_odometry(1, 2, "rov/odom", "rov/base_link", v[0:3], v[3:7], v[7:10],
                                   v[10:13])
    t_fast = (time.perf_counter() - t0) / n
    packer = cdr.OdometryEncoder("rov/odom", "rov/base_link")
    t0 = time.perf_counter()
    for _ in range(n):
        packed = packer(1, 2, v[0:3], v[3:7], v[7:10], v[10:13])
    t_packed = (time.perf_counter() - t0) / n
    m = max(n // 20, 10)
    t0 = time.perf_counter()
    for _ in range(m):
        slow = ref(msg)
    t_ref = (time.perf_counter() - t0) / m
    return {
        "buffer_encoder_us": t_fast * 1e6,
        "precompiled_struct_encoder_us": t_packed * 1e6,
        "mcap_ros2_reference_us": t_ref * 1e6,
        "speedup_buffer": t_ref / t_fast,
        "speedup_precompiled": t_ref / t_packed,
        "identical_bytes": fast == slow == packed,
    }


def run(quick: bool = False) -> dict[str, Any]:
    """Measure recording throughput; ``quick`` runs a few-second version."""
    odom_calls = 4_000 if quick else 60_000
    pings = 20 if quick else 300
    with tempfile.TemporaryDirectory(prefix="uhrisim-bench-record-") as tmp:
        folder = Path(tmp)
        odom = _bench_odometry(folder, odom_calls, "zstd")
        sonar = _bench_sonar(folder, pings, "zstd")
        sonar_raw = _bench_sonar(folder, max(pings // 2, 10), "none")
    encoder = _bench_encoder(2_000 if quick else 20_000)
    return {
        "config": {
            "quick": quick,
            "chunk_size_bytes": 256 * 1024,
            "odometry_agents": 2,
            "polar_shape": list(POLAR_SHAPE),
            "fan_shape": list(FAN_SHAPE),
            "points_per_ping": 200,
            "sonar_rate_hz": SONAR_RATE_HZ,
        },
        "odometry_zstd": odom,
        "sonar_zstd": sonar,
        "sonar_uncompressed": sonar_raw,
        "odometry_encoder": encoder,
        "targets": {
            "odometry_calls_per_s": ODOM_TARGET_CALLS_PER_S,
            "sonar_pings_per_s": SONAR_TARGET_PINGS_PER_S,
        },
        "meets_target": bool(
            odom["calls_per_s"] >= ODOM_TARGET_CALLS_PER_S
            and sonar["pings_per_s"] >= SONAR_TARGET_PINGS_PER_S
        ),
    }

