"""Hand-computed numbers for the helm's primitives: ZAIC, coupler, CPA, extrapolator, solver.

Every expected value below is worked out in the comment next to it from the definitions
in docs/reference/helm.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.autonomy.coupler import couple, rescale
from uhrisim.autonomy.cpa import cpa_distance, cpa_distance_reference, cpa_time
from uhrisim.autonomy.domain import Domain, DomainAxis, Objective
from uhrisim.autonomy.extrapolator import LinearExtrapolator
from uhrisim.autonomy.solver import WeightedObjective, solve
from uhrisim.autonomy.zaic import zaic_heq, zaic_leq, zaic_peak, zaic_peak_on_axis
from uhrisim.core.errors import ConfigError

D = Domain.paper()


# ---------------------------------------------------------------------------- domain
def test_paper_domain_grids():
    crs, spd, dep = D.axis("course"), D.axis("speed"), D.axis("depth")
    assert (crs.npts, spd.npts, dep.npts) == (360, 26, 101)
    assert crs.delta == 1.0 and crs.period == 360.0
    assert spd.values[1] == pytest.approx(0.2) and spd.values[-1] == 5.0
    assert dep.optional and not crs.optional and crs.wrap
    assert crs.index_of(359.7) == 0  # circular: 359.7 is 0.3 from 0 and 0.7 from 359
    assert spd.index_of(0.61) == 3  # 0.61 / 0.2 = 3.05 -> 3


# ---------------------------------------------------------------------------- ZAIC
@pytest.mark.parametrize(
    ("x", "expected"),
    [
        (50.0, 100.0),  # summit
        (55.0, 80.0),  # in peak: 100 - (40/10)*5
        (45.0, 80.0),  # symmetric
        (60.0, 60.0),  # d = pw: 100 - 40
        (70.0, 30.0),  # base: 60 - 60 * (70-60)/20
        (80.0, 0.0),  # d = pw + bw: min
        (95.0, 0.0),  # beyond
        (30.0, 30.0),  # below: d = 20, same as x = 70
        (20.0, 0.0),  # below: d = 30 = pw + bw
    ],
)
def test_zaic_peak_values(x, expected):
    u = zaic_peak(x, summit=50.0, peakwidth=10.0, basewidth=20.0, summitdelta=40.0)
    assert float(u) == pytest.approx(expected)


def test_zaic_peak_wrap_course():
    # summit 350, query 10: circular distance 20; pw 0, bw 180, delta 0 -> 100*(1 - 20/180)
    u = zaic_peak([10.0, 350.0, 170.0, 260.0], 350.0, 0.0, 180.0, 0.0, wrap_period=360.0)
    assert u == pytest.approx([100.0 * (1 - 20 / 180), 100.0, 0.0, 50.0])
    # without wrap the same query is 340 away: zero
    assert float(zaic_peak(10.0, 350.0, 0.0, 180.0, 0.0)) == 0.0


def test_zaic_zero_peakwidth_ignores_delta_and_min_max():
    # pw = 0: the base starts at max (delta only shapes a plateau); min 10, max 60
    u = zaic_peak([2.0, 3.0, 4.0], 2.0, 0.0, 2.0, 30.0, minutil=10.0, maxutil=60.0)
    assert u == pytest.approx([60.0, 35.0, 10.0])  # 60 - 50 * (1/2) at d = 1


def test_zaic_insist_summit_between_grid_points():
    spd = D.axis("speed")
    # summit 0.55, bw 0.05: nearest grid points 0.4/0.6 are >= 0.05 away -> all min;
    # insist summit puts max on the grid point nearest 0.55, i.e. 0.6 (index 3)
    u = zaic_peak_on_axis(spd, 0.55, 0.0, 0.05, 0.0)
    assert u[3] == 100.0 and np.count_nonzero(u) == 1
    u2 = zaic_peak_on_axis(spd, 0.55, 0.0, 0.05, 0.0, insist_summit=False)
    assert not u2.any()
    # IvP's rule (ZAIC_PEAK.cpp:378-428): a half-way summit goes to the LOWER point, one
    # beyond the axis to its end - on a wrapping axis too (359.7 -> 359, not 0)
    assert zaic_peak_on_axis(spd, 0.5, 0.0, 0.05, 0.0)[2] == 100.0
    assert zaic_peak_on_axis(spd, 7.0, 0.0, 0.05, 0.0)[25] == 100.0
    assert zaic_peak_on_axis(spd, -1.0, 0.0, 0.05, 0.0)[0] == 100.0
    crs = D.axis("course")
    assert zaic_peak_on_axis(crs, 359.7, 0.0, 0.2, 0.0)[359] == 100.0


def test_zaic_on_course_axis_wraps():
    crs = D.axis("course")
    u = zaic_peak_on_axis(crs, 350.0, 0.0, 180.0, 0.0)
    assert u[10] == pytest.approx(100 * (1 - 20 / 180))
    assert u[350] == 100.0 and u[170] == 0.0 and u[330] == u[10]


def test_zaic_leq_heq():
    assert zaic_leq([1.0, 2.0, 3.0, 4.0, 5.0], 2.0, 2.0) == pytest.approx([100, 100, 50, 0, 0])
    assert zaic_heq([0.0, 1.0, 2.0, 3.0], 2.0, 2.0) == pytest.approx([0, 50, 100, 100])
    assert zaic_leq([2.0, 2.5], 2.0, 0.0) == pytest.approx([100, 0])


# ---------------------------------------------------------------------------- coupler
def test_coupler_scaling():
    fc = np.array([0.0, 50.0, 100.0])  # -> 0, 25, 50
    fs = np.array([10.0, 30.0, 20.0])  # -> 0, 50, 25
    F = couple(fc, fs)
    assert F.shape == (3, 3)
    assert F[1, 2] == pytest.approx(50.0)  # 25 + 25, already spanning 0..100
    assert F[2, 1] == pytest.approx(100.0) and F[0, 0] == 0.0
    # weights 70/30: fc -> 0, 35, 70; fs -> 0, 30, 15; F[1, 2] = 50, max 100
    F2 = couple(fc, fs, 70.0, 30.0)
    assert F2[1, 2] == pytest.approx(50.0) and F2[2, 0] == pytest.approx(70.0)
    # un-normalised sum with an offset input: fc rescaled to 0..50 regardless of offset
    F3 = couple(fc + 7.0, fs, normalize=False)
    assert F3[2, 1] == pytest.approx(100.0) and F3[0, 0] == pytest.approx(0.0)
    # a constant ("indifferent") function keeps its value, as PDMap::normalize leaves a
    # constant (PDMap.cpp:175-176); the normalised coupling then spans 0..100 all the same
    assert rescale(np.full(4, 3.0), 0.0, 50.0) == pytest.approx([3.0] * 4)
    F4 = couple(np.array([0.0, 100.0]), np.full(3, 9.0), normalize=False)
    assert pytest.approx(np.array([[9.0] * 3, [59.0] * 3])) == F4
    assert pytest.approx(np.array([[0.0] * 3, [100.0] * 3])) == couple(
        np.array([0.0, 100.0]), np.full(3, 9.0))
    assert pytest.approx(np.full((2, 3), 16.0)) == couple(np.full(2, 7.0), np.full(3, 9.0))


# ---------------------------------------------------------------------------- CPA
def test_cpa_crossing_tracks():
    # own (0,0) north at 1; contact (10,10) west at 1: both at (0,10) at t=10 -> 0
    # (sqrt of a rounding-level r^2 + 2bt + at^2 ~ 1e-14 m^2: sub-micron, hence abs=1e-6)
    assert float(cpa_distance(0, 0, 0.0, 1.0, 10, 10, 270.0, 1.0, 60)) == pytest.approx(0, abs=1e-6)
    # contact 2 m further north: r0 = (-10,-12), w = (1,1), t* = 22/2 = 11, r = (1,-1)
    assert float(cpa_time(0, 0, 0.0, 1.0, 10, 12, 270.0, 1.0, 60)) == pytest.approx(11.0)
    assert float(cpa_distance(0, 0, 0.0, 1.0, 10, 12, 270.0, 1.0, 60)) == pytest.approx(
        math.sqrt(2)
    )


def test_cpa_head_on_parallel_and_receding():
    # head-on with 3 m lateral offset: w = (0,2), t* = 40/4 = 10, r = (-3, 0)
    assert float(cpa_distance(0, 0, 0.0, 1.0, 3, 20, 180.0, 1.0, 60)) == pytest.approx(3.0)
    # parallel, same speed: range constant 5
    assert float(cpa_distance(0, 0, 0.0, 1.0, 5, 0, 0.0, 1.0, 60)) == pytest.approx(5.0)
    # overtaking a slower parallel contact 5 m abeam, 10 m ahead: closes 0.5 m/s, t*=20 -> 5
    assert float(cpa_distance(0, 0, 0.0, 1.0, 5, 10, 0.0, 0.5, 60)) == pytest.approx(5.0)
    # ... but with a 10 s horizon it only closes to (-5, -5): 5*sqrt(2)
    assert float(cpa_distance(0, 0, 0.0, 1.0, 5, 10, 0.0, 0.5, 10)) == pytest.approx(
        5 * math.sqrt(2)
    )
    # receding: contact 10 m astern going south, own north -> CPA is now, 10 m
    assert float(cpa_distance(0, 0, 0.0, 1.0, 0, -10, 180.0, 1.0, 60)) == pytest.approx(10.0)
    assert float(cpa_time(0, 0, 0.0, 1.0, 0, -10, 180.0, 1.0, 60)) == 0.0


def test_cpa_grid_matches_sampled_reference():
    crs, spd = D.axis("course").values, D.axis("speed").values
    grid = cpa_distance(3.0, -4.0, crs[:, None], spd[None, :], 20.0, 15.0, 200.0, 0.7, 120.0)
    assert grid.shape == (360, 26)
    rng = np.random.default_rng(7)
    for _ in range(25):
        i, j = rng.integers(360), rng.integers(26)
        ref = cpa_distance_reference(3.0, -4.0, crs[i], spd[j], 20.0, 15.0, 200.0, 0.7, 120.0)
        # sampling at 6 ms steps: the sampled minimum is within v_rel * dt / 2 of the true one
        assert grid[i, j] == pytest.approx(ref, abs=0.02)
        assert grid[i, j] <= ref + 1e-9


# ---------------------------------------------------------------------------- extrapolator
@pytest.mark.parametrize(
    ("dt", "dist", "maxed"),
    [
        (-1.0, 0.0, False),  # report from the future: no travel
        (3.0, 6.0, False),  # before decay: v*dt = 2*3
        (5.0, 10.0, False),  # at decay start
        (7.0, 13.2, False),  # 2*5 + 2*2 - 2*2^2/(2*5)
        (10.0, 15.0, False),  # decay end: 2*5 + 2*5/2
        (20.0, 15.0, True),  # frozen, decay maxed
    ],
)
def test_extrapolator_regimes(dt, dist, maxed):
    ex = LinearExtrapolator(5.0, 10.0)
    p = ex.extrapolate(1.0, 2.0, 90.0, 2.0, 100.0, 100.0 + dt)  # heading east
    assert p.distance == pytest.approx(dist)
    assert (p.x, p.y) == pytest.approx((1.0 + dist, 2.0))
    assert p.decay_maxed is maxed


def test_extrapolator_bad_decay():
    with pytest.raises(ConfigError):
        LinearExtrapolator(10.0, 5.0)


# ---------------------------------------------------------------------------- solver
def _random_objs(rng):
    cs = Objective.over(D, ("course", "speed"), rng.uniform(0, 100, (360, 26)))
    c = Objective.over(D, ("course",), rng.uniform(0, 100, 360))
    d = Objective.over(D, ("depth",), rng.uniform(0, 100, 101))
    return [
        WeightedObjective("cs", 2.0, cs),
        WeightedObjective("c", 0.5, c),
        WeightedObjective("d", 1.5, d),
    ]


def test_solver_matches_brute_force_and_audit_adds_up():
    rng = np.random.default_rng(3)
    objs = _random_objs(rng)
    res = solve(D, objs)
    full = (
        2.0 * objs[0].objective.values[:, :, None]
        + 0.5 * objs[1].objective.values[:, None, None]
        + 1.5 * objs[2].objective.values[None, None, :]
    )
    i, j, k = np.unravel_index(np.argmax(full), full.shape)
    assert (res.indices["course"], res.indices["speed"], res.indices["depth"]) == (i, j, k)
    assert res.total == pytest.approx(full.max())
    assert sum(res.contributions.values()) == pytest.approx(res.total)
    assert res.decision == {"course": float(i), "speed": pytest.approx(0.2 * j), "depth": float(k)}


def test_solver_tie_rule_first_in_c_order():
    flat = Objective.over(D, ("course", "speed"), np.full((360, 26), 7.0))
    res = solve(D, [WeightedObjective("flat", 1.0, flat)])
    assert res.decision == {"course": 0.0, "speed": 0.0}  # lowest course, then lowest speed
    v = np.zeros((360, 26))
    v[[40, 20], [5, 9]] = 1.0  # two equal maxima: course 20 comes first
    res = solve(D, [WeightedObjective("two", 1.0, Objective.over(D, ("course", "speed"), v))])
    assert res.decision == {"course": 20.0, "speed": pytest.approx(1.8)}


def test_solver_all_stop_cases():
    assert solve(D, []).decision is None
    assert solve(D, []).all_stop_reason == "NothingToDo"  # pHelmIvP's IVPHELM_ALLSTOP
    depth_only = WeightedObjective("d", 1.0, Objective.over(D, ("depth",), np.arange(101.0)))
    res = solve(D, [depth_only])
    assert res.decision is None and res.all_stop_reason == "MissingDecVars:course,speed"
    assert res.contributions == {"d": 100.0}  # audit still reported
    zero = WeightedObjective("z", 0.0, Objective.over(D, ("course", "speed"), np.ones((360, 26))))
    assert solve(D, [zero]).decision is None  # weight <= 0 is dropped


def test_objective_shape_checked():
    with pytest.raises(ConfigError):
        Objective.over(D, ("speed", "course"), np.zeros((26, 360)))
    with pytest.raises(ConfigError):
        Objective.over(D, ("course",), np.zeros(359))
    with pytest.raises(ConfigError):
        DomainAxis("speed", 1.0, 0.0, 5)
