"""The native vector env (uhrisim.envs.vector): N episodes as arrays in one process, held
to N single envs (the ordinary Simulation) on the same seeds, step for step."""

import math

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium", reason="the [gym] extra is not installed")

from uhrisim.envs import EnvArgumentError, Randomization, TrailDiverEnv  # noqa: E402
from uhrisim.envs.task import REWARD_TERMS  # noqa: E402
from uhrisim.envs.vector import TrailDiverVectorEnv  # noqa: E402
from uhrisim.scenario.schema import CylinderObject  # noqa: E402
from uhrisim.scenario.shipped import shipped_scenario  # noqa: E402


def _ram(obs):
    """Full ahead at the diver: ends in a collision with it."""
    return np.array([math.atan2(obs[4], obs[3]), 1.0, obs[5]], dtype=np.float32)


def _dive(obs):
    """Slowly ahead and ever deeper: ends on the sea floor."""
    del obs
    return np.array([0.0, 0.3, 2.0], dtype=np.float32)


def _fly_both(seeds, steps, policy=None, **kwargs):
    """Step a vector env and one single env per seed with the same actions (seeded random
    ones, or ``policy(obs)``) and compare every step; when a single episode ends, the
    vector env's next step (autoreset, NEXT_STEP) must be the single env's next
    ``reset()``. Returns how the first episode of each seed ended."""
    vec = TrailDiverVectorEnv(num_envs=len(seeds), **kwargs)
    singles = [TrailDiverEnv("state", **kwargs) for _ in seeds]
    v_obs, v_info = vec.reset(seed=seeds)
    obs = [env.reset(seed=s)[0] for env, s in zip(singles, seeds, strict=True)]
    np.testing.assert_array_equal(v_obs, np.array(obs))
    np.testing.assert_array_equal(v_info["episode_seed"],
                                  [env._episode_seed for env in singles])
    vec.action_space.seed(seeds[0])
    endings, ended = {}, [False] * len(seeds)
    for _ in range(steps):
        actions = (vec.action_space.sample() if policy is None
                   else np.stack([policy(o) for o in obs]))
        v_obs, v_reward, v_term, v_trunc, v_info = vec.step(actions)
        for i, env in enumerate(singles):
            if ended[i]:  # the vector env reset this one: the single env's next episode
                obs[i], _ = env.reset()
                assert v_info["episode_seed"][i] == env._episode_seed
                np.testing.assert_array_equal(v_obs[i], obs[i])
                assert v_reward[i] == 0.0 and not v_term[i] and not v_trunc[i]
                ended[i] = False
                continue
            obs[i], reward, terminated, truncated, info = env.step(actions[i])
            np.testing.assert_array_equal(v_obs[i], obs[i])
            assert v_reward[i] == pytest.approx(reward, abs=1e-12)
            assert (v_term[i], v_trunc[i]) == (terminated, truncated)
            for term in REWARD_TERMS:
                assert v_info["reward_terms"][term][i] == pytest.approx(
                    info["reward_terms"][term], abs=1e-12)
            assert v_info["position_error_m"][i] == pytest.approx(info["position_error_m"],
                                                                 abs=1e-12)
            if terminated or truncated:
                endings.setdefault(i, info["termination"] or "truncated")
                assert v_info["termination"][i] == info["termination"]
                ended[i] = True
    return endings


def test_make_vec_gives_the_native_vector_env():
    vec = gymnasium.make_vec("uhrisim/TrailDiverState-v0", num_envs=3,
                             vectorization_mode="vector_entry_point", time_limit_s=5.0)
    assert isinstance(vec, TrailDiverVectorEnv) and vec.num_envs == 3
    obs, info = vec.reset(seed=1)
    assert obs.shape == (3, 14) and obs.dtype == np.float32 and obs in vec.observation_space
    obs, reward, _, _, info = vec.step(vec.action_space.sample())
    assert obs in vec.observation_space and reward.shape == (3,)
    assert set(info["reward_terms"]) == set(REWARD_TERMS)
    assert vec.metadata["autoreset_mode"] == gymnasium.vector.AutoresetMode.NEXT_STEP


def test_vector_env_flies_the_single_envs_episodes_with_random_actions():
    """Seeded random actions over episodes with pilings; truncation at 10 s, then the
    autoreset into each single env's next episode."""
    endings = _fly_both([20, 21, 22, 23], 60, time_limit_s=10.0, lost_range_m=10.0)
    assert len(endings) == 4 and "truncated" in endings.values()


def test_vector_env_ends_episodes_where_the_single_envs_do():
    """Collisions with the diver and with the sea floor (the Simulation's swept sphere)
    end the same episodes on the same step, with the same last observation."""
    assert set(_fly_both([0, 1, 2], 200, _ram, lost_range_m=30.0).values()) == {"collision"}
    assert set(_fly_both([5, 6], 200, _dive, lost_range_m=60.0,
                         randomization={"clutter": 0}).values()) == {"collision"}


def test_thruster_commands_fly_the_single_envs_episodes():
    endings = _fly_both([7, 8], 40, command="thrusters", time_limit_s=8.0,
                        randomization=Randomization.none())
    assert len(endings) == 2


def test_sub_environments_are_independent_of_the_batch():
    """An episode's trajectory does not depend on the others in the batch (N = 1 vs N = 5)."""
    actions = np.random.default_rng(3).uniform([-1, 0, -1], [1, 1, 1], (30, 3))
    one = TrailDiverVectorEnv(num_envs=1, time_limit_s=5.0)
    five = TrailDiverVectorEnv(num_envs=5, time_limit_s=5.0)
    obs_one, _ = one.reset(seed=[42])
    obs_five, _ = five.reset(seed=[1, 2, 42, 3, 4])
    for a in actions:
        obs_one, r1, *_ = one.step(a[None, :].astype(np.float32))
        obs_five, r5, *_ = five.step(np.tile(a, (5, 1)).astype(np.float32))
        np.testing.assert_array_equal(obs_one[0], obs_five[2])
        assert r1[0] == r5[2]


@pytest.mark.parametrize("randomization", [
    {"clutter": 5},
    {"diver_path": False, "water": False},  # the file's loiter and water
])
def test_episode_starts_from_the_draws_equal_those_read_from_the_scenario_data(randomization):
    """A reset's episode from its draws alone (the file's values read once, one Loiter
    behavior reset each time) equals the one read from the episode's whole scenario data
    (validated, its behaviors built): poses, loiter vertices, first vertex and direction,
    the helm's speed and depth decisions, pilings, water."""
    vec = TrailDiverVectorEnv(num_envs=1, randomization=randomization)
    for seed in range(0, 2_000_000_000, 20_000_000):
        drawn, read = vec._drawn_start(seed), vec._scenario_start(seed)
        assert drawn._replace(pilings=None) == read._replace(pilings=None)
        assert [p[:4] for p in drawn.pilings] == [p[:4] for p in read.pilings]
        assert [CylinderObject.model_validate(p.object) for p in drawn.pilings] == [
            CylinderObject.model_validate(p.object) for p in read.pilings]


def _fly_compiled_and_numpy(seeds, steps, policy, **kwargs):
    """Step the vector env with its compiled ticks and measures and one on numpy's arrays
    (the reference, as without numba) with the same actions; returns the step results."""
    fast = TrailDiverVectorEnv(num_envs=len(seeds), **kwargs)
    slow = TrailDiverVectorEnv(num_envs=len(seeds), **kwargs)
    slow.step_kernel = None
    obs, _ = fast.reset(seed=seeds)
    np.testing.assert_array_equal(obs, slow.reset(seed=seeds)[0])
    endings = []
    for _ in range(steps):
        actions = np.stack([policy(o) for o in obs])
        obs, reward, terminated, truncated, info = fast.step(actions)
        s_obs, s_reward, s_terminated, s_truncated, s_info = slow.step(actions)
        np.testing.assert_array_equal(fast.rov, slow.rov)  # bit for bit
        np.testing.assert_array_equal(fast.diver, slow.diver)
        np.testing.assert_array_equal(obs, s_obs)
        np.testing.assert_array_equal(terminated, s_terminated)
        np.testing.assert_array_equal(truncated, s_truncated)
        # numpy's arctan2 and libm's differ in the last bit (the bearing term and error)
        np.testing.assert_allclose(reward, s_reward, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(info["termination"], s_info["termination"])
        endings += [e for e in info["termination"] if e]
    return endings


def test_compiled_ticks_equal_the_numpy_ones():
    """The compiled ticks (numba) and the numpy ones: the same states, observations and
    endings, through collisions with the diver, the sea floor (the compiled ticks leave
    those moves to the env's swept sphere) and pilings."""
    if TrailDiverVectorEnv(num_envs=1).step_kernel is None:
        pytest.skip("numba (the [fast] extra) is not installed: the numpy ticks run alone")
    assert _fly_compiled_and_numpy([6], 108, _dive, lost_range_m=60.0) == ["collision"]
    assert _fly_compiled_and_numpy([0, 2], 24, _ram, lost_range_m=30.0,
                                   randomization={"clutter": 4}) == ["collision"] * 2


def test_compiled_ticks_equal_the_numpy_ones_with_the_quadratic_thrust_map(tmp_path):
    """The compiled step reads the thrust map as a code (videoray.THRUST_MAPS): Wang's
    quadratic map flies as the numpy ticks fly it."""
    if TrailDiverVectorEnv(num_envs=1).step_kernel is None:
        pytest.skip("numba (the [fast] extra) is not installed: the numpy ticks run alone")
    source = shipped_scenario()
    text = source.read_text().replace("thrust_map: linear", "thrust_map: quadratic")
    assert "thrust_map: quadratic" in text
    scenario = tmp_path / source.name
    scenario.write_text(text)
    for name in ("videoray_trail.bhv",):  # what the scenario refers to, beside it
        (tmp_path / name).write_text((source.parent / name).read_text())
    assert TrailDiverVectorEnv(num_envs=1, scenario=scenario).rov_plant.params.thrust_map == \
        "quadratic"
    _fly_compiled_and_numpy([0, 1], 12, _ram, scenario=scenario)


def test_ticks_shared_among_threads_give_the_same_episodes():
    """threads=2 shares the episodes' compiled steps between two threads, in chunks (of 2
    rows here; a first share of 1 row a new episode), while new episodes begin: every
    state, observation, reward and ending equals one thread's, resets and pilings too;
    the floor's collision caster built up front (prepare) changes nothing."""
    one = TrailDiverVectorEnv(num_envs=8, randomization={"clutter": 4}, time_limit_s=6.0)
    two = TrailDiverVectorEnv(num_envs=8, threads=2, randomization={"clutter": 4},
                              time_limit_s=6.0)
    two.step_chunk, two.rows_per_beginning = 2, 1
    two.prepare()
    if one.step_kernel is None:
        pytest.skip("numba (the [fast] extra) is not installed: no compiled ticks to share")
    np.testing.assert_array_equal(one.reset(seed=5)[0], two.reset(seed=5)[0])
    actions = np.random.default_rng(5).uniform([-1, 0, -1], [1, 1, 1], (40, 8, 3))
    for a in actions.astype(np.float32):
        for mine, theirs in zip(one.step(a)[:4], two.step(a)[:4], strict=True):
            np.testing.assert_array_equal(mine, theirs)
        np.testing.assert_array_equal(one.rov, two.rov)
    two.close()


@pytest.mark.parametrize("kwargs, message", [
    ({"num_envs": 0}, "num_envs must be an integer >= 1"),
    ({"threads": 0}, "threads must be an integer >= 1"),
    ({"observation": "sonar"}, "makes observation=.state., not .sonar."),
    ({"obsevation": "state"}, "did you mean 'observation'"),
    ({"scenario_hook": lambda data, rng: None}, "does not take scenario_hook"),
])
def test_bad_arguments_are_clear_errors(kwargs, message):
    with pytest.raises(EnvArgumentError, match=message):
        TrailDiverVectorEnv(**kwargs)


def test_bad_actions_are_refused():
    vec = TrailDiverVectorEnv(num_envs=2)
    vec.reset(seed=0)
    with pytest.raises(gymnasium.error.InvalidAction, match="2 rows of 3 finite numbers"):
        vec.step(np.zeros((3, 3), dtype=np.float32))
    with pytest.raises(gymnasium.error.InvalidAction, match="finite"):
        vec.step(np.array([[0.0, math.nan, 0.0], [0.0, 0.5, 0.0]], dtype=np.float32))


def test_vector_bench_reports_rates_per_size_and_a_plot(tmp_path):
    from uhrisim.bench import vector

    r = vector.run(quick=True, out_dir=tmp_path)
    assert set(r["sizes"]) == {"1", "16", "64"}
    for size in r["sizes"].values():
        assert size["steps_per_s"] > 0 and size["steps_per_cpu_s"] > 0
    assert r["target_n1"]["target"] == 5000.0
    assert r["target_n1"]["vs_single_env"] == pytest.approx(
        r["sizes"]["1"]["steps_per_cpu_s"] / r["single_env_steps_per_cpu_s"])
    assert (tmp_path / "vector_steps_per_s.png").stat().st_size > 10_000
    assert r["sonar"]["sizes"]["4"]["steps_per_cpu_s"] > 0
