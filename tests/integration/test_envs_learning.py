"""The learning proof: the cross-entropy method over a linear policy (numpy only) learns
on TrailDiverState-v0 to trail the diver far better than a random policy, close to the
scenario's own helm (BHV_Trail), on episodes it never trained on."""

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the [gym] extra is not installed")

from uhrisim.envs import TrailDiverEnv
from uhrisim.envs.cem import LinearPolicy, cross_entropy_search, mean_return

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
    learned = mean_return(env, lambda obs: policy.act(result.mean, obs), TEST_SEEDS)
    env.action_space.seed(0)
    random = mean_return(env, lambda obs: env.action_space.sample(), TEST_SEEDS)
    helm = float(np.mean([env.helm_episode(episode_seed=s)["return"] for s in TEST_SEEDS]))
    # An episode's return is at most 80 (1 per step at the trail point); a random pilot
    # drifts off the trail point (or loses the diver), the helm stays near it.
    print(f"returns on unseen episodes: random {random:.1f}, CEM {learned:.1f}, "
          f"helm {helm:.1f}; CEM mean per iteration {np.round(result.mean_scores, 1)}")
    assert helm > 30.0
    assert learned > random + 30.0
    assert learned > 0.8 * helm, (learned, helm, result.mean_scores)
    assert result.mean_scores[-1] > result.mean_scores[0]
