"""examples/ppo_trail_diver.py on real environments: the native vector env stepped as
stable-baselines3 steps its vector envs, the evaluation, the helm's baseline and, where
torch and stable-baselines3 are installed (never by the suite), training with its
budget, checkpoints and resuming."""

import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the [gym] extra is not installed")

from tests.support.examples import EXAMPLES, load_example
from uhrisim.envs import TrailDiverEnv
from uhrisim.envs.cem import rollout
from uhrisim.envs.vector import TrailDiverVectorEnv

ppo = load_example("ppo_trail_diver")


def _events(step, actions, n_steps):
    """Per sub-environment, (observation, reward, done, last observation of the episode
    or None) of each step that is part of an episode."""
    rows = len(actions)
    events = [[] for _ in range(rows)]
    for _ in range(n_steps):
        obs, reward, done, last = step(actions)
        for i in range(rows):
            events[i].append((obs[i], reward[i], done[i], last[i]))
    return events


def test_same_step_reset_flies_the_episodes_of_the_next_step_autoreset():
    """The wrapper's sequences are the vector env's own (Gymnasium NEXT_STEP), less the
    step NEXT_STEP spends on a reset: at an episode's end the wrapper returns the next
    episode's first observation and keeps the last one in the infos."""
    kwargs = {"time_limit_s": 2.0, "lost_range_m": 4.5}  # 8 steps; some lost before
    seeds = [5, 6, 7, 8]
    unit = np.array([[0.0, 0.2, 0.0], [0.5, 1.0, -0.5], [-0.3, -1.0, 0.0],
                     [1.0, 0.0, 0.2]], dtype=np.float32)  # one action per row, each step

    wrapped = ppo.SameStepReset(TrailDiverVectorEnv(num_envs=4, **kwargs))
    first = wrapped.reset(seed=seeds)
    truncations = []

    def step_wrapped(actions):
        obs, reward, done, infos = wrapped.step(actions)
        truncations.extend(info["TimeLimit.truncated"] for info in infos if info)
        return obs, reward, done, [info.get("terminal_observation") for info in infos]

    mine = _events(step_wrapped, unit, 30)

    raw = TrailDiverVectorEnv(num_envs=4, **kwargs)
    np.testing.assert_array_equal(raw.reset(seed=seeds)[0], first)
    physical = ppo.ActionScale(raw.single_action_space)(unit)
    theirs = [[] for _ in seeds]
    ended = np.zeros(4, bool)
    for _ in range(40):
        obs, reward, terminated, truncated, _ = raw.step(physical)
        for i in range(4):
            if ended[i]:  # the spent step: the next episode's first observation
                last_obs, last_reward, _, _ = theirs[i][-1]
                theirs[i][-1] = (obs[i], last_reward, True, last_obs)
            else:
                theirs[i].append((obs[i], reward[i], False, None))
        ended = terminated | truncated

    endings = 0
    for i in range(4):
        assert len(theirs[i]) >= len(mine[i])
        for (o, r, d, last), (o2, r2, d2, last2) in zip(mine[i], theirs[i], strict=False):
            np.testing.assert_array_equal(o, o2)
            assert r == pytest.approx(r2, abs=1e-6) and d == d2
            if d:
                endings += 1
                np.testing.assert_array_equal(last, last2)
    assert endings >= 6 and truncations.count(True) >= 2 and truncations.count(False) >= 1


def _constant(obs):
    """Half speed ahead, heading and depth held (actions in [-1, 1], one per row)."""
    obs = np.asarray(obs)
    action = np.array([0.0, 0.0, 0.0], dtype=np.float32)
    return action if obs.ndim == 1 else np.tile(action, (len(obs), 1))


def test_evaluation_on_the_vector_env_scores_the_single_envs_episodes():
    kwargs = {"time_limit_s": 20.0, "randomization": {"clutter": 0}}
    result = ppo.evaluate(_constant, ppo.STATE_ENV, kwargs, [3, 4, 9])
    env = ppo.make_single_env(ppo.STATE_ENV, **kwargs)
    runs = np.array([rollout(env, _constant, s) for s in (3, 4, 9)])
    assert result.mean_return == pytest.approx(runs[:, 0].mean(), abs=1e-3)
    assert result.std_return == pytest.approx(runs[:, 0].std(), abs=1e-3)
    assert result.position_error_m == pytest.approx(runs[:, 1].mean(), abs=1e-4)


def test_the_helm_beats_a_policy_that_holds_still_and_is_computed_once(tmp_path):
    settings = {"pilings": 2, "eval_seeds": [3]}  # the env's own default clutter

    def hold_still(obs):  # heading change 0, speed 0, depth change 0
        return np.tile(np.array([0.0, -1.0, 0.0], np.float32), (len(obs), 1))

    still = ppo.evaluate(hold_still, ppo.STATE_ENV, ppo.env_kwargs(settings), [3])
    helm = ppo.helm_baseline(tmp_path, settings)
    reference = TrailDiverEnv("state", randomization={"clutter": 2}).helm_episode(
        episode_seed=3)
    assert helm.mean_return == pytest.approx(reference["return"])
    assert helm.position_error_m == pytest.approx(reference["mean_position_error_m"])
    assert helm.mean_return > still.mean_return + 10.0
    saved = json.loads((tmp_path / "helm.json").read_text())
    saved["helm"]["mean_return"] = 1234.5  # the file is read back, not recomputed
    (tmp_path / "helm.json").write_text(json.dumps(saved))
    assert ppo.helm_baseline(tmp_path, settings).mean_return == 1234.5
    assert ppo.helm_baseline(tmp_path, {"pilings": 0, "eval_seeds": [3]}).mean_return \
        != 1234.5  # other episodes: computed again


def _train(out, *argv):
    done = subprocess.run([sys.executable, str(EXAMPLES / "ppo_trail_diver.py"),
                           "--out", str(out), "--envs", "4", "--eval-seeds", "3",
                           *argv], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_training_checkpoints_resumes_and_keeps_to_its_budget(tmp_path):
    pytest.importorskip("stable_baselines3", reason="torch and stable-baselines3 are not "
                        "installed (examples/ppo_trail_diver.py says how)")
    out = tmp_path / "run"
    printed = _train(out, "--steps", "4096", "--eval-every", "2048", "--checkpoint-every",
                     "2048")
    assert "1 torch thread;" in printed and "helm" in printed
    assert [r["env_steps"] for r in ppo.read_curve(out / "curve.csv")] == [0, 2048, 4096]
    assert ppo.latest_checkpoint(out)[1] == 4096 and (out / "best.zip").exists()
    printed = _train(out, "--resume", "--steps", "6144", "--eval-every", "2048",
                     "--checkpoint-every", "2048")
    assert "resuming from" in printed
    rows = ppo.read_curve(out / "curve.csv")
    assert [r["env_steps"] for r in rows] == [0, 2048, 4096, 6144]
    assert rows[3]["wall_s"] > rows[2]["wall_s"]
    assert ppo.latest_checkpoint(out)[1] == 6144 and (out / "curve.png").exists()
    # a budget far short of the steps: stops, evaluates and saves where it stopped
    short = tmp_path / "short"
    _train(short, "--minutes", "0.1", "--steps", "10000000")
    steps = ppo.latest_checkpoint(short)[1]
    assert 0 < steps < 10_000_000
    assert ppo.read_curve(short / "curve.csv")[-1]["env_steps"] == steps
