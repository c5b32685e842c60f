"""Each behavior's objective function at hand-computed states (no vehicle, no helm loop)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.autonomy.behaviors import BehaviorContext, ContactInfo, OwnNav
from uhrisim.autonomy.behaviors.avoid_collision import PIECE, cpa_utility, relevance
from uhrisim.autonomy.behaviors.trail import FAR_PIECE
from uhrisim.autonomy.config import build_behavior_spec
from uhrisim.autonomy.cpa import cpa_distance
from uhrisim.autonomy.domain import Domain
from uhrisim.autonomy.ivp_build import reflect
from uhrisim.core.errors import ConfigError

D = Domain.paper()
SPD = D.axis("speed").values


def make(kind: str, **params):
    items = [(k, v, "test") for k, v in {"name": "b", **params}.items()]
    return build_behavior_spec(kind, items, "test").instantiate()


def ctx(own: OwnNav, t: float = 0.0, **contacts) -> BehaviorContext:
    """A tick at ``t`` with contacts ``name=(x, y, heading, speed)`` reported at t = 0."""
    ledger = {name: ContactInfo(name, x, y, h, v, 0.0, 0.0)
              for name, (x, y, h, v) in contacts.items()}  # fmt: skip
    return BehaviorContext(t, D, {}, own, ledger)


def argmax_cs(obj) -> tuple[float, float]:
    i, j = np.unravel_index(np.argmax(obj.values), obj.values.shape)
    return float(i), float(SPD[j])


@pytest.mark.slow
def test_trail_regimes():
    b = make("Trail", contact="diver", trail_range=2, radius=1, nm_radius=5)
    diver = (0.0, 0.0, 0.0, 1.0)  # at the origin, heading north at 1 m/s -> P = (0, -2)
    assert b.trail_point(0.0, 0.0, 0.0) == pytest.approx((0.0, -2.0))
    # middle regime: own (3, -4), D = sqrt(13) = 3.61; aim at A = P + 5 north = (0, 3):
    # bearing atan2(-3, 7) = -23.2 deg -> 336.8 -> grid 337; ahead_by = -2 -> 1*(1+0.2)
    c = ctx(OwnNav(3.0, -4.0, 0.0, 1.0), diver=diver)
    obj = b.on_run(c)
    assert c.posts == [("VIEW_POINT", "x=0.00,y=-2.00,label=b")]
    assert obj.axes == ("course", "speed") and obj.values.max() == pytest.approx(100.0)
    assert argmax_cs(obj) == (337.0, pytest.approx(1.2))
    # inside radius: match the contact's heading and speed
    obj = b.on_run(ctx(OwnNav(0.3, -2.0, 90.0, 0.0), diver=diver))
    assert argmax_cs(obj) == (0.0, pytest.approx(1.0))
    # far regime (D = 30 > 5): 100 (1 - cpa/D) against a virtual contact at P ...
    obj = b.on_run(ctx(OwnNav(30.0, -2.0, 0.0, 0.0), diver=diver))
    crs, spd = D.axis("course").values, SPD
    cpa = cpa_distance(30.0, -2.0, crs[:, None], spd[None, :], 0.0, -2.0, 0.0, 1.0, 60.0)
    exact = np.clip(100.0 - 100.0 * cpa / 30.0, 0.0, 100.0)
    assert np.allclose(exact[:, 0], 0.0)  # standing still: cpa = D (abeam, t* = 0)
    # west at 1 m/s: r0 = (30, 0), w = (-1, -1), t* = 15, cpa = |(15, -15)| = 21.21
    assert exact[270, 5] == pytest.approx(100.0 * (1.0 - math.sqrt(450.0) / 30.0))
    # ... handed over as pHelmIvP builds it: 3 x 2-index pieces, normalised 0..100
    # (BHV_Trail.cpp:43, 219-243, 333; the build itself is held to MOOS-IvP in
    # test_helm_ivp_build.py)
    np.testing.assert_array_equal(obj.values, reflect(exact, FAR_PIECE))
    assert (obj.values.min(), obj.values.max()) == pytest.approx((0.0, 100.0))
    assert abs(obj.values - exact).max() > 1.0  # the pieces are not the exact table
    # relative vs absolute trail angle
    b2 = make("Trail", contact="diver", trail_range=2, trail_angle=90, trail_angle_type="absolute")
    assert b2.trail_point(0.0, 0.0, 45.0) == pytest.approx((2.0, 0.0))
    # no contact information: no function and a warning (on_no_contact_ok defaults to
    # true; false makes it an error, which halts the helm: IvPContactBehavior.cpp:533-541)
    c = ctx(OwnNav(0, 0, 0, 0))
    assert b.on_run(c) is None and [v for v, _ in c.posts] == ["BHV_WARNING"]
    b3 = make("Trail", contact="diver", on_no_contact_ok="false")
    c = ctx(OwnNav(0, 0, 0, 0))
    assert b3.on_run(c) is None and c.posts[0][0] == "BHV_ERROR"
    # an 11 s old report is used where it puts the contact: pHelmIvP dead-reckons no
    # contact (IvPContactBehavior.cpp:568-591), whatever extrapolate and decay say
    c = ctx(OwnNav(3.0, -4.0, 0.0, 1.0), t=11.0, diver=diver)
    np.testing.assert_array_equal(b.on_run(c).values, b.on_run(ctx(
        OwnNav(3.0, -4.0, 0.0, 1.0), diver=diver)).values)
    assert c.posts == [("VIEW_POINT", "x=0.00,y=-2.00,label=b")]
    # extrapolate = false: the speed summit is 0 near the trail point (BHV_Trail.cpp:273)
    b4 = make("Trail", contact="diver", trail_range=2, radius=1, nm_radius=5, extrapolate="false")
    assert argmax_cs(b4.on_run(ctx(OwnNav(3.0, -4.0, 0.0, 1.0), diver=diver))) == (337.0, 0.0)
    # pwt_outer_dist: off AT that range already (BHV_Trail.cpp:372-375)
    b5 = make("Trail", contact="diver", trail_range=2, pwt_outer_dist=5)
    assert b5.on_run(ctx(OwnNav(3.0, -4.0, 0.0, 1.0), diver=diver)) is None
    assert b5.on_run(ctx(OwnNav(3.0, -3.9, 0.0, 1.0), diver=diver)) is not None


def test_avoid_collision_relevance_and_utility():
    assert relevance(35.0, 50.0, 20.0, "linear") == pytest.approx(0.5)
    assert relevance(35.0, 50.0, 20.0, "quadratic") == pytest.approx(0.25)
    assert relevance(35.0, 50.0, 20.0, "quasi") == pytest.approx(0.5**1.5)
    assert relevance(60.0, 50.0, 20.0, "linear") == 0.0
    assert relevance(20.0, 50.0, 20.0, "quasi") == 1.0
    # inside pwt_inner_dist the relevance grows past 1 (BHV_AvoidCollision.cpp:484-497)
    assert relevance(10.0, 50.0, 20.0, "quasi") == pytest.approx((40.0 / 30.0) ** 1.5)
    assert relevance(0.5, 3.0, 1.0, "quasi") == pytest.approx(1.3975, abs=1e-4)
    u = cpa_utility(np.array([4.0, 8.0, 16.5, 25.0, 30.0]), 8.0, 25.0)
    assert u == pytest.approx([0.0, 25.0, 62.5, 100.0, 100.0])  # 25 + 75 * 8.5/17 = 62.5


def test_avoid_collision_objective_head_on():
    b = make("AvoidCollision", contact="boat", pwt_outer_dist=50, pwt_inner_dist=20,
             completed_dist=75, min_util_cpa_dist=8, max_util_cpa_dist=25)  # fmt: skip
    boat = (0.0, 10.0, 180.0, 1.0)  # 10 m ahead, coming straight at us
    # first build: nothing, the domain has depth (BHV_AvoidCollision.cpp:51-54, 315-331)
    assert b.on_run(ctx(OwnNav(0.0, 0.0, 0.0, 1.0), boat=boat)) is None
    obj = b.on_run(ctx(OwnNav(0.0, 0.0, 0.0, 1.0), boat=boat))
    assert b.priority_scale == pytest.approx((40.0 / 30.0) ** 1.5)  # range 10 < inner 20
    crs = D.axis("course").values
    exact = cpa_utility(cpa_distance(0.0, 0.0, crs[:, None], SPD[None, :],
                                     0.0, 10.0, 180.0, 1.0, 120.0), 8.0, 25.0)  # fmt: skip
    assert exact[0, 5] == 0.0  # north at 1 m/s: cpa 0
    # east at 5 m/s: w = (5, 1), r0 = (0, -10), t* = 10/26, r = (1.923, -9.615), cpa 9.806
    cpa = math.hypot(5 * 10 / 26, -10 + 10 / 26)
    assert exact[90, 25] == pytest.approx(25 + 75 * (cpa - 8) / 17)
    # handed over as 3 x 3-index pieces normalised 0..100: no candidate clears 25 m
    # (exact peak < 100), the normalised one peaks at 100 all the same
    assert exact.max() < 100.0
    np.testing.assert_array_equal(obj.values, reflect(exact, PIECE))
    assert (obj.values.min(), obj.values.max()) == pytest.approx((0.0, 100.0))
    # range already inside min_util_cpa_dist (6 < 8): min becomes range/2 = 3
    c = ctx(OwnNav(0.0, 0.0, 0.0, 0.0), boat=(0.0, 6.0, 0.0, 0.0))
    exact = cpa_utility(cpa_distance(0.0, 0.0, crs[:, None], SPD[None, :],
                                     0.0, 6.0, 0.0, 0.0, 120.0), 3.0, 25.0)  # fmt: skip
    assert exact[180, 0] == pytest.approx(25 + 75 * (6 - 3) / 22)  # stay: cpa = 6
    np.testing.assert_array_equal(b.on_run(c).values, reflect(exact, PIECE))
    # min above max_util_cpa_dist: the AOF cannot start, no function and an error
    b2 = make("AvoidCollision", contact="boat", min_util_cpa_dist=30, max_util_cpa_dist=25,
              pwt_outer_dist=50, pwt_inner_dist=20)  # fmt: skip
    c = ctx(OwnNav(0.0, 0.0, 0.0, 0.0), boat=(0.0, 40.0, 180.0, 1.0))  # range 40 > min 30
    assert b2.on_run(c) is None and c.posts[0][0] == "BHV_ERROR"
    # completed at 1.1 x completed_dist (82.5 m), not before (BHV_AvoidCollision.cpp:275)
    c = ctx(OwnNav(0.0, 0.0, 0.0, 0.0), boat=(0.0, 80.0, 0.0, 0.0))
    assert b.on_run(c) is None and not b.complete_requested  # beyond outer: no relevance
    c = ctx(OwnNav(0.0, 0.0, 0.0, 0.0), boat=(0.0, 82.5, 0.0, 0.0))
    assert b.on_run(c) is None and b.complete_requested
    # ... and while idle too (l.226)
    b3 = make("AvoidCollision", contact="boat", completed_dist=75)
    b3.on_idle(ctx(OwnNav(0.0, 0.0, 0.0, 0.0), boat=(0.0, 90.0, 0.0, 0.0)))
    assert b3.complete_requested


def test_constant_depth_function():
    b = make("ConstantDepth", depth=3)
    obj = b.on_run(ctx(OwnNav(0, 0, 0, 0)))
    assert obj.axes == ("depth",)
    # pw 3, bw 100, delta 50: d=2 -> 100 - 50/3*2; d=47 -> 50 - 50*44/100
    assert obj.values[[3, 5, 50]] == pytest.approx([100.0, 100 - 100 / 3, 28.0])


def test_waypoint_lead_and_station_keep_speeds():
    w = make("Waypoint", points="0,100", speed=1.0, lead=5, lead_to_start=True)
    w.start_mark = (0.0, 0.0)  # where the behavior started: the first track line's anchor
    # own (3, 10): perpendicular foot (0, 10), steer 5 m further: (0, 15) -> atan2(-3, 5)
    assert w.steer_point(3.0, 10.0) == pytest.approx((0.0, 15.0))
    obj = w.on_run(ctx(OwnNav(3.0, 10.0, 0.0, 1.0)))
    assert argmax_cs(obj) == (329.0, pytest.approx(1.0))  # 360 - 30.96 -> 329
    assert w.steer_point(0.0, 98.0) == (0.0, 100.0)  # never past the point
    # without lead_to_start there is no track line before the first point
    w2 = make("Waypoint", points="0,100", speed=1.0, lead=5)
    w2.start_mark = (0.0, 0.0)
    assert w2.steer_point(3.0, 10.0) == (0.0, 100.0)
    # lead_damper 4: 1 m off the line -> lead * (1 + 2 * (1 - 1/4)) = 5 * 2.5 = 12.5 m
    w3 = make("Waypoint", points="0,100", speed=1.0, lead=5, lead_damper=4, lead_to_start=1)
    w3.start_mark = (0.0, 0.0)
    assert w3.steer_point(1.0, 10.0) == pytest.approx((0.0, 22.5))
    # speed ZAIC (pw speed/2, bw 1.6, delta 20) and the heading-hold course component
    c = ctx(OwnNav(0.0, 50.0, 90.0, 1.0))
    obj = w2.on_run(c)
    assert argmax_cs(obj) == (0.0, pytest.approx(1.0))
    assert obj.values[0, 5] > obj.values[0, 7] > obj.values[0, 3] - 1e-9  # 1.0 > 1.4 vs 0.6
    # heading-hold component: own heading 170, point due north. Courses 170 and 190 are
    # equally bad for the point (100 (1 - 170/180) = 5.6) but 170 holds the heading (20)
    # while 190 is 20 deg off it (20 - 5 * 20/30 = 16.7)
    obj = w2.on_run(ctx(OwnNav(0.0, 50.0, 170.0, 1.0)))
    assert obj.values[170, 5] > obj.values[190, 5]
    s = make("StationKeep", station_pt="0,0", inner_radius=4, outer_radius=15)
    # transit_speed defaults to 2.5 m/s (BHV_StationKeep.cpp:62)
    assert [s.desired_speed(d) for d in (3.0, 9.5, 20.0)] == pytest.approx([0.0, 0.6, 2.5])
    # the tick the station is set: speed 0 toward it (BHV_StationKeep.cpp:371-376)
    assert argmax_cs(s.on_run(ctx(OwnNav(0.0, 9.5, 90.0, 0.0)))) == (180.0, 0.0)
    obj = s.on_run(ctx(OwnNav(0.0, 9.5, 90.0, 0.0)))
    assert argmax_cs(obj) == (180.0, pytest.approx(0.6))  # head back south at 1.2*5.5/11
    # outer_speed above transit_speed raises it (l.168-169); radii must be > 0
    s2 = make("StationKeep", station_pt="0,0", outer_speed=3.0)
    assert s2.params.transit_speed == 3.0
    with pytest.raises(ConfigError, match="inner_radius must be > 0"):
        make("StationKeep", station_pt="0,0", inner_radius=0)


def test_loiter_function_points_at_the_current_vertex():
    b = make("Loiter", polygon="0,0 : 0,20 : 20,20 : 20,0", speed=1.4, acquire_dist=5)
    c = ctx(OwnNav(10.0, -30.0, 0.0, 1.0))  # 30 m south of the square: acquire mode
    obj = b.on_run(c)
    assert b.acquire_mode and ("LOITER_ACQUIRE", "true") in c.posts
    view = dict(c.posts)["VIEW_POLYGON"]  # pMarineViewer-style, clockwise vertices
    assert view == "pts={0.00,0.00:0.00,20.00:20.00,20.00:20.00,0.00},label=b"
    tx, ty = b.vertices[b.index]
    brg = math.degrees(math.atan2(tx - 10.0, ty + 30.0)) % 360.0
    assert argmax_cs(obj) == (float(round(brg)), pytest.approx(1.4))
    # clockwise acquisition from the south: approach vector to (0, 0) is (-10, 30), mostly
    # north, and its clockwise onward edge runs north up the west side (cos = 0.95); the
    # south-east corner's onward edge runs west, against the approach (cos = -0.32)
    assert (tx, ty) == (0.0, 0.0)
    assert b.vertices[(b.index + b.direction) % 4] == (0.0, 20.0)
    # counter-clockwise: (20, 0) now continues north up the east side -> chosen instead
    b2 = make("Loiter", polygon="0,0 : 0,20 : 20,20 : 20,0", speed=1.4, clockwise="false")
    b2.on_run(ctx(OwnNav(10.0, -30.0, 0.0, 1.0)))
    assert b2.vertices[b2.index] == (20.0, 0.0) and b2.direction == -1


def test_waypoint_flags_repeat_and_completion():
    w = make("Waypoint", points="0,10 : 0,20", speed=1, repeat=1, wptflag="HIT = $[X],$[Y]",
             cycleflag=["LAP = true"])  # fmt: skip
    seen = []
    for y in (0.0, 9.0, 19.0, 9.5, 19.5):
        c = ctx(OwnNav(0.0, y, 0.0, 1.0))
        obj = w.on_run(c)
        seen.append(([v for v, _ in c.posts if v in ("HIT", "LAP")], w.index, obj is None))
    assert seen == [
        ([], 0, False),
        (["HIT"], 1, False),  # (0, 10) within capture radius 3
        (["HIT", "LAP"], 0, False),  # end of the first pass: repeat once
        (["HIT"], 1, False),
        (["HIT", "LAP"], 1, True),  # second pass done: complete, no function
    ]
    assert w.complete_requested and w.finished
    c = ctx(OwnNav(0.0, 9.0, 0.0, 1.0))
    w.reset()
    w.on_run(c)
    assert dict(c.posts)["HIT"] == "0.00,10.00"


def test_station_keep_swing_and_hibernation():
    s = make("StationKeep", center_activate=True, swing_time=3, hibernation_radius=8,
             inner_radius=2, outer_radius=6, outer_speed=0.6, transit_speed=1.0)  # fmt: skip
    s.on_run_start(ctx(OwnNav(0.0, 0.0, 0.0, 0.5), t=0.0))
    s.on_run(ctx(OwnNav(1.0, 0.0, 0.0, 0.5), t=1.0))  # still swinging: station follows
    assert s.station == (1.0, 0.0)
    steps = []
    for t, x in ((4.0, 2.0), (5.0, 10.0), (6.0, 5.2), (7.0, 2.5)):
        c = ctx(OwnNav(x, 0.0, 90.0, 0.5), t=t)
        obj = s.on_run(c)
        steps.append((s.state, argmax_cs(obj)[1], dict(c.posts).get("PSKEEP_MODE")))
    assert s.station == (1.0, 0.0)  # fixed once the swing time is over
    assert steps == [
        ("hibernating", 0.0, None),  # d = 1: inside, speed 0 (mode posted at t = 1)
        ("seeking_station", pytest.approx(1.0), "SEEKING_STATION"),  # d = 9 > 8: transit
        ("seeking_station", pytest.approx(0.4), None),  # d = 4.2: 0.6*2.2/4 = 0.33 -> 0.4
        ("hibernating", 0.0, "HIBERNATING"),  # d = 1.5 <= inner radius 2
    ]


def test_loiter_acquisition_rules():
    sq = "0,0 : 0,20 : 20,20 : 20,0"  # clockwise order as stored
    b = make("Loiter", polygon=sq, speed=1.0)
    # outside, south: only the two south corners are visible from (10, -30)
    assert b._visible_vertices(10.0, -30.0) == [0, 3]
    # turns onto the onward clockwise edge: (0,0): 341.6 -> 0 = +18.4; (20,0): 18.4 -> 270
    approaches = b._approaches(10.0, -30.0)
    assert b._turn(approaches, 0, 1) == pytest.approx(18.435, abs=1e-3)
    assert b._turn(approaches, 3, 1) == pytest.approx(-108.435, abs=1e-3)
    assert b.acquire(10.0, -30.0, 0.0) == (0, 1)  # clockwise: the largest turn
    # best: heading 350 is 8.4 deg from the clockwise entry (341.6) and 28.4 from 18.4
    best = make("Loiter", polygon=sq, speed=1.0, clockwise="best")
    assert best.acquire(10.0, -30.0, 350.0) == (0, 1)
    assert best.acquire(10.0, -30.0, 30.0) == (3, -1)
    # inside at the centre: every vertex needs a 135 deg turn; the one ahead (heading 45,
    # vertex (20, 20)) wins with the 2 deg spiral bonus
    assert b.acquire(10.0, 10.0, 45.0) == (2, 1)
    # acquire mode is only FARTHER than acquire_dist OUTSIDE (BHV_Loiter.cpp:301-303): deep
    # inside, a loiter running from the first iteration heads for vertex 0; one that goes
    # from idle to running picks its vertex (onIdleToRunState, l.270-278)
    from uhrisim.autonomy.geometry import signed_dist_to_polygon

    assert signed_dist_to_polygon(10.0, 10.0, b.vertices) == -10.0
    assert signed_dist_to_polygon(10.0, -30.0, b.vertices) == 30.0
    inner = make("Loiter", polygon=sq, speed=1.0, acquire_dist=5)
    inner.on_run(ctx(OwnNav(10.0, 10.0, 45.0, 1.0)))
    assert not inner.acquire_mode and inner.index == 0
    inner.on_run_start(ctx(OwnNav(10.0, 10.0, 45.0, 1.0)))
    inner.on_run(ctx(OwnNav(10.0, 10.0, 45.0, 1.0)))
    assert not inner.acquire_mode and inner.index == 2
    inner.on_run(ctx(OwnNav(10.0, 18.0, 45.0, 1.0)))  # 2 m from the north edge: on-poly
    assert not inner.acquire_mode


def test_constant_heading_peak_snaps_wraps_and_completes():
    """BHV_ConstantHeading: a wrapping peak at the heading snapped to the grid (pw 10,
    bw 170, δ 25); complete_thresh completes it; the mismatch is posted."""
    b = make("ConstantHeading", heading=-10.4, duration="no-time-limit",
             heading_mismatch_var="HDG_MISMATCH")
    c = ctx(OwnNav(0.0, 0.0, 20.0, 0.0))
    obj = b.on_run(c)
    crs = D.axis("course").values
    assert obj.axes == ("course",)
    assert crs[int(np.argmax(obj.values))] == 350.0  # -10.4 -> 349.6 -> grid 350
    assert obj.values[int(np.where(crs == 355.0)[0][0])] == pytest.approx(100 - 25 * 5 / 10)
    assert obj.values[int(np.where(crs == 5.0)[0][0])] == pytest.approx(75 * (1 - 5 / 170))
    assert obj.values[int(np.where(crs == 170.0)[0][0])] == 0.0
    assert c.posts == [("HDG_MISMATCH", 30.0)]
    done = make("ConstantHeading", heading=350, complete_thresh=5, duration="no-time-limit")
    assert done.on_run(ctx(OwnNav(0.0, 0.0, 353.0, 0.0))) is None and done.complete_requested


def test_max_speed_is_a_ceiling():
    """BHV_MaxSpeed: 100 at or below max_speed, down to 0 over basewidth above it."""
    b = make("MaxSpeed", max_speed=0.3, basewidth=0.2, speed_slack_var="SLACK")
    c = ctx(OwnNav(0.0, 0.0, 0.0, 0.5))
    obj = b.on_run(c)
    assert obj.axes == ("speed",)
    expected = np.clip(100.0 * (1.0 - (SPD - 0.3) / 0.2), 0.0, 100.0)
    np.testing.assert_allclose(obj.values, expected)
    assert c.posts == [("SLACK", pytest.approx(-0.2))]
    assert make("MaxSpeed", max_speed=-1).params.max_speed == 0.0  # IvP clips at 0


def test_constant_speed_peak_clipped_at_zero():
    """BHV_ConstantSpeed: a peak at the speed (pw 0, bw 0.2); IvP clips a negative speed
    to 0; the mismatch is posted."""
    b = make("ConstantSpeed", speed=0.4, duration="no-time-limit", speed_mismatch_var="MIS")
    c = ctx(OwnNav(0.0, 0.0, 0.0, 1.0))
    obj = b.on_run(c)
    np.testing.assert_allclose(obj.values, np.clip(100.0 * (1 - np.abs(SPD - 0.4) / 0.2), 0, None))
    assert c.posts == [("MIS", pytest.approx(0.6))]
    still = make("ConstantSpeed", speed=-1.0, duration="no-time-limit")
    assert float(SPD[int(np.argmax(still.on_run(ctx(OwnNav(0, 0, 0, 0))).values))]) == 0.0
