"""Closed-loop behavior tests: the helm drives a tiny kinematic vehicle.

Vehicle (written here, first principles): heading turns toward DESIRED_HEADING at most
``turn_rate`` deg/s (the short way), speed relaxes first-order (time constant ``tau``) to
DESIRED_SPEED, depth moves toward DESIRED_DEPTH at most ``dive_rate`` m/s. Integration at
0.1 s; the helm runs at 4 Hz (on the first 0.1 s tick at or after each multiple of 0.25 s).
Positions in MOOS local coordinates (x east, y north), compass headings.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from tests.support.kinematic_vehicle import Kinematic
from uhrisim.autonomy import Helm, HelmConfig, NodeReport, format_node_report, load_bhv
from uhrisim.autonomy.geometry import parse_polygon

DATA = Path(__file__).resolve().parents[1] / "data" / "helm"
ALERT_VARS = ("TRAIL_INFO", "CONTACT_INFO", "DEPTH_UPDATES", "LOITER_UPDATES")


def run(helm, veh, t_end, contact=None, contact_name="diver", events=None, on_tick=None):
    """Integrate to ``t_end``; ``contact(t) -> (x, y, hdg, spd)``; ``events``: {t: mail}."""
    events = dict(events or {})
    outs = []
    n = round(t_end / 0.1)
    last_slot = -1
    for k in range(n + 1):
        t = k * 0.1
        slot = (2 * k) // 5
        if slot != last_slot:
            last_slot = slot
            mail = veh.nav()
            if contact is not None:
                cx, cy, ch, cv = contact(t)
                mail["NODE_REPORT"] = format_node_report(
                    NodeReport(contact_name, cx, cy, cv, ch, 0.0, time=t)
                )
            for te in [te for te in events if te <= t + 1e-9]:
                mail.update(events.pop(te))
            out = helm.step(t, mail)
            veh.desired.update({k2: v for k2, v in out.posts if k2.startswith("DESIRED_")})
            outs.append((t, veh.x, veh.y, veh.heading, veh.speed, veh.depth, out))
            if on_tick is not None:
                on_tick(t, veh, out)
        veh.step(0.1)
    return outs


def _rel_errors(outs, contact, trail_range, t0, t1):
    """Max |range - trail_range| and max |bearing error| (deg, from the contact's stern)."""
    r_err, b_err = 0.0, 0.0
    for t, x, y, *_ in outs:
        if not (t0 <= t <= t1):
            continue
        cx, cy, ch, _ = contact(t)
        rng = math.hypot(x - cx, y - cy)
        brg = math.degrees(math.atan2(x - cx, y - cy))
        rel = (brg - (ch + 180.0) + 180.0) % 360.0 - 180.0
        r_err, b_err = max(r_err, abs(rng - trail_range)), max(b_err, abs(rel))
    return r_err, b_err


def test_loiter_traces_the_octagon_lap_after_lap():
    cfg = HelmConfig.from_mapping(
        {
            "behaviors": [
                {
                    "type": "Loiter",
                    "name": "loiter",
                    "speed": 1.0,
                    "slip_radius": 4,
                    "polygon": "format=radial, x=10, y=-20, radius=20, pts=8",
                }
            ]
        }
    )
    h = Helm(cfg, "diver")
    seq = []

    def tick(t, veh, out):
        idx = h.behavior("loiter").index
        if not seq or seq[-1] != idx:
            seq.append(idx)

    outs = run(h, Kinematic(0.0, 0.0, 180.0), 260.0, on_tick=tick)
    # vertex sequence: consecutive clockwise (k -> k+1 mod 8), more than two full laps
    assert all((b - a) % 8 == 1 for a, b in itertools.pairwise(seq))
    assert len(seq) >= 17 and h.behavior("loiter").laps >= 2
    # every vertex really visited: passes within capture radius (3 m) + turning slack 1 m
    xy = np.array([(o[1], o[2]) for o in outs])
    verts = parse_polygon("format=radial, x=10, y=-20, radius=20, pts=8")
    for vx, vy in verts:
        assert np.min(np.hypot(xy[:, 0] - vx, xy[:, 1] - vy)) < 3.0
    # and the path stays near the polygon (inside the circumscribed circle + 3 m)
    assert np.max(np.hypot(xy[50:, 0] - 10, xy[50:, 1] + 20)) < 23.0


def test_trail_settles_behind_a_straight_then_turning_contact():
    cfg = HelmConfig.from_mapping(
        {
            "behaviors": [
                {
                    "type": "Trail",
                    "name": "trail",
                    "contact": "diver",
                    "pwt": 300,
                    "trail_range": 2,
                    "trail_angle": 180,
                    "radius": 0.2,
                    "nm_radius": 5,
                }
            ]
        }
    )
    v, t_turn, rate = 0.5, 150.0, 3.0

    def contact(t):  # north at 0.5 m/s, then a 90 deg turn to the east at 3 deg/s
        if t <= t_turn:
            return (10.0, v * t, 0.0, v)
        tt = t - t_turn
        a = math.radians(rate * min(tt, 30.0))
        R = v / math.radians(rate)
        x, y = 10.0 + R * (1 - math.cos(a)), v * t_turn + R * math.sin(a)
        return (x + v * max(tt - 30.0, 0.0), y, rate * min(tt, 30.0), v)

    outs = run(Helm(cfg, "rov"), Kinematic(0.0, 0.0, 180.0), 320.0, contact=contact)
    for t0, t1 in ((90.0, 150.0), (250.0, 320.0)):  # settled on each leg, and staying there
        r_err, b_err = _rel_errors(outs, contact, 2.0, t0, t1)
        assert r_err < 0.5 and b_err < 15.0, (t0, r_err, b_err)


@pytest.mark.parametrize(
    "geometry",
    ["head_on", "crossing"],
)
def test_avoid_collision_keeps_cpa_and_reaches_waypoint(geometry):
    min_cpa = 5.0
    cfg = HelmConfig.from_mapping(
        {
            "behaviors": [
                {
                    "type": "Waypoint",
                    "name": "wpt",
                    "points": "0,100",
                    "speed": 1.0,
                    "capture_radius": 3,
                    "slip_radius": 6,
                    "endflag": "ARRIVED = true",
                },
                {
                    "type": "AvoidCollision",
                    "name": "avd",
                    "contact": "boat",
                    "pwt": 200,
                    "pwt_outer_dist": 30,
                    "pwt_inner_dist": 10,
                    "completed_dist": 200,
                    "min_util_cpa_dist": min_cpa,
                    "max_util_cpa_dist": 10,
                    "pwt_grade": "linear",
                },
            ]
        }
    )
    if geometry == "head_on":  # reciprocal courses on the same line
        contact = lambda t: (0.0, 100.0 - t, 180.0, 1.0)  # noqa: E731
    else:  # from the east, meeting own track at (0, 50) at t = 50 like own ship
        contact = lambda t: (50.0 - t, 50.0, 270.0, 1.0)  # noqa: E731
    # without avoidance: own ship (north at 1 m/s) and the contact meet at (0, 50) at t = 50
    assert math.hypot(*np.subtract(contact(50.0)[:2], (0.0, 50.0))) < 1e-9
    outs = run(
        Helm(cfg, "rov"), Kinematic(0.0, 0.0, 0.0), 140.0, contact=contact, contact_name="boat"
    )
    closest = min(math.hypot(o[1] - contact(o[0])[0], o[2] - contact(o[0])[1]) for o in outs)
    assert closest > min_cpa
    arrived = [o[0] for o in outs if ("ARRIVED", "true") in o[-1].posts]
    assert len(arrived) == 1 and arrived[0] < 130.0
    assert math.hypot(outs[-1][1], outs[-1][2] - 100.0) < 3.0 + 0.5
    assert any("avd" in o[-1].active for o in outs)  # it did act


def test_constant_depth_holds_depth():
    cfg = HelmConfig.from_mapping(
        {
            "behaviors": [
                {"type": "ConstantDepth", "name": "depth", "depth": 3,
                 "duration": "no-time-limit"},
                {"type": "Waypoint", "name": "go", "points": "0,1000", "speed": 1},
            ]
        }
    )
    outs = run(Helm(cfg, "rov"), Kinematic(0.0, 0.0, 0.0), 40.0)
    assert all(o[-1].decision.depth == 3.0 for o in outs)
    assert all(abs(o[5] - 3.0) < 1e-6 for o in outs if o[0] > 6.5)  # 3 m at 0.5 m/s: 6 s
    assert max(o[5] for o in outs) <= 3.0 + 1e-9


def test_mode_switches_change_active_behaviors():
    h = Helm(load_bhv(DATA / "meta_vehicle.bhv", known_vars=ALERT_VARS), "videoray")
    diver = lambda t: (10.0, 0.0, 180.0, 0.0)  # noqa: E731  (holding station)
    spawn = "name=diver # contact=diver"
    events = {
        1.0: {"DEPLOY": "true", "TRAIL_INFO": spawn, "CONTACT_INFO": spawn},
        40.0: {"TRAIL": "false"},
        100.0: {"RETURN": "true"},
    }
    seen = {}

    def tick(t, veh, out):
        seen.setdefault(out.mode, (t, out.active))

    outs = run(h, Kinematic(0.0, 0.0, 180.0), 200.0, contact=diver, events=events, on_tick=tick)
    assert seen["INACTIVE"][1] == ()
    assert seen["ACTIVE:TRAILING"][1] == ("const_depth", "trail_diver")
    assert "loiter" in seen["ACTIVE:LOITERING"][1]
    assert "waypt_return" in seen["ACTIVE:RETURNING"][1]
    # the return waypoint's endflags (STATION_KEEP = true, RETURN = false) switch the mode
    assert "station-keep" in seen["ACTIVE:STATION-KEEPING"][1]
    t_sk = seen["ACTIVE:STATION-KEEPING"][0]
    assert 100.0 < t_sk < 200.0
    final = outs[-1]
    assert math.hypot(final[1], final[2]) < 2.0 + 2.0  # holds near the return point (0, 0)
    modes = [o[-1].mode for o in outs]
    order = list(dict.fromkeys(modes))
    assert order == [
        "INACTIVE",
        "ACTIVE:TRAILING",
        "ACTIVE:LOITERING",
        "ACTIVE:RETURNING",
        "ACTIVE:STATION-KEEPING",
    ]
