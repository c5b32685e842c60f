"""Learning at scale without a GPU: the numpy cross-entropy method on the native vector env.

Every iteration flies its whole population (and the current mean) on the training
episodes at once, in one ``TrailDiverVectorEnv`` of (population + 1) x episodes
sub-environments; full 120 s episodes (480 steps) of ``uhrisim/TrailDiverState-v0``,
without pilings (the lesson is the trail). Then the learned linear policy, a random one
and the scenario's own helm (BHV_Trail on the Simulation, ``helm_episode``) are scored
on episodes none of them trained on.

    python examples/cem_vector_trail.py [--out docs/img/cem_vector_curve.png]

Prints the learning curve (return of the mean parameters and of the elite against env
steps), the wall time, and the evaluation; draws the curve. Needs the [gym] extra; the
[fast] extra (numba) makes the vector env faster.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from uhrisim.envs import TrailDiverEnv
from uhrisim.envs.cem import LinearPolicy, cross_entropy_search_vector, vector_returns
from uhrisim.envs.vector import TrailDiverVectorEnv

#: Inputs of the policy (state observation indices) and their scales: trail point
#: forward, starboard, down (m), diver speed (m/s), own surge (m/s).
FEATURES = (0, 1, 2, 8, 9)
SCALES = (2.0, 2.0, 1.0, 0.5, 0.5)
TRAIN_SEEDS = (11, 12, 13, 14)
TEST_SEEDS = (21, 22, 23, 24, 25, 26, 27, 28)
SETTINGS = {"randomization": {"clutter": 0}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/cem_vector_curve.png"))
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--population", type=int, default=48)
    parser.add_argument("--elite", type=int, default=8)
    args = parser.parse_args()

    vec = TrailDiverVectorEnv(num_envs=(args.population + 1) * len(TRAIN_SEEDS), **SETTINGS)
    policy = LinearPolicy(vec.single_action_space, FEATURES, SCALES)
    wall, cpu = time.perf_counter(), time.process_time()
    result = cross_entropy_search_vector(vec, policy, TRAIN_SEEDS, np.random.default_rng(1),
                                         args.iterations, args.population, args.elite)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"trained in {wall:.1f} s wall ({cpu:.1f} s CPU), {result.env_steps[-1]} env "
          f"steps, {vec.num_envs} episodes at a time")
    print("env steps, return of the mean, of the elite (training episodes, at most 480):")
    for steps, mean, elite in zip(result.env_steps, result.mean_scores, result.elite_scores,
                                  strict=True):
        print(f"  {steps:>9d}  {mean:7.1f}  {elite:7.1f}")

    test = TrailDiverVectorEnv(num_envs=len(TEST_SEEDS), **SETTINGS)
    learned, _ = vector_returns(test, policy, result.mean[None, :], TEST_SEEDS)
    random_returns = []
    rng = np.random.default_rng(0)
    for seed in TEST_SEEDS:  # seeded random actions on the same episodes
        test.reset(options={"episode_seeds": [seed] * len(TEST_SEEDS)})
        total, done = 0.0, False
        while not done:
            action = rng.uniform(test.single_action_space.low, test.single_action_space.high)
            _, reward, terminated, truncated, _ = test.step(
                np.tile(action, (len(TEST_SEEDS), 1)).astype(np.float32))
            total, done = total + reward[0], bool(terminated[0] or truncated[0])
        random_returns.append(total)
    helm_env = TrailDiverEnv("state", **SETTINGS)
    helm = np.mean([helm_env.helm_episode(episode_seed=s)["return"] for s in TEST_SEEDS])
    print(f"unseen episodes, mean return: learned {learned[0]:.1f}, random "
          f"{np.mean(random_returns):.1f}, the scenario's helm {helm:.1f}")
    plot(result, helm, float(np.mean(random_returns)), wall, args.out)
    print(f"wrote {args.out}")


def plot(result, helm: float, random: float, wall_s: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = np.array(result.env_steps) / 1e6
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(steps, result.mean_scores, "o-", label="CEM mean policy (training episodes)")
    ax.plot(steps, result.elite_scores, "s--", label="CEM elite (training episodes)")
    ax.axhline(helm, color="green", lw=1, label="scenario's helm (unseen episodes)")
    ax.axhline(random, color="grey", lw=1, label="random actions (unseen episodes)")
    ax.set_xlabel("env steps (millions)")
    ax.set_ylabel("return per 120 s episode (at most 480)")
    ax.set_title(f"CEM on the native vector env: {wall_s:.0f} s wall")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
