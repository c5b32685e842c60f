"""Benchmark: the native vector env's env steps per second against N (``uhrisim bench
vector``), with a plot of steps/s against N.

Targets (issue 27), with the default 0.25 s control step (5 physics steps at 20 Hz),
seeded random actions and the resets of the episodes that end included (autoreset):
``uhrisim/TrailDiverState-v0`` >= 5 000 env steps/s at N = 1 and >= 100 000 at N = 1024;
``uhrisim/TrailDiver-v0`` (a P900-45 ping of 8 192 rays each step) >= 1 000 at N = 64.
Rates are given per wall second and per CPU second of this process (the machine may be
shared: the CPU rate is what the cores this process used delivered; the load average is
printed beside them). N = 1024 is measured again with a thread per core (``threads``):
``target_n1024.steps_per_s_2_threads`` is the "on 2 cores" wall rate, beside one thread's
and the load average after it. ``ready_cpu_s``: CPU seconds from making the env to after
its first steps (numba's compile, or its load from the disk cache). The baseline,
measured in the same run: the single env on the ordinary Simulation (``TrailDiverEnv``),
the episodes the vector env reproduces.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

TARGETS = {"n1": 5000.0, "n1024": 100000.0}
SIZES = (1, 4, 16, 64, 256, 1024)
#: Stretches of N = 1 024 for each thread count (their median is reported).
TARGET_REPEATS = 5
QUICK_SIZES = (1, 16, 64)
#: ``uhrisim/TrailDiver-v0``'s vector env (one ping per step): >= 1 000 env steps/s at N = 64.
SONAR_TARGET = {"num_envs": 64, "steps_per_s": 1000.0}
SONAR_SIZES = (1, 4, 16, 64)
QUICK_SONAR_SIZES = (4,)


def _vector_rates(num_envs: int, seconds: float, sonar: bool = False,
                  threads: tuple[int, ...] = (1,), repeats: int = 1) -> list[dict[str, Any]]:
    """Env steps per wall and per CPU second of a vector env of ``num_envs`` (the sonar
    one for ``sonar``) for each count of ``threads`` (its compiled ticks, or the sonar's
    images, shared among them), stepped with seeded random actions: one env per count,
    made ready (numba's compile or load, the floor's collision caster: ``ready_cpu_s``) and
    warmed up, then ``repeats`` stretches of about ``seconds`` each, the counts taken in
    turn in every repeat (a change of load hits them alike); the median stretch's rates,
    with the lowest and highest wall rates."""
    from uhrisim.envs.sonar_vector import TrailDiverSonarVectorEnv
    from uhrisim.envs.vector import TrailDiverVectorEnv

    runs = []
    for count in threads:
        ready = time.process_time()
        vec = (TrailDiverSonarVectorEnv(num_envs=num_envs, threads=count) if sonar
               else TrailDiverVectorEnv(num_envs=num_envs, threads=count))
        vec.prepare()
        vec.reset(seed=0)
        low, high = vec.single_action_space.low, vec.single_action_space.high
        actions = np.random.default_rng(0).uniform(low, high, (64, num_envs, 3)
                                                   ).astype(np.float32)
        for k in range(5):
            vec.step(actions[k])
        runs.append({"vec": vec, "actions": actions, "done": 5, "stretches": [],
                     "ready_cpu_s": time.process_time() - ready})
    for _ in range(repeats):
        for run in runs:
            vec, actions = run["vec"], run["actions"]
            steps, ended = 0, 0
            wall, cpu = time.perf_counter(), time.process_time()
            while time.perf_counter() - wall < seconds or steps < 5:
                _, _, terminated, truncated, _ = vec.step(actions[run["done"] % len(actions)])
                ended += int(np.count_nonzero(terminated | truncated))
                steps += 1
                run["done"] += 1
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            run["stretches"].append({"batch_steps": steps, "episodes_ended": ended,
                                     "steps_per_s": steps * num_envs / wall,
                                     "steps_per_cpu_s": steps * num_envs / cpu})
    rows = []
    for count, run in zip(threads, runs, strict=True):
        run["vec"].close()
        stretches = sorted(run["stretches"], key=lambda r: r["steps_per_s"])
        rows.append({"num_envs": num_envs, "threads": count, "repeats": repeats,
                     "seconds_each": seconds, **stretches[len(stretches) // 2],
                     "steps_per_s_lowest": stretches[0]["steps_per_s"],
                     "steps_per_s_highest": stretches[-1]["steps_per_s"],
                     "ready_cpu_s": run["ready_cpu_s"]})
    return rows


def _vector_rate(num_envs: int, seconds: float, sonar: bool = False,
                 threads: int = 1) -> dict[str, Any]:
    """:func:`_vector_rates` of one count of ``threads``, one stretch."""
    return _vector_rates(num_envs, seconds, sonar, (threads,))[0]


def _single_rate(steps: int, observation: str = "state") -> float:
    """Env steps per CPU second of the single env on the Simulation (resets included)."""
    from uhrisim.envs.trail_diver import TrailDiverEnv

    env = TrailDiverEnv(observation)
    env.reset(seed=0)
    env.action_space.seed(0)
    cpu = time.process_time()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    return steps / (time.process_time() - cpu)


def plot(rows: list[dict[str, Any]], single: float, path: Path) -> Path:
    """Steps/s against N (log-log), per CPU second and per wall second, with the targets
    and the single env's rate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [r["num_envs"] for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.loglog(n, [r["steps_per_cpu_s"] for r in rows], "o-", label="vector env, per CPU s")
    ax.loglog(n, [r["steps_per_s"] for r in rows], "s--", label="vector env, per wall s")
    ax.axhline(single, color="grey", lw=1, label="single env (Simulation), per CPU s")
    ax.plot([1, 1024], [TARGETS["n1"], TARGETS["n1024"]], "r*", ms=12, label="targets")
    ax.set_xlabel("N (episodes in one vector env)")
    ax.set_ylabel("env steps / s (0.25 s each)")
    ax.set_title("uhrisim/TrailDiverState-v0, native vector env")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def run(quick: bool = False, out_dir: Path = Path("out/bench")) -> dict[str, Any]:
    try:
        import gymnasium  # noqa: F401
    except ImportError as error:
        return {"status": f"skipped: {error}"}
    from uhrisim.core.compiled import numba_module

    seconds = 0.3 if quick else 3.0
    cores = len(os.sched_getaffinity(0))
    sizes = QUICK_SIZES if quick else SIZES
    # N = 1 024, the target's: one thread against a thread per core, taken in turn,
    # the median of several stretches
    target = (_vector_rates(1024, seconds, threads=(1, cores) if cores > 1 else (1,),
                            repeats=TARGET_REPEATS) if 1024 in sizes else [])
    rows = [_vector_rate(n, seconds) for n in sizes if n != 1024] + target[:1]
    single = _single_rate(40 if quick else 400)
    by_n = {r["num_envs"]: r for r in rows}
    result: dict[str, Any] = {
        "control_step_s": 0.25, "physics_rate_hz": 20, "random_actions": True,
        "compiled_kernels": numba_module() is not None,
        "load_average_1min": os.getloadavg()[0], "cores": len(os.sched_getaffinity(0)),
        "sizes": {str(r["num_envs"]): r for r in rows},
        "single_env_steps_per_cpu_s": single,
    }
    for key, n in (("n1", 1), ("n1024", 1024)):
        if n in by_n:
            rate = by_n[n]["steps_per_cpu_s"]
            result[f"target_{key}"] = {"steps_per_cpu_s": rate, "target": TARGETS[key],
                                       "meets_target": rate >= TARGETS[key],
                                       "vs_single_env": rate / single}
    if len(target) > 1:  # the "on 2 cores": the steps in a thread per core
        result["target_n1024"].update(_on_cores(*target, TARGETS["n1024"]))
    result["plot"] = str(plot(rows, single, Path(out_dir) / "vector_steps_per_s.png"))
    result["sonar"] = _sonar_rates(quick, seconds)
    return result


def _sonar_rates(quick: bool, seconds: float) -> dict[str, Any]:
    """``uhrisim/TrailDiver-v0``'s vector env (P900-45, 8 192 rays a ping, one ping a
    step) against N, and the single sonar env (not in ``quick``); the target's N = 64 as
    the state env's N = 1 024: one thread against a thread per core, taken in turn, the
    median of :data:`TARGET_REPEATS` stretches."""
    if quick:
        rows = [_vector_rate(n, seconds, sonar=True) for n in QUICK_SONAR_SIZES]
        return {"sizes": {str(r["num_envs"]): r for r in rows}}
    n = SONAR_TARGET["num_envs"]
    cores = len(os.sched_getaffinity(0))
    target = _vector_rates(n, seconds, sonar=True, threads=(1, cores) if cores > 1 else (1,),
                           repeats=TARGET_REPEATS)
    rows = [_vector_rate(size, seconds, sonar=True) for size in SONAR_SIZES if size != n]
    out: dict[str, Any] = {"sizes": {str(r["num_envs"]): r for r in rows + target[:1]}}
    single = _single_rate(40, "sonar")
    rate = target[0]["steps_per_cpu_s"]
    out["single_env_steps_per_cpu_s"] = single
    out[f"target_n{n}"] = {"steps_per_cpu_s": rate, "target": SONAR_TARGET["steps_per_s"],
                           "meets_target": rate >= SONAR_TARGET["steps_per_s"],
                           "vs_single_env": rate / single, "repeats": TARGET_REPEATS}
    if len(target) > 1:  # the "on 2 cores": the images formed in a thread per core
        out[f"target_n{n}"].update(_on_cores(*target, SONAR_TARGET["steps_per_s"]))
    return out


def _on_cores(one: dict[str, Any], shared: dict[str, Any], target: float) -> dict[str, Any]:
    """The "on N cores" figures of a target's size: the median stretches of one thread
    (``one``) and of a thread per core (``shared``) from :func:`_vector_rates`, their wall
    speed-up, whether the shared wall rate meets ``target`` (env steps/s) and the load
    average after them."""
    cores = shared["threads"]
    return {
        "repeats": TARGET_REPEATS,
        "steps_per_s_1_thread": one["steps_per_s"],
        "steps_per_cpu_s_1_thread": one["steps_per_cpu_s"],
        "steps_per_s_1_thread_range": [one["steps_per_s_lowest"], one["steps_per_s_highest"]],
        f"steps_per_s_{cores}_threads_range": [shared["steps_per_s_lowest"],
                                               shared["steps_per_s_highest"]],
        f"steps_per_s_{cores}_threads": shared["steps_per_s"],
        f"steps_per_cpu_s_{cores}_threads": shared["steps_per_cpu_s"],
        f"wall_speedup_{cores}_threads": shared["steps_per_s"] / one["steps_per_s"],
        f"meets_target_on_{cores}_cores": shared["steps_per_s"] >= target,
        "load_average_1min_after": os.getloadavg()[0]}
