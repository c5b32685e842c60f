"""The Gymnasium environments (uhrisim.envs): API conformance, determinism, reward
bookkeeping, terminations, the typed command path, vector envs and refusals."""

import math

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium", reason="the [gym] extra is not installed")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from uhrisim.envs import ENV_IDS, EnvArgumentError, Randomization, TrailDiverEnv  # noqa: E402
from uhrisim.envs.task import REWARD_TERMS, THRUSTER_LIMIT  # noqa: E402
from uhrisim.scenario.shipped import shipped_scenario  # noqa: E402

FAST = {"randomization": {"clutter": 0}}


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_passes(env_id):
    env = gymnasium.make(env_id, time_limit_s=5.0).unwrapped
    check_env(env, skip_render_check=False)
    env.close()


def _trajectory(env, seed, n=24):
    """Observations, rewards and infos of ``n`` steps of seeded random actions."""
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs]
    rewards, infos = [], []
    for _ in range(n):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        out.append(obs)
        rewards.append(reward)
        infos.append(info)
        if terminated or truncated:
            break
    return out, rewards, infos


def _same(a, b):
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    return np.array_equal(a, b)


@pytest.mark.parametrize("observation", ["state", "sonar"])
def test_same_seed_same_trajectory(observation):
    n = 24 if observation == "state" else 6
    first = _trajectory(TrailDiverEnv(observation), seed=5, n=n)
    second = _trajectory(TrailDiverEnv(observation), seed=5, n=n)
    assert len(first[0]) == len(second[0]) > 1
    assert all(_same(a, b) for a, b in zip(first[0], second[0], strict=True))
    assert first[1] == second[1]
    other = _trajectory(TrailDiverEnv(observation), seed=6, n=2)
    assert not _same(first[0][0], other[0][0])


def test_the_20_hz_physics_step_flies_the_file_s_60_hz_trajectory():
    """The default physics rate (20 Hz, the controllers' rate) against the scenario's own
    60 Hz: inputs are held between control updates either way and the VideoRay's RK4
    sub-steps keep their length, so 30 s of seeded random commands end within millimetres
    (only rounding and the collision/kick bookkeeping between ticks differ)."""
    runs = {}
    for rate in (20.0, None):
        env = TrailDiverEnv("state", physics_rate_hz=rate, time_limit_s=30.0)
        env.reset(seed=3)
        env.action_space.seed(3)
        states, ranges = [], []
        for _ in range(120):
            _, _, terminated, truncated, info = env.step(env.action_space.sample())
            states.append(env._sim.agents["videoray"].state.copy())
            ranges.append(info["range_m"])
            if terminated or truncated:
                break
        runs[rate] = (np.array(states), np.array(ranges))
    (fast, fast_range), (file_rate, file_range) = runs[20.0], runs[None]
    assert fast.shape == file_rate.shape and len(fast) > 60
    assert np.max(np.linalg.norm(fast[:, :3] - file_rate[:, :3], axis=1)) < 0.01  # m
    assert np.max(np.abs(fast_range - file_range)) < 0.01


def test_both_observations_describe_the_same_episode():
    sonar = TrailDiverEnv("sonar", randomization=Randomization.none())
    state = TrailDiverEnv("state", randomization=Randomization.none())
    obs_sonar, _ = sonar.reset(seed=1)
    obs_state, _ = state.reset(seed=1)
    np.testing.assert_allclose(obs_sonar["contact"][:3], obs_state[3:6], atol=1e-5)
    np.testing.assert_allclose(obs_sonar["nav"][5:9], obs_state[9:13], atol=1e-6)
    assert obs_sonar["nav"][2] == pytest.approx(obs_state[13], abs=1e-6)


@pytest.mark.parametrize("side_deg", [12.0, -12.0])
def test_sonar_image_shows_the_diver_at_its_bearing_and_range(side_deg):
    """Polar layout and frames: with the diver held ``side_deg`` to starboard (FRD), its
    echo is in the beam column of that bearing (port to starboard over the 45° fan) and
    in the range row of its distance (0.5-10 m, nearest first)."""
    env = TrailDiverEnv("sonar", randomization=Randomization.none())
    obs, _ = env.reset(seed=1)
    for _ in range(16):
        forward, starboard, down = obs["contact"][:3]
        obs, *_ = env.step(np.array([math.atan2(starboard, forward) - math.radians(side_deg),
                                     0.6, down]))
    forward, starboard = (float(v) for v in obs["contact"][:2])
    bearing_deg = math.degrees(math.atan2(starboard, forward))
    assert abs(bearing_deg - side_deg) < 3.0
    image = obs["sonar"].astype(float)
    assert image.shape == (96, 64) and obs["sonar"].dtype == np.uint8
    column = (bearing_deg + 22.5) / 45.0 * 64
    row = (math.hypot(forward, starboard) - 0.5) / 9.5 * 96
    assert abs(int(np.argmax(image.sum(axis=0))) - column) <= 3
    assert abs(int(np.argmax(image.sum(axis=1))) - row) <= 4


def test_reward_terms_add_up_and_follow_their_definitions():
    env = TrailDiverEnv("state", command="thrusters", **FAST)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    w = env.weights
    for _ in range(30):
        action = rng.uniform(-150, 150, 3).astype(np.float32)
        _, reward, terminated, truncated, info = env.step(action)
        terms = info["reward_terms"]
        assert tuple(terms) == REWARD_TERMS
        assert reward == pytest.approx(sum(terms.values()), abs=1e-12)
        closeness = 1.0 - min(info["position_error_m"] / w.position_scale_m, 1.0)
        assert terms["trail_position"] == pytest.approx(w.trail_position * closeness)
        assert terms["bearing"] == pytest.approx(-w.bearing * abs(info["bearing_error_deg"])
                                                 / 180.0)
        # thruster mode: the inputs at the end of the step are the (held) action
        assert terms["energy"] == pytest.approx(
            -w.energy * np.mean((action / THRUSTER_LIMIT) ** 2), rel=1e-6)
        if terminated or truncated:
            break


def test_collision_terminates_with_its_penalty():
    """Full ahead at the diver (the file's start poses, ROV turned to face it)."""
    env = TrailDiverEnv("state", lost_range_m=30.0, randomization=Randomization.none())
    obs, _ = env.reset(seed=0)
    for _ in range(200):
        bearing = math.atan2(obs[4], obs[3])
        obs, _, terminated, truncated, info = env.step(np.array([bearing, 1.0, obs[5]]))
        if terminated or truncated:
            break
    assert terminated and info["termination"] == "collision"
    assert info["reward_terms"]["collision"] == -env.weights.collision
    with pytest.raises(gymnasium.error.ResetNeeded):
        env.step(env.action_space.sample())


def test_lost_diver_terminates_and_time_limit_truncates():
    env = TrailDiverEnv("state", lost_range_m=8.0, **FAST)
    obs, _ = env.reset(seed=4)
    for _ in range(400):  # full speed away from the diver
        away = math.atan2(-obs[4], -obs[3])
        obs, _, terminated, truncated, info = env.step(np.array([away, 1.0, 0.0]))
        if terminated or truncated:
            break
    assert terminated and not truncated and info["termination"] == "lost"
    assert info["range_m"] > 8.0 and info["reward_terms"]["lost"] == -env.weights.lost

    short = TrailDiverEnv("state", time_limit_s=2.0, **FAST)
    short.reset(seed=4)
    flags = [short.step(np.zeros(3, dtype=np.float32))[2:4] for _ in range(8)]
    assert flags == [(False, False)] * 7 + [(False, True)]


def test_commands_enter_through_the_typed_input_path():
    """Desired mode posts DESIRED_* relative to the current heading and depth; thruster
    mode holds the commanded inputs (clipped to ±150)."""
    env = TrailDiverEnv("state", **FAST)
    env.reset(seed=2)
    sim = env._sim
    rov = sim.agents["videoray"]
    heading0 = math.degrees(rov.nav().yaw) % 360.0
    depth0 = rov.nav().position_ned[2]
    env.step(np.array([math.radians(30.0), 0.8, 0.5], dtype=np.float32))
    posts = sim.agents["videoray"].community.values()
    assert posts["DESIRED_HEADING"] == pytest.approx((heading0 + 30.0) % 360.0, abs=1e-3)
    assert posts["DESIRED_SPEED"] == pytest.approx(0.8, abs=1e-6)
    assert posts["DESIRED_DEPTH"] == pytest.approx(depth0 + 0.5, abs=1e-6)

    thr = TrailDiverEnv("state", command="thrusters", **FAST)
    thr.reset(seed=2)
    thr.step(np.array([200.0, -40.0, 10.0], dtype=np.float32))
    np.testing.assert_array_equal(thr._sim.agents["videoray"].inputs, [150.0, -40.0, 10.0])


def test_randomization_from_the_seed():
    env = TrailDiverEnv("state", randomization={"clutter": 3})
    a, b = env.episodes.scenario(7), env.episodes.scenario(8)
    assert env.episodes.scenario(7) == a
    clutter = [o for o in a.scenario.world.objects if o.label.startswith("clutter")]
    assert len(clutter) == 3
    water = a.scenario.world.water
    assert 4.0 <= water.temperature_c <= 28.0 and 30.0 <= water.salinity_psu <= 38.0
    assert a.scenario.agents != b.scenario.agents
    plain = TrailDiverEnv("state", randomization=Randomization.none()).episodes.scenario(7)
    base = env.episodes.base
    assert plain.scenario.agents[0] == base.agents[0]
    assert plain.scenario.world == base.world


def test_scenario_hook_randomises_on_its_own_stream():
    def murky_harbour(data, rng):
        data["world"]["water"]["temperature_c"] = 4.0
        data["world"].setdefault("objects", []).append(
            {"type": "box", "label": "hull", "size": [2, 2, 2],
             "position": {"north": float(rng.uniform(30, 40)), "east": 0, "depth": 3}})

    plain = TrailDiverEnv("state", **FAST)
    hooked = TrailDiverEnv("state", scenario_hook=murky_harbour, **FAST)
    a, b = plain.episodes.scenario(9), hooked.episodes.scenario(9)
    assert b.scenario.world.water.temperature_c == 4.0
    assert [o.label for o in b.scenario.world.objects] == ["hull"]
    assert 30 <= b.scenario.world.objects[0].position.north <= 40
    assert b.scenario.agents == a.scenario.agents  # the built-in draws are unchanged
    hooked.reset(seed=0)
    assert "hull" in [o.label for o in hooked._sim.scene.static_objects]

    def bad(data, rng):
        data["agents"][0]["start"]["depth"] = -5

    with pytest.raises(EnvArgumentError, match=r"agents\[0\]\.start"):
        TrailDiverEnv("state", scenario_hook=bad).reset(seed=0)


def test_async_vector_env_matches_single_envs():
    seeds = [10, 11]
    vec = gymnasium.make_vec("uhrisim/TrailDiverState-v0", num_envs=2,
                             vectorization_mode="async", **FAST)
    try:
        obs, _ = vec.reset(seed=seeds)
        actions = np.array([[0.2, 0.5, 0.0], [-0.3, 1.0, 0.1]], dtype=np.float32)
        for _ in range(4):
            obs, rewards, *_ = vec.step(actions)
    finally:
        vec.close()
    for i, seed in enumerate(seeds):
        single = gymnasium.make("uhrisim/TrailDiverState-v0", **FAST)
        single.reset(seed=seed)
        for _ in range(4):
            one, reward, *_ = single.step(actions[i])
        np.testing.assert_array_equal(obs[i], one)
        assert rewards[i] == reward


@pytest.mark.parametrize("kwargs, message", [
    ({"obsevation": "state"}, "did you mean 'observation'"),
    ({"command": "rudder"}, "command must be one of"),
    ({"control_step_s": 0.11}, "whole number of physics steps"),
    ({"randomization": {"cluter": 1}}, "did you mean 'clutter'"),
    ({"follower": "auv"}, "follower 'auv' is no agent"),
    ({"scenario": shipped_scenario("track_and_trail_usimmarine.yaml"), "command": "thrusters"},
     "is a kinematic model"),
    ({"scenario": shipped_scenario().parent / "nope.yaml"}, "cannot read scenario file"),
    ({"sonar_shape": 64}, "sonar_shape must be two integers"),
    ({"time_limit_s": float("nan")}, "time_limit_s must be a finite number > 0"),
])
def test_bad_arguments_are_clear_gymnasium_errors(kwargs, message):
    with pytest.raises(gymnasium.error.Error, match=message):
        gymnasium.make("uhrisim/TrailDiverState-v0", **kwargs)


def test_bad_actions_and_options_are_refused():
    env = gymnasium.make("uhrisim/TrailDiverState-v0", **FAST)
    env.reset(seed=0)
    with pytest.raises(gymnasium.error.InvalidAction, match=r"shape \(3,\)"):
        env.step(np.zeros(4, dtype=np.float32))
    with pytest.raises(gymnasium.error.InvalidAction, match="finite"):
        env.step(np.array([0.0, math.nan, 0.0], dtype=np.float32))
    with pytest.raises(EnvArgumentError, match="unknown reset option 'seed_offset'"):
        env.reset(options={"seed_offset": 1})
    # the episode goes on after a refused action
    env.reset(seed=0)
    assert env.step(np.zeros(3, dtype=np.float32))[0].shape == (14,)


@pytest.mark.filterwarnings("ignore:.*(ERROR|Received the following error|Raising the last)"
                            ":UserWarning")
def test_async_vector_env_reports_a_bad_action_without_hanging():
    vec = gymnasium.make_vec("uhrisim/TrailDiverState-v0", num_envs=2,
                             vectorization_mode="async", **FAST)
    try:
        vec.reset(seed=0)
        vec.step_async(np.array([[0.0, math.nan, 0.0], [0.0, 0.5, 0.0]], dtype=np.float32))
        with pytest.raises(gymnasium.error.InvalidAction, match="finite"):
            vec.step_wait(timeout=60)
    finally:
        vec.close(terminate=True)


def test_render_shows_map_and_sonar_fan():
    env = TrailDiverEnv("sonar", render_mode="rgb_array", randomization=Randomization.none())
    obs, _ = env.reset(seed=1)
    for _ in range(6):  # turn to face the diver
        forward, starboard = obs["contact"][:2]
        obs, *_ = env.step(np.array([math.atan2(starboard, forward), 0.0, 0.0]))
    frame = env.render()
    assert frame.shape == (400, 800, 3) and frame.dtype == np.uint8
    # the follower is drawn at the map's centre; the fan panel shows the diver's echo
    assert tuple(frame[200, 200]) == (255, 220, 0)
    assert frame[:, 400:].max() > 100


def test_bench_gym_reports_rates_and_targets():
    from uhrisim.bench import run_benchmark

    result = run_benchmark("gym", quick=True)
    for key in ("state_env", "sonar_env"):
        assert result[key]["steps_per_s"] > 0 and result[key]["steps_per_cpu_s"] > 0
        assert isinstance(result[key]["meets_target"], bool)
    vec = result["async_vector_env"]
    assert vec["num_envs"] == 2 and vec["speedup"] > 0
    assert vec["speedup"] == pytest.approx(vec["steps_per_s"] / vec["single_env_steps_per_s"])
