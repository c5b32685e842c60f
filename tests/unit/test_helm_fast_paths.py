"""The helm's fast numerical paths are held to their plain reference transcriptions.

Each fast function performs the same floating-point operations as its reference (only
fewer temporaries, cached constants, reductions taken from 1-D pieces), so the check is
bit-for-bit equality (``tobytes``), over random arguments drawn to hit every branch
(zero widths, clipped summit delta, wrapping, constant inputs).
"""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.autonomy.behaviors.avoid_collision import cpa_utility
from uhrisim.autonomy.behaviors.base import BehaviorContext, OwnNav
from uhrisim.autonomy.conditions import Relation, VarRef, field_match
from uhrisim.autonomy.config import HelmConfig
from uhrisim.autonomy.coupler import couple, couple_reference, coupled_objective
from uhrisim.autonomy.cpa import CpaGrid, avoid_utility_inplace, cpa_distance
from uhrisim.autonomy.domain import Domain, DomainAxis, Objective
from uhrisim.autonomy.geometry import (
    _dist_to_segment,
    parse_polygon,
    point_in_polygon,
    signed_dist_to_polygon,
)
from uhrisim.autonomy.solver import WeightedObjective, solve, solve_reference
from uhrisim.autonomy.zaic import ZaicMemo, zaic_peak, zaic_peak_on_axis, zaic_peak_reference

COURSE = DomainAxis("course", 0.0, 359.0, 360, wrap=True)
SPEED = DomainAxis("speed", 0.0, 2.0, 41)
DOMAIN = Domain((COURSE, SPEED))


def _zaic_args(rng: np.random.Generator) -> tuple[float, ...]:
    return (
        float(rng.uniform(-10.0, 400.0)),  # summit (outside the axis too)
        float(rng.choice([0.0, 1e-12, rng.uniform(0.0, 60.0)])),  # peakwidth
        float(rng.choice([0.0, rng.uniform(0.0, 200.0)])),  # basewidth
        float(rng.choice([0.0, rng.uniform(-10.0, 120.0)])),  # summitdelta (clipped)
        float(rng.choice([0.0, rng.uniform(0.0, 20.0)])),  # minutil
        float(rng.choice([100.0, rng.uniform(30.0, 100.0)])),  # maxutil
    )


def test_zaic_peak_bit_identical_to_reference():
    rng = np.random.default_rng(7)
    for _ in range(2000):
        args = _zaic_args(rng)
        for axis in (COURSE, SPEED):
            wrap = axis.period if axis.wrap else None
            fast = zaic_peak(axis.values, *args, wrap_period=wrap)
            ref = zaic_peak_reference(axis.values, *args, wrap_period=wrap)
            assert fast.tobytes() == ref.tobytes(), args


@pytest.mark.parametrize("x", [0.0, 40.0, 55.0, 400.0])
def test_zaic_peak_scalar_input_matches_reference(x):
    fast = zaic_peak(x, 50.0, 10.0, 20.0, 30.0, wrap_period=360.0)
    assert float(fast) == float(zaic_peak_reference(x, 50.0, 10.0, 20.0, 30.0, wrap_period=360.0))


def test_couple_bit_identical_to_reference():
    rng = np.random.default_rng(11)
    for k in range(600):
        fc = zaic_peak(COURSE.values, *_zaic_args(rng), wrap_period=360.0)
        fs = zaic_peak(SPEED.values, *_zaic_args(rng))
        if k % 5 == 0:
            fs = np.full(SPEED.npts, 3.0)  # constant piece: rescales to its top value
        if k % 7 == 0:
            fc = rng.normal(size=COURSE.npts)
        for w in ((50.0, 50.0), (30.0, 70.0)):
            ref = couple_reference(fc, fs, *w)
            assert couple(fc, fs, *w).tobytes() == ref.tobytes()
            objective = coupled_objective(DOMAIN, fc, fs, w)
            assert objective.value_range == (ref.min(), ref.max())
        assert np.array_equal(couple(fc, fs, normalize=False),
                              couple_reference(fc, fs, normalize=False))  # fmt: skip


def test_zaic_memo_returns_the_same_function_and_recomputes_on_change():
    memo = ZaicMemo()
    a = memo(SPEED, 0.5, 0.0, 0.3, 0.0)
    assert memo(SPEED, 0.5, 0.0, 0.3, 0.0) is a  # repeated arguments: reused
    assert not a.flags.writeable
    assert np.array_equal(a, zaic_peak_on_axis(SPEED, 0.5, 0.0, 0.3, 0.0))
    b = memo(SPEED, 0.7, 0.0, 0.3, 0.0)
    assert b is not a and np.array_equal(b, zaic_peak_on_axis(SPEED, 0.7, 0.0, 0.3, 0.0))


def test_cpa_grid_equals_cpa_distance():
    crs, spd = COURSE.values, SPEED.values
    grid = CpaGrid.over(crs, spd)
    rng = np.random.default_rng(3)
    for k in range(300):
        own = rng.uniform(-20.0, 20.0, 2)
        cn = own if k % 10 == 0 else rng.uniform(-20.0, 20.0, 2)  # r0 = 0 included
        h, v = float(rng.uniform(0.0, 360.0)), float(rng.choice([0.0, rng.uniform(0.0, 2.0)]))
        horizon = float(rng.choice([120.0, 60.0, 1.0, 0.0]))
        fast = grid.distance(own[0], own[1], cn[0], cn[1], h, v, horizon)
        ref = cpa_distance(own[0], own[1], crs[:, None], spd[None, :], cn[0], cn[1], h, v,
                           horizon)  # fmt: skip
        assert np.array_equal(fast, ref)  # == (a zero's sign may differ)


def test_avoid_utility_inplace_equals_cpa_utility():
    rng = np.random.default_rng(5)
    for _ in range(200):
        cpa = rng.uniform(0.0, 4.0, (36, 41))
        lo = float(rng.uniform(0.0, 2.0))
        hi = float(rng.choice([lo, lo + rng.uniform(0.0, 2.0)]))
        ref = cpa_utility(cpa, lo, hi)
        assert avoid_utility_inplace(cpa.copy(), lo, hi).tobytes() == ref.tobytes()


def test_avoid_collision_function_equals_reference_path():
    cfg = HelmConfig.from_mapping({"domain": {"course": [0, 359, 360], "speed": [0, 2, 41]},
                                   "behaviors": [{"type": "AvoidCollision", "name": "avd",
                                                  "contact": "diver", "pwt_outer_dist": 4,
                                                  "pwt_inner_dist": 1.5,
                                                  "min_util_cpa_dist": 1.0,
                                                  "max_util_cpa_dist": 1.5}]})  # fmt: skip
    b = cfg.behaviors[0].instantiate()
    rng = np.random.default_rng(9)
    for k in range(40):
        x, y = rng.uniform(-3.0, 3.0, 2)
        info = {"DIVER_NAV_X": float(x), "DIVER_NAV_Y": float(y),
                "DIVER_NAV_HEADING": float(rng.uniform(0, 360)),
                "DIVER_NAV_SPEED": float(rng.uniform(0, 1)), "DIVER_NAV_UTC": 0.0}  # fmt: skip
        own = OwnNav(0.0, 0.0, float(rng.uniform(0, 360)), 0.5, 1.0)
        ctx = BehaviorContext(0.5 * k / 40, cfg.domain, info, own)
        fast, ref = b.on_run(ctx), b.objective_reference(ctx)
        if ref is None or b.priority_scale <= 0.0:
            continue
        assert fast is not None and fast.values.tobytes() == ref.values.tobytes()


def test_solve_equals_reference_solver():
    dom = Domain((COURSE, SPEED, DomainAxis("depth", 0.0, 50.0, 26, optional=True)))
    rng = np.random.default_rng(13)
    for k in range(150):
        plateaus = rng.integers(0, 5, (360, 41)) * 25.0  # many exact ties
        objs = [WeightedObjective("cs", float(rng.uniform(1, 300)),
                                  Objective.over(dom, ("course", "speed"), plateaus))]  # fmt: skip
        if k % 2:
            objs.append(WeightedObjective("c", 50.0, Objective.over(
                dom, ("course",), rng.integers(0, 3, 360) * 10.0)))  # ties on purpose
        if k % 3:
            objs.append(WeightedObjective("cs2", 200.0, Objective.over(
                dom, ("course", "speed"), rng.uniform(0, 100, (360, 41)))))
        objs.append(WeightedObjective("d", 100.0, Objective.over(
            dom, ("depth",), rng.integers(0, 4, 26) * 1.0)))
        if k % 5 == 0:
            objs.append(WeightedObjective("off", 0.0, objs[0].objective))  # dropped
        if k % 4 == 0:  # joins all three axes into one component
            objs.append(WeightedObjective("sd", 30.0, Objective.over(
                dom, ("speed", "depth"), rng.integers(0, 3, (41, 26)) * 5.0)))
        if k % 7 == 0:  # depth before course in the objective list
            objs.reverse()
        fast, ref = solve(dom, objs), solve_reference(dom, objs)
        assert fast.decision == ref.decision and fast.indices == ref.indices
        assert list(fast.decision) == list(ref.decision)  # same axis order too
        assert fast.total == ref.total and fast.contributions == ref.contributions


def test_solve_reusing_a_lone_read_only_function_s_maximum_equals_reference():
    """A read-only table alone on its axes (ConstantDepth's) has its maximum found once per
    weighting: the same decision as the reference solver when the table, its priority or
    its renormalisation changes, and for ties (the first maximum)."""
    dom = Domain((COURSE, SPEED, DomainAxis("depth", 0.0, 50.0, 26, optional=True)))
    rng = np.random.default_rng(19)
    tables = [rng.integers(0, 4, 26) * 1.0, rng.integers(0, 4, 26) * 60.0]  # ties; > 100
    for t in tables:
        t.flags.writeable = False
    cs = Objective.over(dom, ("course", "speed"), rng.uniform(0, 100, (360, 41)))
    for k in range(12):
        depth = Objective.over(dom, ("depth",), tables[k % 2])
        objs = [WeightedObjective("cs", 100.0, cs),
                WeightedObjective("d", [100.0, 1e-300, 3.0][k % 3], depth)]
        fast, ref = solve(dom, objs), solve_reference(dom, objs)
        assert fast.indices == ref.indices and fast.contributions == ref.contributions


def test_solve_keeps_at_most_64_plans_and_equals_reference():
    """More span combinations than the solver keeps plans for (64 per domain): at most 64
    are kept, and every decision, contribution and all-stop equals the reference's."""
    from itertools import combinations, product

    from uhrisim.autonomy.solver import _PLANS_KEPT

    dom = Domain((DomainAxis("a", 0.0, 4.0, 5), DomainAxis("b", 0.0, 3.0, 4),
                  DomainAxis("c", 0.0, 2.0, 3, optional=True)))
    subsets = [c for k in (1, 2, 3) for c in combinations(dom.names, k)]  # 7 spans
    combos = list(product(subsets, repeat=2)) + list(product(subsets[:4], repeat=3))  # 113
    rng = np.random.default_rng(23)
    seen = set()
    for spans in combos:
        objs = [WeightedObjective(f"f{j}", float(rng.choice([1.0, 50.0, 200.0])),
                                  Objective.over(dom, axes, rng.integers(0, 4, dom.shape(axes))
                                                 * float(rng.choice([1.0, 60.0]))))
                for j, axes in enumerate(spans)]
        fast, ref = solve(dom, objs), solve_reference(dom, objs)
        seen.add(spans)
        assert 0 < len(dom.solver_plans) <= _PLANS_KEPT == 64
        assert fast.decision == ref.decision and fast.indices == ref.indices
        assert fast.all_stop_reason == ref.all_stop_reason
        assert fast.total == ref.total and fast.contributions == ref.contributions
    assert len(seen) > _PLANS_KEPT


def _signed_dist_reference(x: float, y: float, pts) -> float:
    n = len(pts)
    d = min(_dist_to_segment(x, y, pts[i], pts[(i + 1) % n]) for i in range(n))
    return -d if point_in_polygon(x, y, pts) else d


def test_signed_dist_to_polygon_equals_segment_by_segment_reference():
    rng = np.random.default_rng(17)
    polys = [parse_polygon("format=radial, x=10, y=-20, radius=20, pts=8"),
             parse_polygon("0,0:10,0:10,10:0,10")]  # fmt: skip
    for pts in polys:
        for k in range(2000):
            x, y = (pts[k % len(pts)] if k % 50 == 0  # exactly on a vertex
                    else (float(rng.uniform(-40, 40)), float(rng.uniform(-50, 30))))  # fmt: skip
            assert signed_dist_to_polygon(x, y, pts) == _signed_dist_reference(x, y, pts)


def _field_match_reference(a: str, b: str) -> bool:
    fa, fb = a.split(":"), b.split(":")
    short, long_ = (fa, fb) if len(fa) <= len(fb) else (fb, fa)
    n = len(short)
    return any(long_[i : i + n] == short for i in range(len(long_) - n + 1))


def test_condition_string_fast_path_equals_general_rules():
    """String vs string: '=' exact, '==' field match, others lexical (conditions.py)."""
    words = ["ACTIVE", "ACTIVE:TRAILING", "TRAILING", "A:B:C", "B:C", "B", "", ":", "A::B",
             "true", "3", "3.0"]  # fmt: skip
    lexical = {"!=": str.__ne__, "<": str.__lt__, ">": str.__gt__, "<=": str.__le__,
               ">=": str.__ge__}  # fmt: skip
    for a in words:
        for b in words:
            assert field_match(a, b) == _field_match_reference(a, b), (a, b)
            info = {"V": a, "W": b}
            assert Relation("V", "=", b).evaluate(info) == (a == b)
            assert Relation("V", "==", VarRef("W")).evaluate(info) == _field_match_reference(a, b)
            for op, f in lexical.items():
                assert Relation("V", op, b).evaluate(info) == f(a, b), (a, op, b)
    # a number on either side still compares numerically
    assert Relation("V", "=", 3.0).evaluate({"V": "3"})
    assert Relation("V", "=", "3").evaluate({"V": 3.0})
