"""Underwater camera throughput, and the paper's mission with camera and sonar.

Targets on one core (issue 19): 640×480 ≥ 20 frames/s and 320×240 ≥ 60 frames/s (the
VideoRay Pro 4 preset, coastal water Jerlov 1C, lamps on, forward scatter and noise on,
the paper's pier scene with the diver 4 m ahead); the track-and-trail mission with the
camera at 10 Hz and the sonar at 15 Hz (``scenarios/camera_trail.yaml``) ≥ 5× real time.
Also reported: the split of a frame between ray casting and image formation.

Rates are given per wall-clock second and per CPU second of this process. On a shared
machine the wall rate drops with the load; the CPU-time rate is what one core delivers,
and the targets are judged on it. "One core" includes numpy's BLAS: run with
``OPENBLAS_NUM_THREADS=1`` (the ray caster's small matrix products otherwise start
BLAS threads, whose start-up and hand-over cost more CPU than they save; the output
says which was in force).
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from uhrisim.bench.sonar import _rates
from uhrisim.core.frames import rot_z
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.sim.simulation import Simulation
from uhrisim.world.paper_scenes import pier_scene

TARGET_FPS = {"640x480": 20.0, "320x240": 60.0}
TARGET_MISSION_RTF = 5.0
MISSION = "camera_trail.yaml"


def _frame_rates(width: int, height: int, min_time: float, sampling: str = "adaptive"
                 ) -> dict[str, Any]:
    ps = pier_scene(with_diver=True)
    ps.scene.set_pose("diver", (4.0, 0.3, 3.5), rot_z(0.6), 0.5)
    pose = ps.sonar_poses["approach"]
    rc = ps.scene.raycaster()
    camera = UnderwaterCamera(
        CameraConfig(width=width, height=height, water=jerlov("1C"), tilt_deg=10.0,
                     sampling=sampling),
        np.random.default_rng(0))
    origin, R = camera.camera_pose(pose.position_ned, pose.rotation)
    dirs = camera.geometry.dirs_cam @ R.T

    def frame() -> object:
        return camera.capture(rc, pose.position_ned, pose.rotation, 0.0)

    def cast() -> object:
        return rc.cast(origin, dirs, camera.config.max_range_m)

    frame()
    wall, cpu = _rates(frame, 3, min_time)
    key = f"{width}x{height}"
    out = {"sampling": sampling, "frames_per_s": wall, "frames_per_s_cpu": cpu,
           "ms_per_frame_cpu": 1e3 / cpu, "pixels_per_s_cpu": width * height * cpu}
    if sampling == "adaptive":
        coarse = len(camera._grid.coarse) if camera._grid is not None else width * height
        out["rays_cast_fraction"] = coarse / (width * height) + camera.last_exact_fraction
        out["target_fps"] = TARGET_FPS[key]
        out["meets_target"] = cpu >= TARGET_FPS[key]
    else:  # one ray per pixel: how the time splits between casting and forming
        _, cast_cpu = _rates(cast, 3, min_time / 2)
        out["ray_cast_ms_cpu"] = 1e3 / cast_cpu
        out["formation_ms_cpu"] = max(1e3 / cpu - 1e3 / cast_cpu, 0.0)
    return out


def mission_rates(seconds: float) -> tuple[float, float]:
    """Simulated seconds per wall second and per CPU second of the camera mission (no
    hooks), after a 2 s warm-up."""
    with Simulation(load_scenario(shipped_scenario(MISSION))) as sim:
        sim.run(2.0)
        wall, cpu = time.perf_counter(), time.process_time()
        sim.run(seconds)
        return seconds / (time.perf_counter() - wall), seconds / (time.process_time() - cpu)


def run(quick: bool = False) -> dict[str, Any]:
    min_time = 0.5 if quick else 3.0
    seconds = 3.0 if quick else 20.0
    wall_rtf, cpu_rtf = mission_rates(seconds)
    return {
        "scene": "pier + diver 4 m ahead, Jerlov 1C, lamps on",
        "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
        "640x480": _frame_rates(640, 480, min_time),
        "320x240": _frame_rates(320, 240, min_time),
        "640x480_one_ray_per_pixel": _frame_rates(640, 480, min_time, "full"),
        "mission": {"scenario": MISSION, "camera_hz": 10, "sonar_hz": 15,
                    "simulated_s": seconds, "real_time_factor": wall_rtf,
                    "real_time_factor_cpu": cpu_rtf, "target": TARGET_MISSION_RTF,
                    "meets_target": cpu_rtf >= TARGET_MISSION_RTF},
    }
