"""Imaging-sonar throughput: rays → polar image → fan image, per preset, on the pier scene.

Target (issue 3): P900-45, 256 beams × 64 elevation rays, 30 m window at 2.54 cm bins,
512 px fan, the paper's pier scene: ≥ 150 pings/s on one core (10× the real 15 Hz).
Also reported: the 100 m / 128-ray case, the split between ray casting and image
formation, and the resident memory (RSS) over many pings (it must stay flat).
"""

from __future__ import annotations

import os
import time
from typing import Any

import cv2
import numpy as np

from uhrisim.bench import best_rate
from uhrisim.sensors.sonar import PRESETS, ImagingSonar, SonarConfig

TARGET_PINGS_PER_S = 150.0


def _rss_mib() -> float:
    """Resident set size of this process, MiB (Linux /proc; 0 when unavailable)."""
    try:
        with open("/proc/self/statm") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return 0.0


def _case(paper, preset: str, range_m: float, rays: int, quick: bool, labels: bool = True):
    pose = paper.sonar_poses["approach"]
    cfg = SonarConfig(
        preset=preset,
        range_max_m=range_m,
        rays_per_beam=rays,
        tilt_deg=pose.tilt_deg,
        mount_position_frd=(0.0, 0.0, 0.0),
        fan_size_px=512,
        rate_hz=min(15.0, 1500.0 / (2.2 * range_m)),
        labels=labels,
    )
    sonar = ImagingSonar(cfg, np.random.default_rng(0))
    rc = paper.scene.raycaster("embree")
    p, R = pose.position_ned, pose.rotation
    sonar.ping(rc, p, R, 0.0)  # warm-up (caches, BVH)
    min_time = 0.3 if quick else 2.0
    repeats = 3 if quick else 20
    full = best_rate(lambda: sonar.ping(rc, p, R, 0.0), repeats, min_time)
    p_s, R_s = sonar.sonar_pose(p, R)
    dirs = sonar.geometry.dirs_sonar @ R_s.T
    origins = np.broadcast_to(p_s, dirs.shape).copy()
    cast = best_rate(lambda: rc.cast(origins, dirs, range_m), repeats, min_time)
    n_bins, n_beams = sonar.polar_shape
    form_s = max(1.0 / full - 1.0 / cast, 1e-9)
    return (
        sonar,
        rc,
        {
            "preset": preset,
            "beams": n_beams,
            "rays_per_beam": rays,
            "range_max_m": range_m,
            "bins": n_bins,
            "rays_per_ping": sonar.n_rays,
            "fan_px": list(sonar.geometry.fan_mask.shape),
            "labels": labels,
            "pings_per_s": full,
            "rays_per_s": full * sonar.n_rays,
            "cast_only_pings_per_s": cast,
            "image_formation_ms": form_s * 1e3,
            "cast_ms": 1e3 / cast,
        },
    )


def run(quick: bool = False) -> dict[str, Any]:
    """Measure; ``quick`` uses short timing windows and a short memory run."""
    from uhrisim.world.paper_scenes import pier_scene

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # one core, as the target states
    try:
        paper = pier_scene()
        cases: dict[str, Any] = {}
        for name in PRESETS:
            sonar, rc, res = _case(paper, name, 30.0, 64, quick)
            cases[f"{name}/30m/64rays"] = res
            if name == "P900-45":
                main_sonar, main_rc = sonar, rc
        cases["P900-45/30m/64rays/no-labels"] = _case(paper, "P900-45", 30.0, 64, quick, False)[2]
        cases["P900-45/100m/128rays"] = _case(paper, "P900-45", 100.0, 128, quick)[2]

        # Memory over many pings: RSS after a warm-up vs at the end.
        n = 200 if quick else 10_000
        pose = paper.sonar_poses["approach"]
        for i in range(20):
            main_sonar.ping(main_rc, pose.position_ned, pose.rotation, i * 0.1)
        rss0 = _rss_mib()
        t0 = time.perf_counter()
        for i in range(n):
            main_sonar.ping(main_rc, pose.position_ned, pose.rotation, i / 15.0)
        elapsed = time.perf_counter() - t0
        rss1 = _rss_mib()
    finally:
        cv2.setNumThreads(threads)

    main = cases["P900-45/30m/64rays"]
    return {
        "config": {
            "scene": "pier_scene(), pose 'approach' (3 m deep, tilt 10 deg)",
            "threads": "cv2.setNumThreads(1); numpy/Embree single-threaded calls",
            "fan_size_px": 512,
        },
        "cases": cases,
        "memory": {
            "pings": n,
            "rss_start_mib": rss0,
            "rss_end_mib": rss1,
            "rss_growth_mib": rss1 - rss0,
            "sustained_pings_per_s": n / elapsed,
            "flat": (rss1 - rss0) < 20.0,
        },
        "target": {
            "description": "P900-45, 256 beams x 64 rays, 30 m at 2.54 cm, 512 px fan, pier: "
            ">= 150 pings/s on one core",
            "target_pings_per_s": TARGET_PINGS_PER_S,
            "measured_pings_per_s": main["pings_per_s"],
            "meets_target": bool(main["pings_per_s"] >= TARGET_PINGS_PER_S),
        },
    }
