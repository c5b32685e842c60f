"""FrameBuilder: simulation ticks → viewer frames (NED, compass degrees, MOOS overlays).

Uses the simulation's own snapshot types (``uhrisim.sim.hooks``) where importable, so a
change there that breaks the viewer shows up here; expected numbers are computed from
the conventions (docs/conventions.md): heading_deg = wrap_360(degrees(yaw)), MOOS
(x east, y north) → (north, east), speed = hypot(u, v).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

from uhrisim.sensors.sonar import SonarInfo
from uhrisim.viz.viewer.adapt import (
    FrameBuilder,
    agent_kind,
    point_from_moos,
    polygon_from_moos,
    sonar_entry,
)

try:  # the simulation's types, when present
    from uhrisim.dynamics.plants import NavState
    from uhrisim.sim.community import Post
    from uhrisim.sim.hooks import AgentSnapshot
except ImportError:  # pragma: no cover - fall back to look-alikes
    NavState = AgentSnapshot = Post = None  # type: ignore[assignment,misc]


def _nav(n, e, d, yaw, u, v):
    if NavState is not None:
        return NavState(np.array([n, e, d]), yaw, np.array([u, v, 0.0]), 0.0)

    @dataclass
    class _Nav:
        position_ned: Any
        yaw: float
        velocity_body: Any
        yaw_rate: float = 0.0

        @property
        def speed(self):
            return math.hypot(self.velocity_body[0], self.velocity_body[1])

    return _Nav(np.array([n, e, d]), yaw, np.array([u, v, 0.0]))


def _snap(name, model, nav, mode):
    if AgentSnapshot is not None:
        return AgentSnapshot(name, model, nav, (0.0, 0.0, 0.0), 0.0, 0.0, 0.0, mode)

    @dataclass
    class _Snap:
        name: str
        model: str
        nav: Any
        mode: str

    return _Snap(name, model, nav, mode)


def _post(community, var, value, t=0.0):
    if Post is not None:
        return Post(community, var, value, t, "helm")

    @dataclass
    class _Post:
        community: str
        var: str
        value: Any
        t: float
        source: str

    return _Post(community, var, value, t, "helm")


@dataclass
class _Ping:
    t: float
    fan_u8: np.ndarray
    info: SonarInfo
    fan_rgb: np.ndarray | None = None


@dataclass
class _Tick:
    t: float
    agents: dict
    pings: dict = field(default_factory=dict)
    posts: tuple = ()


def _tick(t, posts=(), pings=None):
    return _Tick(t, {
        "videoray": _snap("videoray", "videoray", _nav(3.0, 4.0, 5.5, -math.pi / 2, 0.3, 0.4),
                          "TRAIL"),
        "diver": _snap("diver", "diver", _nav(3.0, 4.0 + 2.0, 5.5, math.radians(370.0), 0.5, 0.0),
                       "LOITER"),
    }, pings or {}, tuple(posts))


def test_agent_kinds():
    assert agent_kind("videoray", "rov1") == "rov"
    assert agent_kind("diver", "bob") == "diver"
    assert agent_kind("kinematic", "kayak") == "vehicle"


def test_agents_in_viewer_units():
    f = FrameBuilder().build(_tick(12.5), paused=True, speed_factor=2.0, rtf=1.9)
    assert (f["t"], f["paused"], f["speed_factor"], f["rtf"]) == (12.5, True, 2.0, 1.9)
    rov, diver = f["agents"]
    assert rov == {"name": "videoray", "kind": "rov", "north": 3.0, "east": 4.0, "depth": 5.5,
                   "heading_deg": pytest.approx(270.0), "speed": pytest.approx(0.5),
                   "mode": "TRAIL"}
    assert diver["kind"] == "diver" and diver["heading_deg"] == pytest.approx(10.0)
    assert f["plots"]["range_to_diver"] == pytest.approx(2.0)
    assert f["plots"]["depth"] == {"videoray": 5.5, "diver": 5.5}
    assert f["sonar"] is None


def test_moos_overlays_become_ned():
    # the paper's loiter: octagon about (x=10 east, y=-20 north), radius 20
    poly = polygon_from_moos("pts={30,-20:24.1,-5.9:10,0},label=loiter,edge_color=white")
    assert poly == ("loiter", [[-20.0, 30.0], [-5.9, 24.1], [0.0, 10.0]], True)
    assert point_from_moos("x=1.5,y=-2,label=trail_pt,vertex_size=4") == (
        "trail_pt", -2.0, 1.5, True)
    assert point_from_moos("label=trail_pt,active=false")[3] is False
    assert polygon_from_moos("label=nothing") is None

    b = FrameBuilder(circles=[{"agent": "videoray", "label": "alert", "radius": 5.0}])
    b.observe(_tick(0.1, [_post("videoray", "VIEW_POINT", "x=1,y=2,label=tp"),
                          _post("diver", "VIEW_POLYGON", "pts={0,0:1,0:1,1},label=L")]))
    f = b.build(_tick(0.2))
    assert f["overlays"]["points"] == [{"agent": "videoray", "label": "tp",
                                        "north": 2.0, "east": 1.0}]
    assert f["overlays"]["polygons"] == [{"agent": "diver", "label": "L",
                                          "points": [[0.0, 0.0], [0.0, 1.0], [1.0, 1.0]]}]
    assert f["overlays"]["circles"] == [{"agent": "videoray", "label": "alert", "radius": 5.0}]
    f = b.build(_tick(0.3, [_post("videoray", "VIEW_POINT", "label=tp,active=false")]))
    assert f["overlays"]["points"] == []


def test_pings_observed_between_builds_are_not_lost():
    fan = np.full((40, 30), 7, np.uint8)
    ping = _Ping(0.3, fan, SonarInfo("P900-45", 9e5, 1500.0, 0.0, 10.0, 45.0, 256, 0.1))
    b = FrameBuilder()
    b.observe(_tick(0.3, pings={"videoray/sonar": ping}))
    b.observe(_tick(0.4))
    f = b.build(_tick(0.5))
    (s,) = f["sonar"]
    assert s["agent"] == "videoray" and s["sensor"] == "sonar"
    assert s["t"] == 0.3 and s["fan"] is fan
    # the fan's field of view and range as the ping carries them
    assert s["fov_deg"] == 45.0 and s["max_range"] == 10.0
    assert b.build(_tick(0.6))["sonar"] is None  # consumed


def test_colour_fan_is_sent_as_rgb():
    bgr = np.zeros((4, 4, 3), np.uint8)
    bgr[..., 0] = 200  # blue in OpenCV's BGR
    info = SonarInfo("P900-45", 9e5, 1500.0, 0.0, 1.0, 11.5, 2, 1.0)
    s = sonar_entry("r/sonar", _Ping(0.0, np.zeros((4, 4), np.uint8), info, fan_rgb=bgr))
    assert s["fan"][0, 0].tolist() == [0, 0, 200]


def test_decimated_terrain_keeps_its_shape_and_area():
    # a 240 m × 240 m smooth sea floor on a 1 m grid: 115 200 triangles
    from uhrisim.viz.viewer.adapt import decimate_mesh

    def depth(n, e):
        return 8.0 + 0.5 * np.sin(n / 10.0) * np.cos(e / 13.0)

    g = np.linspace(-120.0, 120.0, 241)
    nn, ee = np.meshgrid(g, g, indexing="ij")
    verts = np.column_stack([nn.ravel(), ee.ravel(), depth(nn, ee).ravel()])
    a = (np.arange(240)[:, None] * 241 + np.arange(240)[None, :]).ravel()
    faces = np.concatenate([np.column_stack([a, a + 241, a + 242]),
                            np.column_stack([a, a + 242, a + 1])])
    v, f = decimate_mesh(verts, faces, max_faces=20_000)
    assert 10_000 < len(f) <= 20_000
    assert f.min() == 0 and f.max() == len(v) - 1
    # every new vertex is a mean of nearby grid points: on the surface to within the
    # curvature term (|f''| ≤ 0.5/100 m⁻¹, cells of a few metres → centimetres)
    assert np.max(np.abs(v[:, 2] - depth(v[:, 0], v[:, 1]))) < 0.05
    # no holes, no overlaps: the triangles' plan-view areas add up to the covered square
    # (less the half-cell margin the boundary clusters pull in)
    p = v[f][:, :, :2]
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]).sum()
    span = v[:, 0].max() - v[:, 0].min()
    assert area == pytest.approx(span * (v[:, 1].max() - v[:, 1].min()), rel=0.01)
    # small meshes are passed through untouched
    v2, f2 = decimate_mesh(verts[:3], [[0, 1, 2]], max_faces=10)
    assert np.array_equal(v2, verts[:3]) and f2.tolist() == [[0, 1, 2]]


def test_camera_frames_observed_between_builds_are_sent_once():
    @dataclass
    class _Shot:
        t: float
        rgb: np.ndarray

    shot = _Shot(0.3, np.zeros((24, 32, 3), np.uint8))
    tick = _tick(0.3)
    tick.images = {"videoray/camera": shot}  # what the simulation's TickFrame carries
    b = FrameBuilder()
    b.observe(tick)
    b.observe(_tick(0.4))
    f = b.build(_tick(0.5))
    (c,) = f["camera"]
    assert c["agent"] == "videoray" and c["sensor"] == "camera"
    assert c["t"] == 0.3 and c["image"] is shot.rgb
    assert b.build(_tick(0.6))["camera"] is None  # consumed
