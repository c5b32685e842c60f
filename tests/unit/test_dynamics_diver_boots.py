"""The commercial diver on weighted boots: feet on a sloped floor, gait, buoyancy."""

import math

import numpy as np
import pytest

from uhrisim.dynamics import diver_boots as bt
from uhrisim.dynamics import free_body as fb
from uhrisim.world import seafloor

DT = 1.0 / 60.0
PARAMS = bt.BootsParams()
SKELETON = PARAMS.skeleton


def start_on(floor, north=0.0, east=0.0, psi=0.0):
    state = bt.BootsState((north, east, 0.0), psi)
    return bt.BootsState((north, east, bt.standing_hip_depth(state, PARAMS, floor)), psi)


def walk(floor, commands, seconds, legs=True):
    """Run the gait; yield (state, q (None without ``legs``), result) every tick."""
    state = start_on(floor)
    q = SKELETON.zeros()
    for k in range(round(seconds / DT)):
        result = bt.step(state, commands(k * DT), PARAMS, DT, floor)
        state = result.state
        if legs:
            q = bt.leg_angles(state, PARAMS, floor, q)
        yield state, q if legs else None, result


@pytest.mark.parametrize("speed", [PARAMS.cruise_speed, PARAMS.max_speed])
def test_a_walking_diver_stays_on_a_sloped_floor_within_5_cm(speed):
    """A 25 % slope (deeper towards 030°), walking 30 s with a turn every 5 s: every
    stance sole (by forward kinematics of the posed legs) is within 5 cm of the floor
    under it (in fact within 5 mm), no swinging sole goes more than 5 cm into it, no
    joint leaves its limits or exceeds its speed."""
    floor = seafloor.sloped(10.0, 0.25, direction_deg=30.0, extent=60.0).depth_at

    def commands(t):
        return bt.BootsCommand(speed, math.radians(15.0) if int(t / 5.0) % 2 else 0.0)

    worst_stance, deepest_swing, previous = 0.0, 0.0, None
    for state, q, result in walk(floor, commands, 30.0):
        assert result.notes == []
        assert SKELETON.limit_violations(q) == []
        if previous is not None:
            assert np.all(np.abs(q - previous) / DT <= SKELETON.max_speed)
        previous = q
        lifts = bt.foot_offsets(state, PARAMS)
        for side, sole in bt.sole_positions(state, PARAMS, q).items():
            height = floor(sole[0], sole[1]) - sole[2]  # > 0: above the floor
            if lifts[side][1] == 0.0:
                worst_stance = max(worst_stance, abs(height))
            else:
                deepest_swing = min(deepest_swing, height)
    assert worst_stance < 0.05
    assert worst_stance < 0.005
    assert deepest_swing > -0.05
    # it went somewhere, up and down the slope, and the hips followed the floor
    hip_above_floor = floor(state.position[0], state.position[1]) - state.position[2]
    assert 0.85 < hip_above_floor < SKELETON.body.hip_height


def test_gait_steps_at_the_stride_frequency():
    floor = seafloor.flat(12.0, 60.0).depth_at
    steps = [len(r.footfalls)
             for _, _, r in walk(floor, lambda t: bt.BootsCommand(0.3), 60.0, legs=False)]
    # after 1 s of speeding up (0.3 m/s²), 0.3 m/s over a 0.7 m stride: 2 steps per stride
    distance = 0.3 * 60.0 - 0.5 * 0.3 * 1.0
    assert sum(steps) == pytest.approx(2 * distance / 0.7, abs=1.0)


def test_footfalls_are_on_the_floor_where_the_foot_lands():
    floor = seafloor.sloped(10.0, 0.1, extent=40.0).depth_at
    for _, _, result in walk(floor, lambda t: bt.BootsCommand(0.4), 10.0):
        for fall in result.footfalls:
            assert fall.position[2] == pytest.approx(floor(*fall.position[:2]))


def test_the_turn_rate_and_the_speed_are_limited():
    floor = seafloor.flat(12.0, 60.0).depth_at
    states = [s for s, _, _ in walk(floor, lambda t: bt.BootsCommand(3.0, 2.0), 5.0, False)]
    assert states[-1].psi == pytest.approx(5.0 * PARAMS.max_turn_rate)
    assert max(s.speed for s in states) == pytest.approx(PARAMS.max_speed)


def test_crouching_lowers_the_hips_stops_walking_and_reaches_a_basket():
    """Crouching fully (2 s at 0.5 /s) brings the hips down to the legs' deepest reach;
    the crouched diver does not walk, and bending at the waist its right hand reaches a
    grasp point 0.25 m above the floor 0.5 m ahead (a wrench in a tool basket), which a
    standing diver's arm alone does not."""
    from uhrisim.dynamics.diver_body import solve_reach

    floor = seafloor.flat(12.0, 30.0).depth_at
    states = [s for s, _, _ in walk(floor, lambda t: bt.BootsCommand(0.3, crouch=1.0), 3.0,
                                    legs=False)]
    state = states[-1]
    assert state.crouch == 1.0 and state.speed == 0.0
    assert state.position[0] < 0.01  # a step's start before the crouch stopped it
    above = 12.0 - state.position[2]
    reach = bt.leg_reach(PARAMS, 1.0)
    # the foot that limits: the one on the floor farthest from under the hips
    legs = [math.sqrt(reach ** 2 - forward ** 2) + lift
            for forward, lift in bt.foot_offsets(state, PARAMS).values()]
    assert above == pytest.approx(min(legs) + SKELETON.body.ankle_height, abs=1e-9)
    assert 0.5 < above < 0.65 < 12.0 - start_on(floor).position[2]
    q = bt.leg_angles(state, PARAMS, floor, SKELETON.zeros())
    assert SKELETON.limit_violations(q) == []
    target = np.array([0.5, SKELETON.shoulder(q, "right")[1], 12.0 - 0.25])
    assert solve_reach(SKELETON, "right", target - np.array(state.position), q, bend=True).ok
    standing = start_on(floor).position
    assert not solve_reach(SKELETON, "right", target - np.array(standing), q).ok  # arm alone


def test_bending_over_from_the_hips_keeps_the_feet_where_they_are():
    """Tilting the pelvis forward (posture) the legs are re-solved: both soles stay on the
    floor (1 mm), the hips flex the more, and a hand reaches the floor 0.4 m ahead. The
    tilt is capped at what the more flexed hip leaves (max_pelvis_tilt)."""
    from uhrisim.dynamics.diver_body import solve_reach

    floor = seafloor.flat(10.0, 30.0).depth_at
    state = start_on(floor)
    upright = bt.leg_angles(state, PARAMS, floor, SKELETON.zeros())
    target = np.array([0.4, 0.2, 10.0 - 0.01]) - np.array(state.position)
    reach = solve_reach(SKELETON, "right", target, upright, bend=True,
                        max_tilt=bt.max_pelvis_tilt(PARAMS, upright))
    assert reach.ok and reach.q[SKELETON.index("posture")] > math.radians(30)
    bent = bt.leg_angles(state, PARAMS, floor, reach.q)
    assert SKELETON.limit_violations(bent) == []
    for side, sole in bt.sole_positions(state, PARAMS, bent).items():
        assert sole == pytest.approx(bt.sole_positions(state, PARAMS, upright)[side], abs=1e-3)
        assert floor(*sole[:2]) - sole[2] == pytest.approx(0.0, abs=5e-3)
    flex = SKELETON.index("left_hip_flex")
    assert bent[flex] > upright[flex] + math.radians(30)


def test_a_slope_steeper_than_walkable_stops_the_diver():
    floor = seafloor.sloped(10.0, 0.5, extent=40.0).depth_at  # 50 %: deeper to the north
    results = [r for _, _, r in walk(floor, lambda t: bt.BootsCommand(0.3), 2.0)]
    assert results[-1].state.speed == 0.0
    assert results[-1].notes == ["too_steep: slope -0.50 ahead, limit 0.30"]


def test_it_cannot_rise_without_changing_its_buoyancy():
    """Two minutes of random walking commands with the suit valve shut: never afloat,
    the hips always a leg's length above the floor."""
    floor = seafloor.procedural(4, extent=60.0, mean_depth=12.0, roughness=0.4).depth_at
    rng = np.random.default_rng(5)
    plan = rng.uniform([-0.2, -0.5], [0.6, 0.5], size=(121, 2))

    def commands(t):
        speed, turn = plan[int(t)]
        return bt.BootsCommand(speed, turn, 0)

    for state, _, _ in walk(floor, commands, 120.0, legs=False):
        assert not state.afloat
        above = floor(state.position[0], state.position[1]) - state.position[2]
        assert 0.75 < above < SKELETON.body.hip_height


def test_inflating_the_suit_lifts_the_diver_when_boyle_says_and_dumping_lands_it():
    floor = seafloor.flat(12.0, 60.0).depth_at
    state = start_on(floor)
    depth = state.position[2]
    # lift when rho g V(z) > W: V = W / (rho g) at depth, n = V (p0 + rho g z) / p0
    needed = (PARAMS.in_water_weight / (fb.WATER_DENSITY * fb.GRAVITY) * 1e3
              * (1.0 + fb.WATER_DENSITY * fb.GRAVITY * depth / fb.ATMOSPHERE_PA))
    t, lifted_at = 0.0, None
    while lifted_at is None and t < 60.0:
        result = bt.step(state, bt.BootsCommand(suit=1), PARAMS, DT, floor)
        state, t = result.state, t + DT
        if "lift_off" in result.notes:
            lifted_at = t
    assert lifted_at == pytest.approx(needed / PARAMS.inflate_lps, abs=2 * DT)
    for k in range(round(8.0 / DT)):  # 3 s more gas, then hold: it rises as its gas swells
        command = bt.BootsCommand(suit=1 if k * DT < 3.0 else 0)
        state = bt.step(state, command, PARAMS, DT, floor).state
    assert state.afloat and state.velocity[2] < 0.0 and state.position[2] < depth - 0.2
    notes = []
    for _ in range(round(60.0 / DT)):  # dump: it sinks back and lands, feet on the floor
        result = bt.step(state, bt.BootsCommand(suit=-1), PARAMS, DT, floor)
        state = result.state
        notes += result.notes
        if "landed" in notes:
            break
    assert notes == ["landed"] and not state.afloat
    assert state.position[2] == pytest.approx(depth, abs=0.02)
