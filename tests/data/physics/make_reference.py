"""Writes ``reference_trajectories.npz``: trajectories of the physics as it was before the
batched kernels (commit f8612a8 on main), which tests/unit/test_dynamics_batched.py holds
today's code to (1e-9 relative).

Run from the repository root with the package installed: ``python
tests/data/physics/make_reference.py`` (only to re-create the file deliberately).
"""

from pathlib import Path

import numpy as np

from uhrisim.dynamics import diver, videoray
from uhrisim.dynamics.plants import DiverPlant, VideoRayPlant
from uhrisim.experiments.openloop import run_openloop
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Simulation

MISSION_S = 120.0
MISSION_EVERY = 6  # ticks between saved rows (10 Hz at 60 Hz physics)


def main() -> None:
    out = {}
    run = run_openloop()  # the paper's open-loop experiment, RK4 at 0.01 s
    out["openloop_t"], out["openloop_states"] = run.t, run.states
    quad = run_openloop(videoray.VideoRayParams(thrust_map="quadratic", coupling="rigid-body"))
    out["openloop_quadratic_rigid_states"] = quad.states
    # many vehicles at once with random held inputs (the batch path): 16 x 200 steps
    rng = np.random.default_rng(2013)
    plant = VideoRayPlant(videoray.VideoRayParams(), 1.0 / 60.0)
    xs = np.zeros((16, videoray.STATE_SIZE))
    xs[:, 3] = rng.uniform(-np.pi, np.pi, 16)
    us = rng.uniform(-150.0, 150.0, (200, 16, 3))
    batch = [xs]
    for k in range(200):
        xs = plant.step(k / 60.0, xs, us[k])
        batch.append(xs)
    out["batch_inputs"], out["batch_states"] = us, np.array(batch)
    # the diver's exact step under random leg inputs
    dplant = DiverPlant(diver.DiverParams(), 1.0 / 20.0)
    legs = rng.uniform(-1.0, 1.5, (400, 3))
    legs[::7, 0] = legs[::7, 1]  # straight legs too (zero yaw rate)
    x = np.array([1.0, -2.0, 1.5, 0.3])
    divers = [x]
    for k in range(400):
        x = dplant.step(k / 20.0, x, legs[k])
        divers.append(x)
    out["diver_inputs"], out["diver_states"] = legs, np.array(divers)
    # the paper's mission (no sonar): both agents' states every MISSION_EVERY ticks
    with Simulation(load_scenario(shipped_scenario()), raycast_sensors=False) as sim:
        rows = []
        for _ in range(round(MISSION_S * 60)):
            sim.step()
            if sim.tick % MISSION_EVERY == 0:
                rows.append(np.concatenate([sim.agents["diver"].state,
                                            sim.agents["videoray"].state]))
    out["mission_states"] = np.array(rows)
    path = Path(__file__).with_name("reference_trajectories.npz")
    np.savez_compressed(path, **out)
    print(f"wrote {path} ({path.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
