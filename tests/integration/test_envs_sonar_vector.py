"""The sonar vector env (uhrisim.envs.sonar_vector): N episodes with one cast of all N
sonars per step, held to N single envs (the Simulation pinging its sonar) on the same
seeds, and its pilings (array code) to the single env's cylinder meshes."""

import math

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium", reason="the [gym] extra is not installed")

from uhrisim.envs import TrailDiverEnv  # noqa: E402
from uhrisim.envs.sonar_vector import TrailDiverSonarVectorEnv  # noqa: E402
from uhrisim.scenario.build_world import add_object, build_static_scene  # noqa: E402


def _toward_diver(contact):
    """Ahead at half speed toward the diver (body-frame contact), matching its depth."""
    return np.array([math.atan2(contact[1], contact[0]), 0.5, contact[2]], dtype=np.float32)


def test_make_vec_steps_the_single_envs_episodes_with_their_sonar_images():
    seeds, kwargs = [1, 0], {"lost_range_m": 30.0}
    vec = gymnasium.make_vec("uhrisim/TrailDiver-v0", num_envs=2,
                             vectorization_mode="vector_entry_point", **kwargs)
    assert isinstance(vec, TrailDiverSonarVectorEnv)
    singles = [TrailDiverEnv("sonar", **kwargs) for _ in seeds]
    v_obs, _ = vec.reset(seed=seeds)
    obs = [env.reset(seed=s)[0] for env, s in zip(singles, seeds, strict=True)]
    seen = 0
    for _ in range(6):
        assert v_obs in vec.observation_space
        for i, o in enumerate(obs):
            for key in ("sonar", "nav", "contact"):
                np.testing.assert_array_equal(v_obs[key][i], o[key], err_msg=key)
        seen += int(np.count_nonzero(v_obs["sonar"] > 100))
        actions = np.stack([_toward_diver(v_obs["contact"][i]) for i in range(2)])
        v_obs, v_reward, v_term, v_trunc, _ = vec.step(actions)
        for i, env in enumerate(singles):
            obs[i], reward, terminated, truncated, _ = env.step(actions[i])
            assert v_reward[i] == pytest.approx(reward, abs=1e-12)
            assert (v_term[i], v_trunc[i]) == (terminated, truncated)
    assert seen > 0  # the diver's echo was in the images compared


def test_pilings_in_array_code_are_the_single_env_s_cylinder_meshes():
    """A ROV 3 m from a piling, facing it: the rays the array code stops on the piling
    are those the mesh stops (but for a few grazing ones), at the same range to 5 mm."""
    vec = TrailDiverSonarVectorEnv(num_envs=1)
    vec.reset(seed=[3])
    north, east, radius = vec.pilings[0, 0]
    vec.rov[0, :4] = (north - 3.0 - radius, east, 1.5, 0.0)  # due south of it, heading north
    _, dirs, distance, normal, _, _ = vec._cast_fans()
    scene = build_static_scene(vec._source)
    for obj in vec._cylinders(0):
        add_object(scene, obj, vec._source, "test")
    origin = vec.sonars[0].sonar_pose(vec.rov[0, :3], np.eye(3))[0]
    mesh = scene.raycaster("embree").cast(origin, dirs[0], vec.sonars[0].cast_window_m[1])
    on_piling = mesh.label == scene.label_id(vec._cylinders(0)[0].label)
    ours = distance[0] < np.inf
    ours &= np.abs(normal[0, :, 2]) < 0.5  # the array code's hits on the piling's side
    assert on_piling.sum() > 500
    assert np.count_nonzero(on_piling != ours) < 0.02 * on_piling.sum()
    both = on_piling & ours
    np.testing.assert_allclose(distance[0, both], mesh.distance[both], atol=5e-3)


def test_scenarios_with_more_to_see_are_refused_by_name():
    from uhrisim.envs import EnvArgumentError
    from uhrisim.scenario.shipped import shipped_scenario

    with pytest.raises(EnvArgumentError, match="the bubbles of 'diver'"):
        TrailDiverSonarVectorEnv(scenario=shipped_scenario("track_and_trail_sonar_clutter"))


def test_images_formed_by_two_threads_are_those_of_one():
    """Each thread forms its own episodes' images: the same observations bit for bit."""
    envs = [TrailDiverSonarVectorEnv(num_envs=3, threads=k) for k in (1, 2)]
    actions = np.random.default_rng(5).uniform(envs[0].single_action_space.low,
                                               envs[0].single_action_space.high, (3, 3, 3))
    runs = [[env.reset(seed=[4, 5, 6])[0]["sonar"]]
            + [env.step(a.astype(np.float32))[0]["sonar"] for a in actions] for env in envs]
    for env in envs:
        env.close()
    assert runs[0][-1].any()
    np.testing.assert_array_equal(runs[0], runs[1])


def test_pings_with_no_hit_take_the_echo_free_shortcut(monkeypatch):
    """With the diver far out of every fan, the pings that see nothing (the sea floor
    beyond the window) form their images by ``polar_bytes``' echo-free shortcut
    (``ImagingSonar._echo_free_level``): the env's speed path, held."""
    from uhrisim.sensors.sonar.sonar import ImagingSonar

    vec = TrailDiverSonarVectorEnv(num_envs=3)
    vec.reset(seed=[7, 8, 9])
    vec.diver[:, :3] = vec.rov[:, :3] + [0.0, 0.0, -500.0]  # far above, out of every fan
    vec.rov[:, 2] = 2.0  # near the surface: the sea floor out of the window
    calls = []
    shortcut = ImagingSonar._echo_free_level
    monkeypatch.setattr(ImagingSonar, "_echo_free_level",
                        lambda self, *pose: calls.append(self) or shortcut(self, *pose))
    vec._ping()
    assert calls == vec.sonars


@pytest.mark.parametrize("shape", [(375, 256, 96, 64), (50, 33, 7, 5), (37, 20, 9, 10),
                                   (45, 24, 7, 3)])
def test_area_averaging_is_opencv_s_inter_area_bit_for_bit(shape):
    """The compiled averaging down (and its plain-Python loops) equal ``cv2.resize``'s
    ``INTER_AREA`` on random images, including scales that are not dyadic; where the
    columns average blocks of 2ⁿ pixels, by the blocks' integer sums and by the loop."""
    import cv2

    from uhrisim.envs.sonar_vector import (
        _area_down_compiled,
        _area_down_loops,
        _area_table,
        _exact_blocks,
    )

    rows, columns, rows_out, columns_out = shape
    images = np.random.default_rng(rows).integers(0, 256, (2, rows, columns), dtype=np.uint8)
    expected = np.stack([cv2.resize(image, (columns_out, rows_out),
                                    interpolation=cv2.INTER_AREA) for image in images])
    tables = _area_table(rows, rows_out), _area_table(columns, columns_out)
    block = _exact_blocks(tables[1])
    assert block == {256: 4, 20: 2, 24: 8}.get(columns, 0)
    kernels = [_area_down_loops] * (rows < 100)  # (the plain loops are slow)
    for kernel in kernels + [k for k in [_area_down_compiled()] if k is not None]:
        for column_block in {0, block}:
            out = np.empty_like(expected)
            kernel(images, *tables, column_block, out)
            np.testing.assert_array_equal(out, expected)
