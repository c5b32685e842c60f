"""Property tests (hypothesis) for the helm primitives and the solver's audit."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from uhrisim.autonomy import NodeReport, format_node_report, parse_node_report
from uhrisim.autonomy.cpa import cpa_distance, cpa_distance_reference
from uhrisim.autonomy.domain import Domain, Objective
from uhrisim.autonomy.extrapolator import LinearExtrapolator
from uhrisim.autonomy.solver import WeightedObjective, solve
from uhrisim.autonomy.zaic import zaic_peak

D = Domain.paper()
coord = st.floats(-200, 200, allow_nan=False)
heading = st.floats(0, 359.99, allow_nan=False)
speed = st.floats(0, 5, allow_nan=False)


@settings(max_examples=100, deadline=None)
@given(
    summit=st.floats(0, 360),
    pw=st.floats(0, 60),
    bw=st.floats(0, 180),
    delta=st.floats(0, 100),
    x=st.floats(0, 360),
)
def test_zaic_bounded_symmetric_and_monotone(summit, pw, bw, delta, x):
    u = zaic_peak([x, 2 * summit - x], summit, pw, bw, delta, wrap_period=None)
    assert 0.0 <= u[0] <= 100.0 and math.isclose(u[0], u[1], abs_tol=1e-9)
    d = np.linspace(0, 400, 401)
    ud = zaic_peak(summit + d, summit, pw, bw, delta)
    assert np.all(np.diff(ud) <= 1e-9)  # never increases away from the summit
    assert ud[0] == 100.0


@settings(max_examples=100, deadline=None)
@given(osx=coord, osy=coord, crs=heading, spd=speed, cnx=coord, cny=coord, cnh=heading,
       cnv=speed, T=st.floats(1, 300))  # fmt: skip
def test_cpa_bounded_by_current_range_and_matches_reference(osx, osy, crs, spd, cnx, cny, cnh,
                                                            cnv, T):  # fmt: skip
    cpa = float(cpa_distance(osx, osy, crs, spd, cnx, cny, cnh, cnv, T))
    r0 = math.hypot(osx - cnx, osy - cny)
    assert 0.0 <= cpa <= r0 + 1e-6
    ref = cpa_distance_reference(osx, osy, crs, spd, cnx, cny, cnh, cnv, T, n_samples=4001)
    # sampled minimum is within |w| dt / 2 above the true one (dt = T/4000, |w| <= 10 m/s)
    assert cpa <= ref + 1e-6 and ref - cpa <= 10.0 * T / 4000 / 2 + 1e-6


@settings(max_examples=100, deadline=None)
@given(v=speed, ds=st.floats(0, 20), span=st.floats(0, 20), dt1=st.floats(0, 60),
       dt2=st.floats(0, 60))  # fmt: skip
def test_extrapolated_distance_monotone_and_capped(v, ds, span, dt1, dt2):
    ex = LinearExtrapolator(ds, ds + span)
    a, b = sorted((dt1, dt2))
    da, _ = ex.travelled(v, a)
    db, maxed = ex.travelled(v, b)
    assert da <= db + 1e-9 and db <= v * ds + v * span / 2 + 1e-9
    assert maxed == (b > ds + span)


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 5))
def test_solver_audit_adds_up_and_is_the_grid_maximum(seed, n):
    rng = np.random.default_rng(seed)
    objs = []
    for i in range(n):
        axes = [("course", "speed"), ("course",), ("speed",), ("depth",)][rng.integers(4)]
        vals = rng.uniform(0, 100, tuple(D.axis(a).npts for a in axes))
        objs.append(WeightedObjective(f"b{i}", float(rng.uniform(0.1, 300)),
                                      Objective.over(D, axes, vals)))  # fmt: skip
    res = solve(D, objs)
    assert math.isclose(sum(res.contributions.values()), res.total, rel_tol=1e-12)
    full = np.zeros((360, 26, 101))
    for w in objs:
        shape = [1, 1, 1]
        for a, k in zip(w.objective.axes, w.objective.values.shape, strict=True):
            shape[D.names.index(a)] = k
        full += w.priority * w.objective.values.reshape(shape)
    covered = {a for w in objs for a in w.objective.axes}
    # maximise over uncovered axes trivially (constant): total equals the grid max
    assert math.isclose(res.total, full.max(), rel_tol=1e-12)
    assert (res.decision is None) == (not {"course", "speed"} <= covered)


name = st.text("abcdefghijklmnopqrstuvwxyz_0123456789", min_size=1, max_size=12)


@settings(max_examples=100, deadline=None)
@given(nm=name, x=coord, y=coord, s=speed, h=heading, d=st.floats(0, 100),
       t=st.floats(0, 1e6))  # fmt: skip
def test_node_report_round_trip_to_format_precision(nm, x, y, s, h, d, t):
    r = parse_node_report(format_node_report(NodeReport(nm, x, y, s, h, d, time=t)))
    assert r.name == nm
    assert abs(r.x - x) <= 5e-4 and abs(r.y - y) <= 5e-4 and abs(r.speed - s) <= 5e-4
    assert abs(((r.heading - h) + 180) % 360 - 180) <= 5e-3 and abs(r.time - t) <= 5e-4
