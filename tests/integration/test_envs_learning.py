"""The learning proof: the cross-entropy method over a linear policy (numpy only) learns
on TrailDiverState-v0 to trail the diver far better than a random policy, close to the
scenario's own helm (BHV_Trail), on episodes it never trained on."""

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the [gym] extra is not installed")

from uhrisim.envs import TrailDiverEnv
from uhrisim.envs.cem import LinearPolicy, cross_entropy_search, mean_return, rollout

TRAIN_SEEDS = (11, 12)
TEST_SEEDS = (21, 22, 23)
#: Inputs of the policy (state observation indices) and their scales: trail point
#: forward, starboard, down (m), diver speed (m/s), own surge (m/s).
FEATURES = (0, 1, 2, 8, 9)
SCALES = (2.0, 2.0, 1.0, 0.5, 0.5)


def test_cem_linear_policy_beats_random_and_nears_the_helm():
    # 20 s episodes (80 steps); no clutter: the lesson is the trail, not obstacle avoidance
    env = TrailDiverEnv("state", time_limit_s=20.0, randomization={"clutter": 0})
    policy = LinearPolicy(env.action_space, FEATURES, SCALES)
    result = cross_entropy_search(
        lambda params: mean_return(env, lambda obs: policy.act(params, obs), TRAIN_SEEDS),
        policy.size, np.random.default_rng(1), iterations=6, population=12, elite=3)
    learned, learned_error = np.mean(
        [rollout(env, lambda obs: policy.act(result.mean, obs), s) for s in TEST_SEEDS], axis=0)
    env.action_space.seed(0)
    random, random_error = np.mean(
        [rollout(env, lambda obs: env.action_space.sample(), s) for s in TEST_SEEDS], axis=0)
    helm_runs = [env.helm_episode(episode_seed=s) for s in TEST_SEEDS]
    helm = np.mean([r["return"] for r in helm_runs])
    helm_error = np.mean([r["mean_position_error_m"] for r in helm_runs])
    # An episode's return is at most 80 (1 per step at the trail point); a random pilot
    # drifts off the trail point (or loses the diver), the helm stays near it.
    print(f"unseen episodes, return / mean distance from the trail point: random "
          f"{random:.1f} / {random_error:.2f} m, CEM {learned:.1f} / {learned_error:.2f} m, "
          f"helm {helm:.1f} / {helm_error:.2f} m; CEM per iteration "
          f"{np.round(result.mean_scores, 1)}")
    assert helm > 30.0
    assert learned > random + 30.0 and learned_error < 0.5 * random_error
    assert learned > 0.8 * helm and learned_error < helm_error + 0.5
    assert result.mean_scores[-1] > result.mean_scores[0]


def test_cem_on_the_native_vector_env_learns_the_trail():
    """The same search with each iteration's population flown at once in the native
    vector env (population + mean) x training episodes: the learned policy beats random
    actions and nears the helm on unseen episodes (examples/cem_vector_trail.py runs it
    at full scale: 120 s episodes, docs/envs.md)."""
    from uhrisim.envs.cem import cross_entropy_search_vector, vector_returns
    from uhrisim.envs.vector import TrailDiverVectorEnv

    settings = {"time_limit_s": 20.0, "randomization": {"clutter": 0}}
    population = 32
    vec = TrailDiverVectorEnv(num_envs=(population + 1) * len(TRAIN_SEEDS), **settings)
    policy = LinearPolicy(vec.single_action_space, FEATURES, SCALES)
    result = cross_entropy_search_vector(vec, policy, TRAIN_SEEDS, np.random.default_rng(1),
                                         iterations=10, population=population, elite=6)
    assert result.env_steps == sorted(result.env_steps) and result.env_steps[0] > 0
    test = TrailDiverVectorEnv(num_envs=len(TEST_SEEDS), **settings)
    learned = float(vector_returns(test, policy, result.mean[None, :], TEST_SEEDS)[0][0])
    still = float(vector_returns(test, policy, np.zeros((1, policy.size)), TEST_SEEDS)[0][0])
    single = TrailDiverEnv("state", **settings)
    # the vector env's episodes are the single env's: the learned policy scores the same
    assert learned == pytest.approx(np.mean([rollout(
        single, lambda obs: policy.act(result.mean, obs), s)[0] for s in TEST_SEEDS]),
        abs=1e-6)
    helm = np.mean([single.helm_episode(episode_seed=s)["return"] for s in TEST_SEEDS])
    print(f"vector CEM: learned {learned:.1f}, all-zero policy {still:.1f}, helm {helm:.1f}; "
          f"per iteration {np.round(result.mean_scores, 1)} after {result.env_steps}")
    assert learned > still + 30.0 and learned > 0.8 * helm
