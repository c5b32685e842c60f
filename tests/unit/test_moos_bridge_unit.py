"""MOOS bridge pieces without a network: geodesy, NODE_REPORT, MOOS time, frame mapping.

Provenance: the geodesy numbers are computed here from first principles (arc length on
a sphere of radius R: 1 m north = 1/R rad; at the equator CMOOSGeodesy's R is the WGS-84
semi-major axis 6378137 m); MOOS time = wall clock x MOOSTimeWarp (MOOS v10
MOOSLocalTime); the NODE_REPORT layout is docs/reference/helm.md's.
"""

from __future__ import annotations

import math

import pytest

from uhrisim.autonomy.contacts import parse_node_report
from uhrisim.bridges.moos.bridge import MoosAgentBridge
from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.geodesy import latlon_from_local, local_from_latlon, moos_grid_radius
from uhrisim.core.errors import BridgeError


def test_grid_radius_limits():
    assert moos_grid_radius(0.0) == pytest.approx(6378137.0, abs=1e-6)  # a at the equator
    assert moos_grid_radius(89.9999) == pytest.approx(6356752.0, abs=1.0)  # -> b at the pole
    # geocentric radius of the ellipsoid: 1/R^2 = cos^2/a^2 + sin^2/b^2
    lat = math.radians(42.358456)
    r = 1.0 / math.sqrt(math.cos(lat) ** 2 / 6378137.0**2 + math.sin(lat) ** 2 / 6356752.0**2)
    assert moos_grid_radius(42.358456) == pytest.approx(r, rel=1e-12)


def test_latlon_first_principles():
    # equator: 1000 m north is 1000/a rad of latitude, 1000 m east is 1000/a rad of longitude
    lat, lon = latlon_from_local(1000.0, 1000.0, 0.0, 10.0)
    assert lat == pytest.approx(math.degrees(math.asin(1000.0 / 6378137.0)), rel=1e-12)
    assert lon == pytest.approx(10.0 + math.degrees(math.asin(1000.0 / 6378137.0)), rel=1e-12)
    # at 60 N a metre east spans twice the longitude (cos 60 = 1/2)
    lat0 = 60.0
    r = moos_grid_radius(lat0)
    _, lon = latlon_from_local(10.0, 0.0, lat0, 0.0)
    assert lon == pytest.approx(math.degrees(10.0 / (r * 0.5)), rel=1e-9)
    assert latlon_from_local(0.0, 0.0, 42.0, -71.0) == (42.0, -71.0)


@pytest.mark.parametrize("lat0", [-33.9, 0.0, 42.358456, 60.0])
def test_geodesy_roundtrip_within_documented_error(lat0):
    r = moos_grid_radius(lat0)
    for x, y in [(100.0, 100.0), (-250.0, 40.0), (1000.0, -1000.0)]:
        la, lo = latlon_from_local(x, y, lat0, -71.0)
        x2, y2 = local_from_latlon(la, lo, lat0, -71.0)
        assert y2 == pytest.approx(y, abs=1e-6)
        # MOOS's pair is not an exact inverse: x2 = x cos(lat)/cos(lat0) exactly ...
        assert x2 == pytest.approx(x * math.cos(math.radians(la)) / math.cos(
            math.radians(lat0)), rel=1e-9)
        # ... i.e. about x*y*tan(lat0)/R (+ x(y/R)^2/2), the error documented in geodesy.py
        bound = abs(x * y * math.tan(math.radians(lat0)) / r) * 1.01 + abs(x) * (y / r) ** 2
        assert abs(x2 - x) <= bound


def test_moos_time_is_wallclock_times_warp():
    c = MoosClient(time_warp=10.0, wall_clock=lambda: 1_700_000_000.5)
    assert c.moos_time() == 17_000_000_005.0
    c.skew = 0.25
    assert c.moos_time() == 17_000_000_005.0  # skew not applied by default
    c.apply_skew = True
    assert c.moos_time() == 17_000_000_005.25
    with pytest.raises(BridgeError, match="time_warp"):
        MoosClient(time_warp=0.0)


class _RecordingClient(MoosClient):
    """A MoosClient that never touches the network and records what would be posted."""

    def __init__(self) -> None:
        super().__init__(wall_clock=lambda: 1000.0)
        self.posts: list[tuple[list, float | None]] = []

    def connect(self, host="127.0.0.1", port=9000, name="x", *, strict=False, timeout_s=3.0):
        self.name = name

    def notify_many(self, items, time=None):
        self.posts.append((list(items), time))
        return True


def test_publish_nav_maps_ned_to_moos_frame_and_units():
    c = _RecordingClient()
    b = MoosAgentBridge("videoray", lat_origin=42.0, long_origin=-71.0, client=c,
                        time_source="sim")
    assert c.name == "uhrisim_videoray"
    assert set(c._registrations) == {"DESIRED_HEADING", "DESIRED_SPEED", "DESIRED_DEPTH"}
    b.publish_nav(2.5, x_north=10.0, y_east=-3.0, depth=2.0, heading_deg=-90.0, speed_mps=1.2)
    items, t = c.posts[-1]
    vals = dict(items)
    assert vals["NAV_X"] == -3.0 and vals["NAV_Y"] == 10.0  # x east, y north
    assert vals["NAV_DEPTH"] == 2.0 and vals["NAV_SPEED"] == 1.2
    assert vals["NAV_HEADING"] == 270.0  # compass degrees in [0, 360)
    lat, lon = latlon_from_local(-3.0, 10.0, 42.0, -71.0)
    assert (vals["NAV_LAT"], vals["NAV_LONG"]) == (lat, lon)
    assert lat > 42.0 and lon < -71.0  # north and west of the origin
    assert t == 1000.0 + 2.5  # sim time source: MOOS time at creation + t_sim
    rep = parse_node_report(vals["NODE_REPORT"])
    assert (rep.x, rep.y, rep.heading, rep.depth, rep.speed) == (-3.0, 10.0, 270.0, 2.0, 1.2)
    assert rep.time == 1002.5 and rep.type == "UUV" and rep.name == "videoray"
    assert (rep.lat, rep.lon) == pytest.approx((lat, lon), abs=1e-8)
    with pytest.raises(BridgeError, match="non-finite"):
        b.publish_nav(3.0, math.nan, 0.0, 0.0, 0.0, 0.0)


def test_publish_nav_equals_the_general_formulas():
    """publish_nav's values and text are exactly those of latlon_from_local, wrap_360 and
    format_node_report(NodeReport(...)), for random states, headings of any range
    (0 and 360 included) and odd type/mode strings."""
    import numpy as np

    from uhrisim.autonomy.contacts import NodeReport, format_node_report
    from uhrisim.core.frames import wrap_360

    rng = np.random.default_rng(9)
    c = _RecordingClient()
    b = MoosAgentBridge("videoray", lat_origin=42.358456, long_origin=-71.087589, client=c,
                        time_source="sim")
    headings = [0.0, -0.0, 360.0, -360.0, 720.5, -1e-12, 359.999999, *rng.uniform(-1e3, 1e3, 200)]
    for i, hdg_in in enumerate(headings):
        n, e, d, spd = rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(0, 50), \
            rng.uniform(0, 3)
        if i % 9 == 0:
            n, e, d, spd = -0.0, 0.0, 0.0, -0.0
        vtype, mode = [("UUV", "MODE@ACTIVE:TRAIL"), ("KAYAK", "NONE"), ("", "X"),
                       ("UUV", "")][i % 4]
        t_sim = float(rng.uniform(0, 1e4))
        b.publish_nav(t_sim, n, e, d, hdg_in, spd, vtype, 1.5, mode)
        items, t = c.posts[-1]
        vals = dict(items)
        hdg = float(wrap_360(hdg_in))
        lat, lon = latlon_from_local(float(e), float(n), 42.358456, -71.087589)
        assert vals == {
            "NAV_X": e, "NAV_Y": n, "NAV_DEPTH": d, "NAV_HEADING": hdg, "NAV_SPEED": spd,
            "NAV_LAT": lat, "NAV_LONG": lon,
            "NODE_REPORT": format_node_report(NodeReport(
                name="videoray", x=e, y=n, speed=spd, heading=hdg, depth=d, lat=lat, lon=lon,
                type=vtype, mode=mode, time=t, length=1.5)),
        }
        assert math.copysign(1.0, vals["NAV_HEADING"]) == math.copysign(1.0, hdg)
