"""Model steps per second: one VideoRay, and many at once through the same kernel
(compiled by numba when the [fast] extra is installed; after a warm-up that compiles)."""

from __future__ import annotations

from typing import Any

import numpy as np

from uhrisim.bench import best_rate
from uhrisim.dynamics import videoray
from uhrisim.dynamics.plants import VideoRayPlant


def run(quick: bool = False) -> dict[str, Any]:
    params = videoray.VideoRayParams()
    dt = 0.01
    plant = VideoRayPlant(params, dt)
    u1 = np.array([130.0, 150.0, -100.0])
    x1 = np.zeros(videoray.STATE_SIZE)
    min_time = 0.05 if quick else 0.5
    plant.step(0.0, x1, u1)  # compile the kernels (numba, when installed) before timing
    plant.step(0.0, np.zeros((2, videoray.STATE_SIZE)), np.tile(u1, (2, 1)))
    single = best_rate(lambda: plant.step(0.0, x1, u1), repeats=100, min_time=min_time)
    results: dict[str, Any] = {
        "config": {"dt_s": dt, "rk4_substeps": plant.integrator.substeps,
                   "yaw_inertia_J": params.J},
        "single_vehicle_steps_per_s": single,
        "real_time_factor_single": single * dt,
        "batch": {},
    }
    for count in (10, 100) if quick else (10, 100, 1000):
        xs = np.zeros((count, videoray.STATE_SIZE))
        us = np.tile(u1, (count, 1))
        rate = best_rate(lambda xs=xs, us=us: plant.step(0.0, xs, us), repeats=20,
                         min_time=min_time)
        results["batch"][str(count)] = {
            "batch_steps_per_s": rate,
            "vehicle_steps_per_s": rate * count,
            "cost_vs_single_loop": single / rate / count,
        }
    hundred = results["batch"]["100"]
    results["target"] = {"description": "100 vehicles cost far less than 100x one (< 0.2 x)",
                         "meets_target": hundred["cost_vs_single_loop"] < 0.2}
    return results
