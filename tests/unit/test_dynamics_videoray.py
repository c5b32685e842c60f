"""VideoRay model (paper eqs 1-4): steady states, energy, integration order, stiffness."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from uhrisim.core.errors import ConfigError, NumericalError
from uhrisim.dynamics import videoray as vr
from uhrisim.dynamics.integrators import FixedStepIntegrator, rk4_step
from uhrisim.dynamics.plants import VideoRayPlant

PARAMS = vr.VideoRayParams()


def positive_root(a: float, b: float, c: float) -> float:
    """Positive root of a s^2 + b s + c = 0, by numpy (independent of the model code)."""
    roots = np.roots([a, b, c])
    return float(max(r.real for r in roots if abs(r.imag) < 1e-12))


def simulate(plant: VideoRayPlant, u: np.ndarray, seconds: float, x0=None) -> np.ndarray:
    x = np.zeros(8) if x0 is None else np.asarray(x0, float)
    for k in range(round(seconds / plant.dt)):
        x = plant.step(k * plant.dt, x, u)
    return x


def test_steady_surge_equals_thrust_drag_balance():
    # Both thrusters at 150 -> X = 2 * 4 N = 8 N (authors' linear map, 4 N at full input).
    # Balance: |Xuu| u^2 + |Xu| u = 8  (Wang 2006 coefficients) -> u ~ 1.075 m/s.
    expected = positive_root(6.04, 0.95, -8.0)
    x = simulate(VideoRayPlant(PARAMS, 0.01), np.array([150.0, 150.0, 0.0]), 40.0)
    assert x[4] == pytest.approx(expected, rel=1e-6)
    assert expected == pytest.approx(1.075, abs=1e-3)
    assert abs(x[5]) < 1e-12 and abs(x[7]) < 1e-12  # symmetric thrust: no sway, no yaw


def test_steady_heave_equals_thrust_drag_balance():
    # Vertical -150 -> 4 N downward; balance |Zww| w^2 + |Zw| w = 4 -> w ~ 0.326 m/s (down).
    expected = positive_root(26.36, 3.70, -4.0)
    x = simulate(VideoRayPlant(PARAMS, 0.01), np.array([0.0, 0.0, -150.0]), 30.0)
    assert x[6] == pytest.approx(expected, rel=1e-6)
    assert expected == pytest.approx(0.326, abs=1e-3)
    assert x[2] > 5.0  # it went deeper (NED z down)


def test_inputs_saturate_at_150():
    beyond = vr.generalized_forces(np.array([400.0, 400.0, -900.0]), PARAMS)
    at_limit = vr.generalized_forces(np.array([150.0, 150.0, -150.0]), PARAMS)
    np.testing.assert_array_equal(beyond, at_limit)


def test_quadratic_thrust_map_of_wang():
    params = vr.VideoRayParams(thrust_map="quadratic")
    thrust = vr.thruster_forces(np.array([100.0, -100.0, 100.0]), params)
    np.testing.assert_allclose(thrust, [2.59e-4 * 1e4, -1.01e-4 * 1e4, 1.19e-4 * 1e4])


@pytest.mark.parametrize("coupling", ["paper", "rigid-body"])
def test_kinetic_energy_never_increases_without_input(coupling):
    params = vr.VideoRayParams(coupling=coupling)
    plant = VideoRayPlant(params, 0.005)
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = np.concatenate([np.zeros(4), rng.uniform(-1.5, 1.5, 3), rng.uniform(-4, 4, 1)])
        energy = [vr.kinetic_energy(x, params)]
        for k in range(400):
            x = plant.step(k * plant.dt, x, np.zeros(3))
            energy.append(vr.kinetic_energy(x, params))
        assert np.all(np.diff(energy) <= 1e-12), "kinetic energy grew with zero input"
        assert energy[-1] < 0.05 * energy[0]


def test_rigid_body_coupling_does_no_work():
    # With damping and forces removed, Fossen's coupling conserves kinetic energy exactly:
    # dE/dt = m11 u du + m22 v dv + J r dr = 0.
    params = vr.VideoRayParams(coupling="rigid-body", Xu=0, Yv=0, Zw=0, Nr=0, Xuu=0, Yvv=0,
                               Zww=0, Nrr=0)
    x = np.array([0, 0, 0, 0, 0.8, -0.3, 0.1, 0.5])
    d = vr.xdot(0.0, x, np.zeros(3), params)
    power = params.m11 * x[4] * d[4] + params.m22 * x[5] * d[5] + params.m33 * x[6] * d[6] \
        + params.J * x[7] * d[7]
    assert power == pytest.approx(0.0, abs=1e-12)


def test_rk4_error_falls_16x_when_step_halves():
    # Non-stiff variant (J = 0.5, as in an older script of the authors) so the asymptotic
    # regime is visible; an independent high-order adaptive solution is the reference.
    params = vr.VideoRayParams(J=0.5)
    u = np.array([130.0, 150.0, -100.0])
    x0 = np.array([0, 0, 0, 0, 0.3, 0.0, 0.0, 0.0])
    horizon = 2.0

    def solve(h: float) -> np.ndarray:
        x = x0.copy()
        for k in range(round(horizon / h)):
            x = rk4_step(vr.xdot, k * h, x, u, params, h)
        return x

    reference = solve_ivp(lambda t, x: vr.xdot(t, x, u, params), (0, horizon), x0,
                          method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    errors = [np.max(np.abs(solve(h) - reference)) for h in (0.04, 0.02, 0.01)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(12.0 < r < 20.0 for r in ratios), ratios


def test_fast_single_vehicle_path_matches_numpy_rk4():
    rng = np.random.default_rng(3)
    plant = VideoRayPlant(PARAMS, 0.01)
    h = plant.dt / plant.integrator.substeps
    for coupling, thrust_map in [("paper", "linear"), ("rigid-body", "quadratic")]:
        params = vr.VideoRayParams(coupling=coupling, thrust_map=thrust_map)
        for _ in range(10):
            x = rng.normal(size=8)
            u = rng.uniform(-200, 200, 3)
            slow = x.copy()
            for k in range(plant.integrator.substeps):
                slow = rk4_step(vr.xdot, k * h, slow, u, params, h)
            fast = vr.rk4_steps(x, u, params, h, plant.integrator.substeps)
            np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("thrust_map", ["linear", "quadratic"])
def test_fast_path_forces_match_numpy_forces(thrust_map):
    params = vr.VideoRayParams(thrust_map=thrust_map)
    rng = np.random.default_rng(11)
    for u in rng.uniform(-300, 300, (50, 3)):
        np.testing.assert_allclose(vr.body_forces(*u, params),
                                   vr.generalized_forces(u, params), rtol=1e-14, atol=1e-15)


def test_batch_step_equals_single_steps():
    rng = np.random.default_rng(5)
    plant = VideoRayPlant(PARAMS, 0.01)
    xs, us = rng.normal(size=(6, 8)), rng.uniform(-150, 150, (6, 3))
    batch = plant.step(0.0, xs, us)
    for i in range(6):
        np.testing.assert_allclose(batch[i], plant.step(0.0, xs[i], us[i]), atol=1e-12)


def test_stiff_yaw_mode_needs_small_steps():
    # |lambda| = (|Nr| + 2|Nrr| r_max)/J with r_max from full differential thrust.
    r_max = positive_root(0.45, 0.023, -8.0)
    assert vr.stiffest_eigenvalue(PARAMS) == pytest.approx((0.023 + 0.9 * r_max) / 0.0118)
    with pytest.raises(ConfigError, match="unstable"):
        FixedStepIntegrator.for_model(vr.xdot, 0.1, vr.stiffest_eigenvalue(PARAMS), substeps=1)
    plant = VideoRayPlant(PARAMS, 0.1)  # sub-stepped automatically, just enough
    eig, limit, n = vr.stiffest_eigenvalue(PARAMS), 0.75 * 2.785, plant.integrator.substeps
    assert (0.1 / n) * eig <= limit < (0.1 / (n - 1)) * eig
    x = simulate(plant, np.array([150.0, -150.0, 0.0]), 5.0)
    assert x[7] == pytest.approx(r_max, rel=1e-6)


def test_unstable_step_without_guard_explodes_and_is_reported():
    # Plain RK4 at 0.1 s diverges (docs/reference/vehicles-and-control.md); the integrator
    # names vehicle and time.
    integrator = FixedStepIntegrator(vr.xdot, dt=0.1, substeps=1, name="rov1")
    x = np.array([0, 0, 0, 0, 0, 0, 0, 3.0])
    with pytest.raises(NumericalError, match=r"vehicle 'rov1', t="):
        for k in range(200):
            x = integrator.step(k * 0.1, x, np.zeros(3), PARAMS)


def test_same_inputs_give_identical_output():
    plant = VideoRayPlant(PARAMS, 0.01)
    u = np.array([100.0, 120.0, -30.0])
    np.testing.assert_array_equal(simulate(plant, u, 3.0), simulate(plant, u, 3.0))


def test_invalid_parameters_are_rejected():
    with pytest.raises(ValueError, match="J must be positive"):
        vr.VideoRayParams(J=0.0)
    with pytest.raises(ValueError, match="damping"):
        vr.VideoRayParams(Xu=1.0)
