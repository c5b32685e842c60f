"""Free bodies: terminal speed, resting on the floor, rising, lift bags (Boyle), current."""

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.dynamics import free_body as fb

RHO, G = fb.WATER_DENSITY, fb.GRAVITY
DT = 1.0 / 60.0
#: A 1 kg steel bar (7850 kg/m³) falling broadside: 0.45 m x 0.04 m projected, C_d 1.2.
BAR = fb.Hydro(mass=1.0, volume=1.0 / 7850.0, drag_coefficient=1.2, area=0.45 * 0.04,
               bottom_offset=0.01)


def drop(hydro, seconds, start_depth=2.0, floor=40.0, gas=0.0):
    x = np.array([0.0, 0.0, start_depth, 0.0, 0.0, 0.0])
    states, where = [x], []
    for _ in range(round(seconds / DT)):
        x, w = fb.step(x, hydro, DT, floor, gas)
        states.append(x)
        where.append(w)
    return np.array(states), where


def test_in_water_weight_and_terminal_speed_formula():
    weight = BAR.in_water_weight()
    assert weight == pytest.approx((1.0 - RHO / 7850.0) * G)  # 8.53 N
    assert BAR.terminal_speed() == pytest.approx(math.sqrt(2 * weight / (RHO * 1.2 * 0.018)))


def test_a_dropped_tool_reaches_the_terminal_speed_within_5_percent():
    """sqrt(2 W / (rho C_d A)) = 0.877 m/s for the bar; after 3 s of fall (about 50 drag
    time constants) the simulated speed is within 5 % of it (in fact within 0.1 %)."""
    states, where = drop(BAR, 3.0)
    assert set(where) == {"water"}
    v_t = BAR.terminal_speed()
    assert v_t == pytest.approx(0.877, abs=0.001)
    assert states[-1, 5] == pytest.approx(v_t, rel=0.05)
    assert states[-1, 5] == pytest.approx(v_t, rel=1e-3)
    assert np.all(states[:, 5] <= v_t * (1 + 1e-9))  # from rest it never overshoots
    np.testing.assert_allclose(states[:, 3:5], 0.0)  # straight down in still water


def test_the_fall_follows_the_exact_tanh_solution():
    states, _ = drop(BAR, 1.0)
    exact = [fb.fall_speed(BAR, k * DT) for k in range(len(states))]
    np.testing.assert_allclose(states[:, 5], exact, rtol=1e-6, atol=1e-9)


def test_it_lands_and_rests_on_the_floor():
    states, where = drop(BAR, 6.0, start_depth=2.0, floor=5.0)
    landed = where.index("floor")
    assert 3.0 / 0.877 < landed * DT < 3.0 / 0.877 + 0.5  # 3 m at about terminal speed
    assert set(where[landed:]) == {"floor"}
    rest = states[landed + 1:]
    np.testing.assert_allclose(rest, np.broadcast_to([0, 0, 5.0 - 0.01, 0, 0, 0], rest.shape))


def test_a_light_object_rises_to_the_surface_and_floats():
    float_ = fb.Hydro(mass=0.5, volume=1e-3, drag_coefficient=0.47, area=0.01)
    assert float_.in_water_weight() < 0.0
    states, where = drop(float_, 10.0, start_depth=3.0)
    assert states[:, 5].min() == pytest.approx(-float_.terminal_speed(), rel=1e-3)
    assert where[-1] == "surface" and states[-1, 2] == 0.0


def test_boyle_law_and_the_bag_capacity():
    # 50 surface litres at 10 m: p0 / (p0 + rho g 10) = 0.502 of it
    assert fb.gas_volume(50.0, 10.0) == pytest.approx(0.050 * 101325 / (101325 + RHO * G * 10))
    assert fb.gas_volume(50.0, 0.0) == pytest.approx(0.050)
    assert fb.gas_volume(500.0, 10.0, capacity_m3=0.1) == 0.1  # the open bag spills
    assert fb.gas_volume(50.0, -1.0) == pytest.approx(0.050)


LOAD = fb.Hydro(mass=60.0, volume=60.0 / 7850.0, drag_coefficient=1.1, area=0.25,
                bottom_offset=0.2)
BAG = fb.Hydro(mass=1.5, volume=1.2e-3, drag_coefficient=1.0, area=0.01)


@pytest.mark.parametrize("margin,lifts", [(1.05, True), (0.95, False)])
def test_a_lift_bag_lifts_only_when_rho_g_v_exceeds_the_in_water_weight(margin, lifts):
    """A 60 kg steel load (W = 510 N in water) with a bag: V litres of gas at the load's
    depth lift it only when rho g V > W (the bag's own in-water weight included)."""
    system = fb.combine(LOAD, BAG, drag_coefficient=1.1, area=0.35, bottom_offset=0.2)
    weight = system.in_water_weight()
    depth = 12.0
    litres_needed = weight / (RHO * G) * 1e3  # at depth
    gas = 1e-3 * margin * litres_needed
    assert (RHO * G * gas > weight) is lifts
    x = np.array([0.0, 0.0, depth - 0.2, 0.0, 0.0, 0.0])  # resting on a 12 m floor
    for _ in range(round(5.0 / DT)):
        x, where = fb.step(x, system, DT, depth, gas)
    if lifts:
        assert where == "water" and x[2] < depth - 0.2 - 0.5 and x[5] < 0.0
        # rising at the terminal speed of the small net lift
        assert -x[5] == pytest.approx(system.terminal_speed(gas), rel=0.02)
    else:
        assert where == "floor" and x[2] == depth - 0.2


def test_a_neutral_object_is_carried_by_the_current_as_quadratic_drag_predicts():
    """Released at rest in a current c, a neutrally buoyant object's speed relative to the
    water decays as |v_r| = |c| / (1 + k |c| t), k = rho C_d A / (2 (m + m_a))."""
    neutral = fb.Hydro(mass=1.0, volume=1.0 / RHO, drag_coefficient=1.0, area=0.01)
    current = np.array([0.2, -0.1, 0.0])
    k = RHO * 1.0 * 0.01 / (2.0 * neutral.inertia())
    x = np.array([0.0, 0.0, 3.0, 0.0, 0.0, 0.0])
    for step in range(1, round(20.0 / DT) + 1):
        x, _ = fb.step(x, neutral, DT, math.nan, water_velocity=current)
        if step % 300 == 0:
            c = np.linalg.norm(current)
            expected = c / (1.0 + k * c * step * DT)
            assert np.linalg.norm(x[3:] - current) == pytest.approx(expected, rel=1e-4)
    # always along the current
    np.testing.assert_allclose(np.cross(x[3:], current), 0.0, atol=1e-12)


def test_bad_parameters_are_clear_errors():
    with pytest.raises(ConfigError, match=r"Hydro.area: must be a finite number > 0"):
        fb.Hydro(mass=1.0, volume=1e-4, drag_coefficient=1.0, area=0.0)
    with pytest.raises(ConfigError, match="state must be 6 finite numbers"):
        fb.step(np.zeros(3), BAR, DT, 5.0)
