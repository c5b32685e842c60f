"""One physics path over N vehicles: the VideoRay's RK4 kernel, the diver's exact step and
the controllers (paper eqs 1-13) on arrays are held to

* the trajectories of the code before they were batched (tests/data/physics: the paper's
  open-loop runs, a batch of 16 vehicles, a diver under random leg inputs and the paper's
  mission, saved from commit f8612a8 by make_reference.py there), within 1e-9 relative;
* one vehicle at a time through the same kernel on floats.
"""

from pathlib import Path

import numpy as np
import pytest

from uhrisim.control.diver import DiverController, DiverGains
from uhrisim.control.videoray_p import GAIN_PRESETS, VideoRayPController
from uhrisim.dynamics import diver, videoray
from uhrisim.dynamics.plants import DiverPlant, VideoRayPlant
from uhrisim.experiments.openloop import run_openloop

REFERENCE = np.load(Path(__file__).resolve().parents[1] / "data" / "physics"
                    / "reference_trajectories.npz")
RELATIVE = 1e-9


def assert_close_relative(actual, reference, rel=RELATIVE):
    """Every entry within ``rel`` of the reference's scale (its largest magnitude per
    state component), so that components passing through zero are judged fairly."""
    actual, reference = np.asarray(actual), np.asarray(reference)
    scale = np.max(np.abs(reference.reshape(-1, reference.shape[-1])), axis=0)
    error = np.max(np.abs(actual - reference).reshape(-1, reference.shape[-1]), axis=0)
    assert np.all(error <= rel * np.maximum(scale, 1e-12)), (error / scale).tolist()


def test_paper_open_loop_runs_are_today_s():
    assert_close_relative(run_openloop().states, REFERENCE["openloop_states"])
    params = videoray.VideoRayParams(thrust_map="quadratic", coupling="rigid-body")
    assert_close_relative(run_openloop(params).states,
                          REFERENCE["openloop_quadratic_rigid_states"])


def _fly(plant, start, inputs):
    """``start`` and the states after each step of ``plant`` under ``inputs`` (held)."""
    out = [start]
    for k, u in enumerate(inputs):
        out.append(plant.step(k * plant.dt, out[-1], u))
    return np.array(out)


def test_a_batch_of_vehicles_flies_today_s_trajectories():
    plant = VideoRayPlant(videoray.VideoRayParams(), 1.0 / 60.0)
    states = REFERENCE["batch_states"]
    assert_close_relative(_fly(plant, states[0], REFERENCE["batch_inputs"]), states)


def test_the_diver_s_exact_step_is_today_s():
    plant = DiverPlant(diver.DiverParams(), 1.0 / 20.0)
    legs, states = REFERENCE["diver_inputs"], REFERENCE["diver_states"]
    assert_close_relative(_fly(plant, states[0], legs), states)
    # the same steps for all at once: a batch of the recorded states
    batch = plant.step(0.0, states[:-1], legs)
    assert_close_relative(batch, states[1:], rel=1e-12)


@pytest.mark.parametrize("make", [lambda: VideoRayPlant(videoray.VideoRayParams(), 0.05),
                                  lambda: DiverPlant(diver.DiverParams(), 0.05)],
                         ids=["videoray", "diver"])
def test_what_a_plant_keeps_of_the_inputs_follows_them(make):
    # One vehicle's forces (or body rates) are kept while its inputs hold: inputs changed
    # in place, changed back or handed as a new array step exactly as a fresh plant does.
    rng = np.random.default_rng(3)
    plant = make()
    x = plant.initial_state(np.array([1.0, -2.0, 3.0]), 0.4)
    u = np.array([40.0, 10.0, -5.0]) if plant.kind == "videoray" else np.array(
        [0.3, 0.1, 0.05])
    for k in range(12):
        if k % 3 == 1:
            u[rng.integers(3)] *= -0.5  # the same array, new values
        elif k % 3 == 2:
            u = u.copy()
        fresh = make()
        expected, nav = fresh.step(0.0, x, u), fresh.nav(x, u)
        x_next = plant.step(0.0, x, u)
        np.testing.assert_array_equal(x_next, expected)
        np.testing.assert_array_equal(plant.nav(x, u).velocity_body, nav.velocity_body)
        x = x_next


@pytest.mark.slow
def test_the_paper_s_mission_flies_today_s_trajectory():
    from uhrisim.scenario.load import load_scenario
    from uhrisim.scenario.shipped import shipped_scenario
    from uhrisim.sim.simulation import Simulation

    reference = REFERENCE["mission_states"]  # diver (4) + videoray (8), every 6th tick
    rows = []
    with Simulation(load_scenario(shipped_scenario()), raycast_sensors=False) as sim:
        for _ in range(len(reference) * 6):
            sim.step()
            if sim.tick % 6 == 0:
                rows.append(np.concatenate([sim.agents["diver"].state,
                                            sim.agents["videoray"].state]))
    assert_close_relative(np.array(rows), reference)


@pytest.mark.parametrize("thrust_map, coupling", [("linear", "paper"),
                                                  ("quadratic", "rigid-body")])
def test_n_vehicles_at_once_equal_one_at_a_time(thrust_map, coupling):
    rng = np.random.default_rng(17)
    params = videoray.VideoRayParams(thrust_map=thrust_map, coupling=coupling)
    plant = VideoRayPlant(params, 0.05)
    xs = rng.normal(size=(64, 8))
    us = rng.uniform(-200.0, 200.0, (64, 3))
    batch = plant.step(0.0, xs, us)
    singles = np.array([plant.step(0.0, x, u) for x, u in zip(xs, us, strict=True)])
    np.testing.assert_allclose(batch, singles, rtol=1e-13, atol=1e-13)
    # N = 1 as an array is the batch path too
    np.testing.assert_allclose(plant.step(0.0, xs[:1], us[:1])[0], singles[0], rtol=1e-13)


def test_controllers_on_n_vehicles_equal_one_at_a_time():
    rng = np.random.default_rng(4)
    n = 50
    heading, depth = rng.uniform(0, 360, n), rng.uniform(0, 10, n)
    for preset in ("ros-node", "mission"):
        for thrust_map in ("linear", "quadratic"):
            params = videoray.VideoRayParams(thrust_map=thrust_map)
            control = VideoRayPController(GAIN_PRESETS[preset], params)
            xs = rng.normal(size=(n, 8)) * [10, 10, 3, 4, 1, 0.3, 0.3, 1]
            speed = rng.uniform(-0.3, 1.2, n)
            many = control.inputs_many(xs, heading, speed, depth)
            one = [control.inputs(x, h, s, d) for x, h, s, d in zip(xs, heading, speed, depth,
                                                                     strict=True)]
            np.testing.assert_allclose(many, one, rtol=1e-13, atol=1e-12)
    control = DiverController(DiverGains(), diver.DiverParams())
    xs = rng.normal(size=(n, 4)) * [10, 10, 3, 7]
    speed = rng.uniform(0, 1, n)
    many = control.inputs_many(xs, heading, speed, depth)
    one = [control.inputs(x, h, s, d) for x, h, s, d in zip(xs, heading, speed, depth,
                                                             strict=True)]
    np.testing.assert_allclose(many, one, rtol=1e-12, atol=1e-12)


def test_a_blow_up_in_a_batch_is_reported_by_name():
    from uhrisim.core.errors import NumericalError

    plant = VideoRayPlant(videoray.VideoRayParams(), 0.05, name="fleet")
    xs = np.zeros((3, 8))
    xs[1, 7] = 1e200  # a yaw rate no vehicle survives
    with pytest.raises(NumericalError, match="fleet"):
        plant.step(0.0, xs, np.zeros((3, 3)))


def test_the_numpy_path_equals_the_compiled_kernel():
    """With numba (``uhrisim[fast]``) a batch runs the float kernel compiled; the numpy
    path (``compiled=False``, and every batch without numba) runs the same kernel on
    arrays: the same numbers, bit for bit."""
    rng = np.random.default_rng(23)
    for thrust_map, coupling in (("linear", "paper"), ("quadratic", "rigid-body")):
        params = videoray.VideoRayParams(thrust_map=thrust_map, coupling=coupling)
        xs, us = rng.normal(size=(200, 8)), rng.uniform(-200.0, 200.0, (200, 3))
        fast = videoray.rk4_steps(xs, us, params, 0.006, 8)
        slow = videoray.rk4_steps(xs, us, params, 0.006, 8, compiled=False)
        np.testing.assert_array_equal(fast, slow)
        for x, u in zip(xs[:20], us[:20], strict=True):  # one vehicle: floats
            np.testing.assert_array_equal(videoray.rk4_steps(x, u, params, 0.006, 8),
                                          videoray.rk4_steps(x, u, params, 0.006, 8,
                                                             compiled=False))
