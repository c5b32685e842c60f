"""Train stable-baselines3's PPO to trail a diver on the CPU, within a wall-clock budget.

Install a CPU-only torch first, then stable-baselines3 (a plain ``pip install
stable-baselines3`` pulls a CUDA build of torch of several GB; uhrisim's tests never
install either):

    pip install torch --index-url https://download.pytorch.org/whl/cpu
    pip install "uhrisim[gym,rl]"

Train for ten minutes of wall time, then go on from the last checkpoint for ten more:

    python examples/ppo_trail_diver.py --minutes 10 --out out/ppo
    python examples/ppo_trail_diver.py --minutes 10 --out out/ppo --resume

Every ``--eval-every`` env steps the deterministic policy flies the fixed evaluation
episodes (``--eval-seeds``, never trained on), and one line reports its mean return and
distance from the trail point beside the scenario's own helm's (BHV_Trail) on the same
episodes, which are computed once and kept in OUT/helm.json. Every ``--checkpoint-every``
env steps the model (policy, optimizer, observation statistics) goes to OUT/checkpoints/;
the best evaluated one to OUT/best.zip. The learning curve is OUT/curve.csv and
OUT/curve.png. When the budget runs out the run stops at the next env step, keeping
back the time its last evaluation took, so the final checkpoint, evaluation and plot
also fit in it.

Torch's threads are pinned (``--threads``, default 1; docs/envs.md has the measured
effect). ``TrailDiverState-v0`` runs on the native vector env (one process, all episodes
as arrays; ``--vector process`` for Gymnasium-style envs in worker processes, as the
sonar env ``--env uhrisim/TrailDiver-v0`` needs, with PPO's "MultiInputPolicy").
Everything but :func:`train` runs without torch (tests/integration/test_envs_ppo_example.py).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

STATE_ENV, SONAR_ENV = "uhrisim/TrailDiverState-v0", "uhrisim/TrailDiver-v0"
#: Unseen evaluation episodes: those of examples/cem_vector_trail.py, so that the helm's
#: score and the CEM's are on the same episodes.
EVAL_SEEDS = (21, 22, 23, 24, 25, 26, 27, 28)
#: PPO's settings (stable-baselines3 names); ``n_steps`` is per sub-environment.
PPO_SETTINGS = {"n_steps": 256, "batch_size": 512, "n_epochs": 10, "learning_rate": 3e-4,
                "gamma": 0.98, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0}
THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
CURVE_FIELDS = ("env_steps", "wall_s", "eval_return", "eval_return_std",
                "eval_position_error_m", "helm_return", "helm_position_error_m",
                "train_episode_return", "steps_per_s")
#: What a run is (kept in OUT/run.json; a resumed run takes them from there).
RUN_SETTINGS = ("env", "vector", "envs", "pilings", "seed", "eval_seeds", "ppo")


class RunError(Exception):
    """A bad command line or output folder; ``main`` prints it as one line."""


# -- the command line ---------------------------------------------------------------------
def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text}")
    return value


def positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text}")
    return value


def seed_list(text: str) -> tuple[int, ...]:
    try:
        seeds = tuple(int(s) for s in text.split(",") if s.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be comma-separated integers, got {text!r}") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"must be non-negative integers, got {text!r}")
    return seeds


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=positive_float, default=None,
                        help="wall-clock budget of this invocation (default: none)")
    parser.add_argument("--steps", type=positive_int, default=10_000_000,
                        help="stop at this many env steps in all (default 10 000 000)")
    parser.add_argument("--out", type=Path, default=Path("out/ppo"))
    parser.add_argument("--resume", action="store_true",
                        help="go on from OUT's last checkpoint, with OUT/run.json's settings")
    parser.add_argument("--eval-every", type=positive_int, default=50_000, help="env steps")
    parser.add_argument("--checkpoint-every", type=positive_int, default=100_000,
                        help="env steps")
    parser.add_argument("--keep", type=positive_int, default=3,
                        help="checkpoints kept (the latest; OUT/best.zip besides)")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch threads (0: torch's default, one per core)")
    parser.add_argument("--env", choices=(STATE_ENV, SONAR_ENV), default=STATE_ENV)
    parser.add_argument("--vector", choices=("native", "process"), default="native",
                        help="native: TrailDiverVectorEnv in this process (state env only); "
                             "process: one env per worker process (SB3's SubprocVecEnv)")
    parser.add_argument("--envs", type=positive_int, default=64,
                        help="sub-environments (worker processes with --vector process)")
    parser.add_argument("--pilings", type=int, default=0,
                        help="random pilings per episode (the env's default is 2; 0 as "
                             "examples/cem_vector_trail.py)")
    parser.add_argument("--eval-seeds", type=seed_list, default=EVAL_SEEDS,
                        help="comma-separated episode seeds of the evaluation")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.threads < 0:
        parser.error(f"argument --threads: must be >= 0, got {args.threads}")
    if args.pilings < 0:
        parser.error(f"argument --pilings: must be >= 0, got {args.pilings}")
    if args.env == SONAR_ENV and args.vector == "native":
        parser.error("the native vector env has the state observation only: use "
                     "--vector process with the sonar env")
    return args


def run_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The settings that make a run (OUT/run.json), as JSON values."""
    return {"env": args.env, "vector": args.vector, "envs": args.envs,
            "pilings": args.pilings, "seed": args.seed, "eval_seeds": list(args.eval_seeds),
            "ppo": dict(PPO_SETTINGS)}


def env_kwargs(settings: dict[str, Any]) -> dict[str, Any]:
    """The env's constructor arguments of a run."""
    return {"randomization": {"clutter": settings["pilings"]}}


# -- the output folder: settings, checkpoints, learning curve ------------------------------
def checkpoint_path(out: Path, steps: int) -> Path:
    return out / "checkpoints" / f"ppo_{steps:010d}.zip"


def statistics_path(model_path: Path) -> Path:
    """The observation statistics (SB3's VecNormalize) saved beside a model file."""
    return model_path.with_name(model_path.stem + "_vecnormalize.pkl")


def checkpoints(out: Path) -> list[tuple[int, Path]]:
    """The complete checkpoints in OUT/checkpoints (model and statistics), as (env steps,
    model file), fewest steps first."""
    found = []
    for path in (out / "checkpoints").glob("ppo_*.zip"):
        digits = path.stem.removeprefix("ppo_")
        if digits.isdigit() and statistics_path(path).exists():
            found.append((int(digits), path))
    return sorted(found)


def latest_checkpoint(out: Path) -> tuple[Path, int] | None:
    """The checkpoint with the most env steps in OUT/checkpoints and its steps, or None."""
    found = checkpoints(out)
    return (found[-1][1], found[-1][0]) if found else None


def prune_checkpoints(out: Path, keep: int) -> None:
    """Delete all but the ``keep`` latest checkpoints."""
    for _, path in checkpoints(out)[:-keep]:
        path.unlink()
        statistics_path(path).unlink()


def prepare_run(args: argparse.Namespace) -> tuple[dict[str, Any], tuple[Path, int] | None]:
    """The run's settings and, with ``--resume``, the checkpoint to start from; OUT/run.json
    written for a new run. A new run refuses an OUT that holds one already."""
    out, settings_file = args.out, args.out / "run.json"
    if not args.resume:
        if settings_file.exists() or latest_checkpoint(out) is not None:
            raise RunError(f"{out} already holds a run: add --resume to go on with it, or "
                           "choose another --out")
        settings = run_settings(args)
        out.mkdir(parents=True, exist_ok=True)
        settings_file.write_text(json.dumps(settings, indent=1) + "\n")
        return settings, None
    checkpoint = latest_checkpoint(out)
    if checkpoint is None or not settings_file.exists():
        raise RunError(f"nothing to resume in {out}: no run.json or no checkpoint in "
                       f"{out / 'checkpoints'}")
    try:
        settings = json.loads(settings_file.read_text())
    except json.JSONDecodeError as error:
        raise RunError(f"{settings_file}:{error.lineno}: not JSON ({error.msg})") from None
    missing = [k for k in RUN_SETTINGS if k not in settings]
    if missing:
        raise RunError(f"{settings_file}: missing {', '.join(missing)}")
    truncate_curve(out / "curve.csv", checkpoint[1])
    return settings, checkpoint


def read_curve(path: Path) -> list[dict[str, float]]:
    """The learning curve's rows (OUT/curve.csv), numbers as floats; [] if there is none."""
    if not path.exists():
        return []
    with path.open(newline="") as file:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(file)]


def append_curve(path: Path, row: dict[str, float]) -> None:
    new = not path.exists()
    with path.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=CURVE_FIELDS)
        if new:
            writer.writeheader()
        writer.writerow({k: row[k] for k in CURVE_FIELDS})


def truncate_curve(path: Path, steps: int) -> None:
    """Drop the rows after ``steps`` env steps (those of a run after its last checkpoint)."""
    rows = [r for r in read_curve(path) if r["env_steps"] <= steps]
    path.unlink(missing_ok=True)
    for row in rows:
        append_curve(path, row)


# -- time and the schedule of evaluations and checkpoints ----------------------------------
@dataclass
class Schedule:
    """When to evaluate, save and stop. ``budget_s``: wall seconds from ``started`` (a
    ``clock()`` reading); ``reserve_s``: what the work after the stop is expected to take
    (the last evaluation's duration), kept back from the budget; ``last_eval`` and
    ``last_checkpoint``: env steps of the last evaluation and checkpoint (a new run's
    start: 0; a resumed run's: its checkpoint's)."""

    eval_every: int
    checkpoint_every: int
    max_steps: int
    budget_s: float | None
    clock: Callable[[], float] = time.monotonic
    started: float | None = None
    reserve_s: float = 0.0
    last_eval: int = 0
    last_checkpoint: int = 0

    def __post_init__(self) -> None:
        if self.started is None:
            self.started = self.clock()

    def elapsed_s(self) -> float:
        return self.clock() - self.started

    def out_of_time(self) -> bool:
        return self.budget_s is not None and self.elapsed_s() + self.reserve_s >= self.budget_s

    def should_stop(self, steps: int) -> bool:
        return steps >= self.max_steps or self.out_of_time()

    def evaluation_due(self, steps: int) -> bool:
        """True when ``steps`` reached a multiple of ``eval_every`` not yet evaluated."""
        return _crossed(steps, self.last_eval, self.eval_every)

    def checkpoint_due(self, steps: int) -> bool:
        return _crossed(steps, self.last_checkpoint, self.checkpoint_every)


def _crossed(steps: int, last: int, every: int) -> bool:
    return steps // every > last // every


def progress_line(row: dict[str, float], best: float) -> str:
    """One line of progress after an evaluation (a row of the curve)."""
    minutes, seconds = divmod(int(row["wall_s"]), 60)
    helm = row["helm_return"]
    share = (f" (PPO at {100 * row['eval_return'] / helm:.0f} % of it)"
             if helm > 0 and row["eval_return"] > 0 else "")
    trained = row["train_episode_return"]
    return (f"{int(row['env_steps']):>10,d} steps {minutes:3d}:{seconds:02d} "
            f"{row['steps_per_s']:6.0f} steps/s | evaluation return {row['eval_return']:6.1f}"
            f" ± {row['eval_return_std']:5.1f}, {row['eval_position_error_m']:.2f} m from the "
            f"trail point | helm {helm:.1f}, {row['helm_position_error_m']:.2f} m{share} | "
            f"best {best:.1f} | training episodes "
            f"{'-' if np.isnan(trained) else f'{trained:.1f}'}")


# -- the environments ---------------------------------------------------------------------
class ActionScale:
    """PPO's actions in [-1, 1] mapped linearly onto the env's action box."""

    def __init__(self, space: Any) -> None:
        self.low, self.high = space.low, space.high

    def __call__(self, actions: np.ndarray) -> np.ndarray:
        unit = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
        return (self.low + 0.5 * (unit + 1.0) * (self.high - self.low)).astype(np.float32)


class SameStepReset:
    """:class:`~uhrisim.envs.vector.TrailDiverVectorEnv` stepped the way stable-baselines3
    steps its vector envs: actions in [-1, 1] (:class:`ActionScale`), and an episode that
    ends is reset in the same step, its row of the observation being the next episode's
    first and its last observation in ``infos[i]["terminal_observation"]`` with
    ``"TimeLimit.truncated"`` (Gymnasium's NEXT_STEP autoreset spends a step instead)."""

    def __init__(self, vec: Any) -> None:
        self.vec, self.num_envs = vec, vec.num_envs
        self.scale = ActionScale(vec.single_action_space)

    def reset(self, seed: int | None = None) -> np.ndarray:
        return self.vec.reset(seed=seed)[0]

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 list[dict[str, Any]]]:
        obs, reward, terminated, truncated, _ = self.vec.step(self.scale(actions))
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if done.any():
            for i in np.flatnonzero(done):
                infos[i] = {"terminal_observation": obs[i].copy(),
                            "TimeLimit.truncated": bool(truncated[i] and not terminated[i])}
            obs = self.vec.reset(options={"reset_mask": done})[0]
        return obs, reward.astype(np.float32), done, infos


def make_single_env(env_id: str, **kwargs: Any) -> Any:
    """One env (``--vector process``) with its action box rescaled to [-1, 1]."""
    import gymnasium

    import uhrisim.envs  # noqa: F401  (registers the ids)

    env = gymnasium.make(env_id, **kwargs)
    ones = np.ones(env.action_space.shape, dtype=np.float32)
    return gymnasium.wrappers.RescaleAction(env, -ones, ones)


@dataclass
class Evaluation:
    """Mean and spread of the return, and the mean distance (m) from the trail point, over
    the evaluation episodes."""

    mean_return: float
    std_return: float
    position_error_m: float


def evaluate(predict: Callable[[np.ndarray], np.ndarray], env_id: str,
             kwargs: dict[str, Any], seeds: Sequence[int]) -> Evaluation:
    """Fly the episodes of ``seeds`` with ``predict`` (observations -> actions in [-1, 1]):
    the state env's all at once on the native vector env, the sonar env's one by one."""
    if env_id == STATE_ENV:
        from uhrisim.envs.vector import TrailDiverVectorEnv

        vec = TrailDiverVectorEnv(num_envs=len(seeds), **kwargs)
        scale = ActionScale(vec.single_action_space)
        obs, _ = vec.reset(options={"episode_seeds": [int(s) for s in seeds]})
        n = len(seeds)
        returns, errors, steps, done = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, bool)
        while not done.all():
            obs, reward, terminated, truncated, info = vec.step(scale(predict(obs)))
            live = ~done
            returns[live] += reward[live]
            errors[live] += info["position_error_m"][live]
            steps[live] += 1
            done |= terminated | truncated
        errors /= steps
    else:
        from uhrisim.envs.cem import rollout

        env = make_single_env(env_id, **kwargs)
        runs = np.array([rollout(env, predict, s) for s in seeds])
        returns, errors = runs[:, 0], runs[:, 1]
    return Evaluation(float(np.mean(returns)), float(np.std(returns)), float(np.mean(errors)))


def helm_baseline(out: Path, settings: dict[str, Any]) -> Evaluation:
    """The scenario's own helm on the evaluation episodes (OUT/helm.json, computed once)."""
    path = out / "helm.json"
    key = {"env_kwargs": env_kwargs(settings), "eval_seeds": settings["eval_seeds"]}
    if path.exists():
        saved = json.loads(path.read_text())
        if saved.get("key") == key:
            return Evaluation(**saved["helm"])
    from uhrisim.envs import TrailDiverEnv

    env = TrailDiverEnv("state", **env_kwargs(settings))
    runs = [env.helm_episode(episode_seed=s) for s in settings["eval_seeds"]]
    returns = [r["return"] for r in runs]
    helm = Evaluation(float(np.mean(returns)), float(np.std(returns)),
                      float(np.mean([r["mean_position_error_m"] for r in runs])))
    path.write_text(json.dumps({"key": key, "helm": helm.__dict__}, indent=1) + "\n")
    return helm


# -- the figure ---------------------------------------------------------------------------
def plot_curve(rows: Sequence[dict[str, float]], path: Path, title: str) -> None:
    """Evaluation return (mean ± std over the episodes) against env steps and against
    wall minutes, with the helm's on the same episodes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = np.array([r["env_steps"] for r in rows]) / 1e6
    minutes = np.array([r["wall_s"] for r in rows]) / 60.0
    mean = np.array([r["eval_return"] for r in rows])
    std = np.array([r["eval_return_std"] for r in rows])
    trained = np.array([r["train_episode_return"] for r in rows])
    helm = rows[-1]["helm_return"]
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.0), sharey=True)
    for ax, x, label in ((axes[0], steps, "env steps (millions)"),
                         (axes[1], minutes, "wall time (minutes)")):
        ax.fill_between(x, mean - std, mean + std, color="C0", alpha=0.2, lw=0)
        ax.plot(x, mean, "o-", ms=3, color="C0", label="PPO, evaluation episodes (± std)")
        ax.plot(x, trained, "-", lw=1, color="C1",
                label="PPO, training episodes (stochastic)")
        ax.axhline(helm, color="green", lw=1.2,
                   label=f"scenario's helm, same episodes ({helm:.0f})")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("return per 120 s episode (at most 480)")
    axes[0].legend(fontsize=8, loc="lower right")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- training (the only part that needs torch) --------------------------------------------
def pin_threads(threads: int) -> None:
    """Torch's (and its BLAS's) thread count, set before torch is imported; 0 leaves
    torch's default (one per core)."""
    if threads > 0:
        for name in THREAD_VARIABLES:
            os.environ[name] = str(threads)


def threads_text(threads: int) -> str:
    return ("torch's default threads" if threads == 0
            else f"{threads} torch thread{'s' if threads > 1 else ''}")


def train(args: argparse.Namespace, started: float) -> None:
    """Train, evaluate and save as the module docstring says; the budget counts from
    ``started`` (a ``time.monotonic()`` reading)."""
    settings, checkpoint = prepare_run(args)
    pin_threads(args.threads)
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.vec_env import VecMonitor, VecNormalize
    except ImportError as error:
        raise RunError(f"{error.name} is missing: pip install torch --index-url "
                       "https://download.pytorch.org/whl/cpu, then pip install "
                       "stable-baselines3") from None
    if args.threads > 0:
        torch.set_num_threads(args.threads)
        torch.set_num_interop_threads(1)
    schedule = Schedule(args.eval_every, args.checkpoint_every, args.steps,
                        None if args.minutes is None else 60.0 * args.minutes,
                        started=started)
    out, curve_file = args.out, args.out / "curve.csv"
    print(f"torch {torch.__version__}, {threads_text(torch.get_num_threads())}; {settings['envs']} "
          f"{settings['vector']} sub-environments of {settings['env']}; output in {out}",
          flush=True)
    kwargs = env_kwargs(settings)
    print(f"the helm on the {len(settings['eval_seeds'])} evaluation episodes ...", flush=True)
    helm = helm_baseline(out, settings)
    vec = VecMonitor(_training_envs(settings, kwargs))
    if checkpoint is None:
        vec = VecNormalize(vec, gamma=settings["ppo"]["gamma"])
        model = PPO("MultiInputPolicy" if settings["env"] == SONAR_ENV else "MlpPolicy", vec,
                    seed=settings["seed"], device="cpu", verbose=0, **settings["ppo"])
    else:
        path, steps = checkpoint
        print(f"resuming from {path} ({steps} env steps)", flush=True)
        vec = VecNormalize.load(str(statistics_path(path)), vec)
        model = PPO.load(path, env=vec, device="cpu")
        vec.seed(settings["seed"] + steps)  # fresh training episodes, not the first ones
        schedule.last_eval = schedule.last_checkpoint = steps
    rows = read_curve(curve_file)
    wall_before = rows[-1]["wall_s"] if rows else 0.0
    best = max((r["eval_return"] for r in rows), default=-np.inf)
    steps_at_start, learning_started = model.num_timesteps, None

    def save(steps: int) -> None:
        path = checkpoint_path(out, steps)
        path.parent.mkdir(parents=True, exist_ok=True)
        model.save(path)
        vec.save(str(statistics_path(path)))
        schedule.last_checkpoint = steps
        prune_checkpoints(out, args.keep)

    def evaluate_now(steps: int) -> None:
        nonlocal best
        began = schedule.clock()
        result = evaluate(lambda obs: model.predict(vec.normalize_obs(obs),
                                                    deterministic=True)[0],
                          settings["env"], kwargs, settings["eval_seeds"])
        trained = [e["r"] for e in model.ep_info_buffer] if model.ep_info_buffer else []
        elapsed = schedule.elapsed_s()
        row = {"env_steps": steps, "wall_s": wall_before + elapsed,
               "eval_return": result.mean_return, "eval_return_std": result.std_return,
               "eval_position_error_m": result.position_error_m,
               "helm_return": helm.mean_return, "helm_position_error_m": helm.position_error_m,
               "train_episode_return": float(np.mean(trained)) if trained else float("nan"),
               "steps_per_s": 0.0 if learning_started is None else
               (steps - steps_at_start) / max(schedule.clock() - learning_started, 1e-9)}
        if result.mean_return > best:
            best = result.mean_return
            model.save(out / "best.zip")
            vec.save(str(statistics_path(out / "best.zip")))
        append_curve(curve_file, row)
        schedule.last_eval = steps
        schedule.reserve_s = schedule.clock() - began
        print(progress_line(row, best), flush=True)

    class Progress(BaseCallback):
        def _on_step(self) -> bool:
            steps = self.model.num_timesteps
            if schedule.evaluation_due(steps):
                evaluate_now(steps)
            if schedule.checkpoint_due(steps):
                save(steps)
            return not schedule.should_stop(steps)

    if checkpoint is None:
        evaluate_now(0)
    learning_started = schedule.clock()
    if model.num_timesteps < args.steps:
        model.learn(total_timesteps=args.steps - model.num_timesteps, callback=Progress(),
                    reset_num_timesteps=False)
    steps = model.num_timesteps
    if schedule.last_eval != steps:
        evaluate_now(steps)
    if schedule.last_checkpoint != steps:
        save(steps)
    vec.close()
    rows = read_curve(curve_file)
    plot_curve(rows, out / "curve.png",
               f"PPO on {settings['env']}: {int(steps):,d} env steps in "
               f"{rows[-1]['wall_s'] / 60:.1f} min wall ({settings['envs']} {settings['vector']} "
               f"envs, {threads_text(args.threads)})")
    print(f"stopped after {schedule.elapsed_s():.0f} s at {steps} env steps; wrote "
          f"{curve_file}, {out / 'curve.png'}, {checkpoint_path(out, steps)}", flush=True)


def _training_envs(settings: dict[str, Any], kwargs: dict[str, Any]) -> Any:
    """The training sub-environments as a stable-baselines3 VecEnv."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecEnv

    if settings["vector"] == "process":
        return make_vec_env(make_single_env, n_envs=settings["envs"], seed=settings["seed"],
                            vec_env_cls=SubprocVecEnv,
                            env_kwargs={"env_id": settings["env"], **kwargs})
    from gymnasium import spaces

    from uhrisim.envs.vector import TrailDiverVectorEnv

    class NativeVecEnv(VecEnv):
        """:class:`SameStepReset` as a stable-baselines3 VecEnv."""

        def __init__(self) -> None:
            self.native = SameStepReset(TrailDiverVectorEnv(num_envs=settings["envs"],
                                                            **kwargs))
            single = self.native.vec.single_action_space
            unit = spaces.Box(-1.0, 1.0, single.shape, np.float32)
            super().__init__(settings["envs"], self.native.vec.single_observation_space, unit)
            self._next_seed: int | None = settings["seed"]

        def reset(self) -> np.ndarray:
            obs = self.native.reset(seed=self._next_seed)
            self._next_seed = None
            return obs

        def seed(self, seed: int | None = None) -> list[int | None]:
            self._next_seed = seed
            return [None if seed is None else seed + i for i in range(self.num_envs)]

        def step_async(self, actions: np.ndarray) -> None:
            self._actions = actions

        def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
            return self.native.step(self._actions)

        def close(self) -> None:
            self.native.vec.close()

        def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
            value = None if attr_name == "render_mode" else getattr(self.native.vec,
                                                                     attr_name)
            return [value for _ in self._get_indices(indices)]

        def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
            raise AttributeError(f"the native vector env has no per-env attribute "
                                 f"{attr_name!r}")

        def env_method(self, method_name: str, *args: Any, indices: Any = None,
                       **kwargs: Any) -> list[Any]:
            raise AttributeError(f"the native vector env has no per-env method "
                                 f"{method_name!r}")

        def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
            return [False for _ in self._get_indices(indices)]

    return NativeVecEnv()


def main(argv: Sequence[str] | None = None) -> None:
    started = time.monotonic()
    args = parse_args(argv)
    try:
        train(args, started)
    except RunError as error:
        sys.exit(f"ppo_trail_diver: {error}")


if __name__ == "__main__":
    main()
