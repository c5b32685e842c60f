"""The paper's P controller (eqs 5-9): wrap, mixing, and closed-loop step responses."""

import numpy as np
import pytest

from uhrisim.control.videoray_p import GAIN_PRESETS, PGains, VideoRayPController
from uhrisim.core.frames import heading_deg_from_yaw, wrap_180
from uhrisim.dynamics.plants import VideoRayPlant
from uhrisim.dynamics.videoray import VideoRayParams

PARAMS = VideoRayParams()


def closed_loop(gains: PGains, x0, heading, speed, depth, seconds=40.0, dt=0.01):
    plant = VideoRayPlant(PARAMS, dt)
    control = VideoRayPController(gains, PARAMS)
    x = np.asarray(x0, float)
    trace = [x]
    for k in range(round(seconds / dt)):
        x = plant.step(k * dt, x, control.inputs(x, heading, speed, depth))
        trace.append(x)
    return np.array(trace)


def sign_changes(values: np.ndarray, deadband: float) -> int:
    signs = np.sign(values[np.abs(values) > deadband])
    return int(np.count_nonzero(np.diff(signs)))


def test_heading_error_is_wrapped_the_short_way():
    control = VideoRayPController(GAIN_PRESETS["ros-node"], PARAMS)
    x = np.array([0, 0, 0, np.radians(350.0), 0, 0, 0, 0])
    port, star, _ = control.inputs(x, 10.0, 0.0, 0.0)
    assert port - star == pytest.approx(2 * 0.5 * 1.0 * 20.0)  # +20 deg error, eq 9 mixing
    trace = closed_loop(GAIN_PRESETS["ros-node"], x, 10.0, 0.0, 0.0, seconds=10.0)
    headings = heading_deg_from_yaw(trace[:, 3])
    # Turning clockwise through north: never passes the far side (180 deg).
    assert np.all((headings > 340.0) | (headings < 20.0))
    assert abs(wrap_180(headings[-1] - 10.0)) < 0.5


def test_heading_step_converges_without_sustained_oscillation():
    trace = closed_loop(GAIN_PRESETS["ros-node"], np.zeros(8), 90.0, 0.0, 0.0, seconds=20.0)
    error = wrap_180(90.0 - heading_deg_from_yaw(trace[:, 3]))
    assert abs(error[-1]) < 0.5
    assert sign_changes(error, deadband=0.5) <= 1
    assert np.max(np.abs(error[-500:])) < 0.5  # last 5 s settled


def test_depth_step_converges_without_sustained_oscillation():
    trace = closed_loop(GAIN_PRESETS["ros-node"], np.zeros(8), 0.0, 0.0, 5.0, seconds=60.0)
    error = 5.0 - trace[:, 2]
    assert abs(error[-1]) < 0.01  # neutral buoyancy: no steady-state error under P control
    assert sign_changes(error, deadband=0.02) <= 1


def test_speed_p_only_settles_at_the_thrust_drag_balance():
    # Paper controller, no feed-forward: steady state where 2*w_s*K_s*(vd-u)*Ct = drag(u).
    gains = GAIN_PRESETS["ros-node"]
    trace = closed_loop(gains, np.zeros(8), 0.0, 1.0, 0.0, seconds=30.0)
    k = 2 * gains.speed_weight * gains.speed * PARAMS.ct_linear
    roots = np.roots([-PARAMS.Xuu, -PARAMS.Xu + k, -k * 1.0])
    expected = max(r.real for r in roots)
    assert trace[-1, 4] == pytest.approx(expected, rel=1e-4)
    assert sign_changes(1.0 - trace[:, 4], 0.001) == 0


def test_speed_with_feedforward_reaches_the_target():
    trace = closed_loop(GAIN_PRESETS["mission"], np.zeros(8), 0.0, 0.8, 0.0, seconds=30.0)
    assert trace[-1, 4] == pytest.approx(0.8, abs=1e-3)
    assert sign_changes(0.8 - trace[:, 4], 0.005) <= 1


def test_outputs_saturate():
    control = VideoRayPController(GAIN_PRESETS["octave"], PARAMS)
    out = control.inputs(np.zeros(8), 90.0, 5.0, 50.0)
    assert np.all(np.abs(out) <= 150.0) and np.any(np.abs(out) == 150.0)
