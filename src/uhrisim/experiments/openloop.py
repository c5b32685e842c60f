"""The paper's open-loop experiment (Figs 5-8).

Starboard input 150, port 130, vertical -100 for the first 5 s, then all zero; 30 s in
total, output every 0.01 s (the authors ran Octave's lsode). Expected: a counter-clockwise
arc while thrusting, then a straight decelerating tail with no rotation; depth increases.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from uhrisim.dynamics import videoray
from uhrisim.dynamics.integrators import integrate_adaptive
from uhrisim.dynamics.plants import VideoRayPlant
from uhrisim.viz.openloop_figures import plot_openloop

THRUST_INPUT = np.array([130.0, 150.0, -100.0])  # port, starboard, vertical (paper section IV)
THRUST_DURATION = 5.0  # s
TOTAL_DURATION = 30.0  # s
OUTPUT_STEP = 0.01  # s
CSV_COLUMNS = ("t", "x", "y", "z", "psi", "u", "v", "w", "r")


def openloop_input(t: float) -> NDArray:
    """Thruster inputs ``[port, star, vert]`` of the experiment at time ``t`` (s)."""
    return THRUST_INPUT.copy() if t < THRUST_DURATION else np.zeros(3)


@dataclass(frozen=True)
class OpenLoopRun:
    """Times (s), states (rows of the VideoRay state) and the inputs applied."""

    t: NDArray
    states: NDArray
    inputs: NDArray


def run_openloop(params: videoray.VideoRayParams | None = None, dt: float = OUTPUT_STEP,
                 method: str = "rk4") -> OpenLoopRun:
    """Simulate the experiment with fixed-step RK4 (``method="rk4"``) or SciPy LSODA."""
    params = params or videoray.VideoRayParams()
    n = round(TOTAL_DURATION / dt)
    t = np.arange(n + 1) * dt
    inputs = np.array([openloop_input(ti) for ti in t])
    x0 = np.zeros(videoray.STATE_SIZE)
    if method == "rk4":
        plant = VideoRayPlant(params, dt)
        states = np.empty((n + 1, videoray.STATE_SIZE))
        states[0] = x0
        for k in range(n):
            states[k + 1] = plant.step(t[k], states[k], inputs[k])
    elif method == "lsoda":
        states = integrate_adaptive(videoray.xdot, x0, openloop_input, params, t,
                                    breakpoints=(THRUST_DURATION,))
    else:
        raise ValueError(f"method must be 'rk4' or 'lsoda', got {method!r}")
    return OpenLoopRun(t=t, states=states, inputs=inputs)


def write_csv(run: OpenLoopRun, path: Path) -> Path:
    """``t,x,y,z,psi,u,v,w,r``: SI units, NED world, FRD body, one row per sample."""
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(CSV_COLUMNS)
        for ti, state in zip(run.t, run.states, strict=True):
            writer.writerow([f"{ti:.2f}", *(f"{value:.9g}" for value in state)])
    return path


def make_openloop(out_dir: Path) -> list[Path]:
    """Run the experiment and write ``openloop.csv`` and the four figures (PNG)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    run = run_openloop()
    figures = plot_openloop(run.t, run.states, run.inputs, out_dir)
    return [write_csv(run, out_dir / "openloop.csv"), *figures]
