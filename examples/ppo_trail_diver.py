"""Train stable-baselines3's PPO to trail a diver (uhrisim/TrailDiverState-v0).

Needs torch (not installed by uhrisim or its tests):

    pip install "uhrisim[gym]" stable-baselines3
    python examples/ppo_trail_diver.py --steps 200000 --envs 4 --out out/ppo

then compares the policy with the scenario's own helm on the same held-out episodes.
For the sonar observation use ``--env uhrisim/TrailDiver-v0`` (a Dict observation: PPO's
"MultiInputPolicy" is chosen for it).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium
import numpy as np

import uhrisim.envs  # noqa: F401  (registers the ids)


def make_env(env_id: str, **kwargs):
    """The environment with its action box rescaled to [-1, 1], which PPO prefers."""
    env = gymnasium.make(env_id, **kwargs)
    ones = np.ones(env.action_space.shape, dtype=np.float32)
    return gymnasium.wrappers.RescaleAction(env, -ones, ones)


def evaluate(model, env_id: str, episode_seeds: list[int]) -> tuple[float, float]:
    """Mean return of the policy and of the scenario's helm on the same episodes."""
    env = make_env(env_id)
    policy, helm = [], []
    for seed in episode_seeds:
        obs, _ = env.reset(options={"episode_seed": seed})
        total, done = 0.0, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += reward
            done = terminated or truncated
        policy.append(total)
        helm.append(env.unwrapped.helm_episode(episode_seed=seed)["return"])
    return float(np.mean(policy)), float(np.mean(helm))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="uhrisim/TrailDiverState-v0")
    parser.add_argument("--steps", type=int, default=200_000)
    parser.add_argument("--envs", type=int, default=4, help="async vector env workers")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("out/ppo"))
    args = parser.parse_args()

    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    vec = make_vec_env(make_env, n_envs=args.envs, seed=args.seed,
                       vec_env_cls=SubprocVecEnv, env_kwargs={"env_id": args.env})
    policy = "MultiInputPolicy" if args.env == "uhrisim/TrailDiver-v0" else "MlpPolicy"
    model = PPO(policy, vec, n_steps=512, batch_size=256, gamma=0.98, seed=args.seed,
                verbose=1)
    model.learn(total_timesteps=args.steps)
    args.out.mkdir(parents=True, exist_ok=True)
    model.save(args.out / "ppo_trail_diver")
    learned, helm = evaluate(model, args.env, episode_seeds=[101, 102, 103, 104, 105])
    print(f"mean return on 5 held-out episodes: PPO {learned:.1f}, helm {helm:.1f}")


if __name__ == "__main__":
    main()
