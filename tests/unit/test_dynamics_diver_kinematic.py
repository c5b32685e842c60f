"""Diver (paper eqs 10-13) and the uSimMarine-like kinematic vehicle."""

import numpy as np
import pytest

from uhrisim.control.diver import DiverController, DiverGains
from uhrisim.control.marine_pid import MarinePidController, MarinePidGains
from uhrisim.core.frames import heading_deg_from_yaw, wrap_180
from uhrisim.dynamics import diver
from uhrisim.dynamics.integrators import rk4_step
from uhrisim.dynamics.kinematic import KinematicParams, kinematic_step
from uhrisim.dynamics.plants import DiverPlant, KinematicPlant

DIVER = diver.DiverParams()


def test_differential_drive_equations_with_paper_wheel_radius_and_track():
    # r = 1, L = 0.5: u_l = 0.6, u_r = 0.4 -> speed (r/2)(1.0) = 0.5 m/s,
    # yaw rate (r/L)(0.2) = 0.4 rad/s (above the 30 deg/s limit -> saturated at 0.5236).
    rates = diver.body_rates(np.array([0.6, 0.4, 0.0]), diver.DiverParams(max_turn_rate=1.0))
    np.testing.assert_allclose(rates, [0.5, 0.4, 0.0])
    d = diver.xdot(0.0, np.array([0, 0, 2.0, np.pi / 2]), np.array([0.5, 0.5, 0.0]), DIVER)
    np.testing.assert_allclose(d, [0.0, 0.5, 0.0, 0.0], atol=1e-15)  # due east at 0.5 m/s


def test_limits_saturate():
    rates = diver.body_rates(np.array([3.0, 2.0, -1.0]), DIVER)
    assert rates[0] == DIVER.max_speed
    assert rates[1] == pytest.approx(DIVER.max_turn_rate)
    assert rates[2] == -DIVER.max_vertical_rate


def test_float_body_rates_match_the_numpy_reference():
    rng = np.random.default_rng(9)
    for u in rng.uniform(-2, 2, (100, 3)):
        np.testing.assert_allclose(diver.body_rates_single(u, DIVER), diver.body_rates(u, DIVER),
                                   rtol=0, atol=1e-15)


def test_leg_inputs_invert_body_rates():
    legs = diver.leg_inputs(0.4, 0.2, -0.1, DIVER)
    np.testing.assert_allclose(diver.body_rates(legs, DIVER), [0.4, 0.2, -0.1])


@pytest.mark.slow
def test_exact_arc_step_matches_fine_rk4_on_the_paper_equations():
    rng = np.random.default_rng(2)
    for _ in range(20):
        x0 = np.array([*rng.normal(size=3), rng.uniform(-np.pi, np.pi)])
        u = rng.uniform(-0.6, 0.8, 3)
        reference = x0.copy()
        for k in range(1000):
            reference = rk4_step(diver.xdot, k * 1e-3, reference, u, DIVER, 1e-3)
        np.testing.assert_allclose(diver.step_exact(x0, u, DIVER, 1.0), reference, atol=1e-10)


def test_neutral_buoyancy_and_straight_swim():
    plant = DiverPlant(DIVER, 0.05)
    x = plant.initial_state(np.array([10.0, 0.0, 1.5]), np.pi)  # heading 180 deg
    for k in range(200):  # 10 s at 0.5 m/s
        x = plant.step(k * 0.05, x, np.array([0.5, 0.5, 0.0]))
    np.testing.assert_allclose(x[:3], [5.0, 0.0, 1.5], atol=1e-9)


def test_diver_controller_turns_and_holds_depth():
    plant = DiverPlant(DIVER, 0.05)
    control = DiverController(DiverGains(), DIVER)
    x = plant.initial_state(np.zeros(3), 0.0)
    headings = []
    for k in range(600):  # 30 s
        x = plant.step(k * 0.05, x, control.inputs(x, 270.0, 0.5, 3.0))
        headings.append(heading_deg_from_yaw(x[3]))
    headings = np.array(headings)
    assert abs(wrap_180(headings[-1] - 270.0)) < 0.5
    assert np.all((headings > 260.0) | (headings < 1.0))  # the short way, through north
    assert x[2] == pytest.approx(3.0, abs=0.01)


def test_kinematic_speed_turn_and_deceleration_follow_usimmarine():
    params = KinematicParams()
    x = np.array([0, 0, 0, 0, 0.0])
    x = kinematic_step(x, np.array([40.0, 0.0, 0.0]), params, 0.1)
    assert x[4] == pytest.approx(40.0 / 20.0)  # thrust/thrust_factor, no accel limit
    slowed = kinematic_step(x, np.array([0.0, 0.0, 0.0]), params, 0.1)
    assert slowed[4] == pytest.approx(2.0 - 0.5 * 0.1)  # max deceleration 0.5 m/s^2
    turned = kinematic_step(x, np.array([50.0, 20.0, 0.0]), params, 1.0)
    # heading change = rudder * (turn_rate/100) * dt * (1 + (thrust-50)/50) = 20*0.7*1*1 deg
    assert np.degrees(turned[3]) == pytest.approx(14.0)
    assert turned[4] == pytest.approx(2.5 * (1 - 0.85 * 0.2))


def test_kinematic_vehicle_with_marine_pid_reaches_heading_speed_depth():
    plant = KinematicPlant(KinematicParams(), 0.1)
    control = MarinePidController(MarinePidGains())
    x = plant.initial_state(np.zeros(3), 0.0)
    for k in range(600):
        x = plant.step(k * 0.1, x, control.inputs(x, 120.0, 1.5, 4.0))
    assert abs(wrap_180(heading_deg_from_yaw(x[3]) - 120.0)) < 1.0
    assert x[4] == pytest.approx(1.5, abs=0.05)
    assert x[2] == pytest.approx(4.0, abs=0.05)
