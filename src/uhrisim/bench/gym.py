"""Benchmark: Gymnasium environment steps per second (``uhrisim bench gym``).

Targets (issue 17), with the default 0.25 s control step (15 physics steps at 60 Hz):

* ``uhrisim/TrailDiverState-v0``: >= 2 000 env steps/s on one core;
* ``uhrisim/TrailDiver-v0`` (sonar, one P900-45 ping per step): >= 100 env steps/s;
* an async vector env of 2 state envs on 2 cores: >= 1.6x the steps/s of one env.

Steps are taken with seeded random actions and include the resets of the episodes that
end (default randomisation, 120 s episodes). Single-env rates are given per wall second
and per CPU second of this process (the target is judged on the CPU rate, which a shared
machine's load does not lower); the vector-env speed-up is a wall-clock ratio and is only
meaningful with two idle cores: the load average is printed beside it.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

TARGETS = {"state_steps_per_s": 2000.0, "sonar_steps_per_s": 100.0, "async_speedup_2": 1.6}


def _rates(env, steps: int) -> dict[str, Any]:
    """Rates of ``steps`` random steps of one env: env steps per wall and per CPU second
    (resets included), per CPU second of the steps alone, and the resets' count and mean
    CPU time (ms)."""
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(10):  # warm-up
        env.step(env.action_space.sample())
    wall, cpu = time.perf_counter(), time.process_time()
    resets, reset_cpu = 0, 0.0
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            start = time.process_time()
            env.reset()
            resets, reset_cpu = resets + 1, reset_cpu + time.process_time() - start
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {"steps": steps, "steps_per_s": steps / wall, "steps_per_cpu_s": steps / cpu,
            "steps_per_cpu_s_without_resets": steps / (cpu - reset_cpu), "resets": resets,
            "reset_cpu_ms": 1e3 * reset_cpu / resets if resets else None}


def _vector_rate(vec, steps: int) -> float:
    """Wall env steps per second (all sub-envs together) of a vector env."""
    vec.reset(seed=0)
    vec.action_space.seed(0)
    for _ in range(10):
        vec.step(vec.action_space.sample())
    wall = time.perf_counter()
    for _ in range(steps):
        vec.step(vec.action_space.sample())  # sub-envs reset themselves (autoreset)
    return steps * vec.num_envs / (time.perf_counter() - wall)


def run(quick: bool = False) -> dict[str, Any]:
    try:
        import gymnasium

        import uhrisim.envs  # noqa: F401  (registers the ids)
    except ImportError as error:
        return {"status": f"skipped: {error}"}
    n_state, n_sonar = (300, 40) if quick else (3000, 300)
    state = gymnasium.make("uhrisim/TrailDiverState-v0")
    state_rates = _rates(state, n_state)
    state.close()
    sonar = gymnasium.make("uhrisim/TrailDiver-v0")
    sonar_rates = _rates(sonar, n_sonar)
    sonar.close()
    vec = gymnasium.make_vec("uhrisim/TrailDiverState-v0", num_envs=2,
                             vectorization_mode="async")
    try:
        async_rate = _vector_rate(vec, n_state // 2)
    finally:
        vec.close()
    one = gymnasium.make("uhrisim/TrailDiverState-v0")
    one_wall = _rates(one, n_state)["steps_per_s"]  # the same load, measured just after
    one.close()
    speedup = async_rate / one_wall
    load = os.getloadavg()[0]
    cores = len(os.sched_getaffinity(0))
    return {
        "control_step_s": 0.25,
        "state_env": {**state_rates, "target": TARGETS["state_steps_per_s"],
                      "meets_target": state_rates["steps_per_cpu_s"]
                      >= TARGETS["state_steps_per_s"]},
        "sonar_env": {**sonar_rates, "target": TARGETS["sonar_steps_per_s"],
                      "meets_target": sonar_rates["steps_per_cpu_s"]
                      >= TARGETS["sonar_steps_per_s"]},
        "async_vector_env": {"num_envs": 2, "cores": cores, "steps_per_s": async_rate,
                             "single_env_steps_per_s": one_wall, "speedup": speedup,
                             "target": TARGETS["async_speedup_2"],
                             "meets_target": bool(speedup >= TARGETS["async_speedup_2"]),
                             "load_average_1min": load,
                             "note": "wall-clock ratio: under load (load average >= "
                                     f"{cores}) it understates the speed-up"
                             if load >= cores else "wall-clock ratio"},
        "random_actions": True, "numpy": np.__version__,
    }
