"""A stand-in "track and trail" run for the viewer: tests, benchmark, screenshots.

Pure functions of time, no simulation: a diver swims round an octagon of radius 20 m
(the paper's loiter mission) at constant speed, and an ROV follows exactly 2 m behind
along the same path (the trail behaviour's steady state). Positions NED metres,
headings compass degrees (docs/conventions.md). Used where the real simulation loop
is not needed; the lead's ``uhrisim run --view`` publishes real frames instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


@dataclass(frozen=True)
class DemoParams:
    """Geometry and speeds of the stand-in mission (paper: loiter octagon, trail 2 m)."""

    radius: float = 20.0  # m, octagon circumradius (loiter polygon)
    center_ne: tuple[float, float] = (0.0, 0.0)  # m, (north, east)
    diver_speed: float = 0.5  # m/s along the polygon
    trail_distance: float = 2.0  # m behind the diver, along the path
    diver_depth: float = 5.0  # m
    rov_depth: float = 5.5  # m
    contact_range: float = 10.0  # m, circle drawn around the ROV
    alert_range: float = 5.0  # m
    sonar_fov_deg: float = 45.0  # BlueView P900-45 (docs/reference/sonar.md)
    sonar_range: float = 10.0  # m, display range of the fan


def octagon(params: DemoParams = DemoParams()) -> np.ndarray:
    """Vertices ``(8, 2)`` as (north, east), first vertex due north, clockwise seen from above."""
    k = np.arange(8)
    ang = 2 * math.pi * k / 8  # compass bearing of each vertex from the centre
    n0, e0 = params.center_ne
    return np.column_stack([n0 + params.radius * np.cos(ang), e0 + params.radius * np.sin(ang)])


def _along(s: float, verts: np.ndarray) -> tuple[float, float, float]:
    """Point (north, east) at arc length ``s`` (m) along the closed polygon, and heading (deg)."""
    edges = np.roll(verts, -1, axis=0) - verts
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    s = s % float(lengths.sum())
    i = int(np.searchsorted(np.cumsum(lengths), s, side="right"))
    i = min(i, len(lengths) - 1)
    s0 = float(np.cumsum(lengths)[i] - lengths[i])
    a = (s - s0) / lengths[i]
    p = verts[i] + a * edges[i]
    heading = math.degrees(math.atan2(edges[i, 1], edges[i, 0])) % 360.0
    return float(p[0]), float(p[1]), heading


def demo_state(t: float, params: DemoParams = DemoParams()) -> dict[str, tuple[float, ...]]:
    """``{"diver": (north, east, depth, heading_deg, speed), "videoray": (...)}`` at time t (s)."""
    verts = octagon(params)
    s = params.diver_speed * t
    dn, de, dh = _along(s, verts)
    rn, re_, rh = _along(s - params.trail_distance, verts)
    return {
        "diver": (dn, de, params.diver_depth, dh, params.diver_speed),
        "videoray": (rn, re_, params.rov_depth, rh, params.diver_speed),
    }


def demo_fan(t: float, params: DemoParams = DemoParams(), size: tuple[int, int] = (200, 170),
             rng: np.random.Generator | None = None) -> np.ndarray:
    """Synthetic fan image (uint8 H×W, apex bottom centre): speckle plus the diver's echo.

    The image spans the field of view exactly (W = 2 H sin(fov/2)), the convention the
    replay uses to recover the fov. ``rng`` supplies the speckle (none if None).
    """
    h = size[0]
    half = math.radians(params.sonar_fov_deg) / 2
    w = max(2, round(2 * h * math.sin(half)))
    y, x = np.mgrid[0:h, 0:w].astype(float)
    r = np.hypot(x - w / 2, h - y) / h  # fraction of max range
    ang = np.arctan2(x - w / 2, h - y)
    img = np.zeros((h, w), dtype=float)
    if rng is not None:
        img += 30.0 * rng.random((h, w))
    st = demo_state(t, params)
    rn, re_, _, rh, _ = st["videoray"]
    dn, de, _, _, _ = st["diver"]
    rng_m = math.hypot(dn - rn, de - re_) / params.sonar_range
    brg = math.atan2(de - re_, dn - rn) - math.radians(rh)
    brg = (brg + math.pi) % (2 * math.pi) - math.pi
    img += 220.0 * np.exp(-(((r - rng_m) / 0.03) ** 2 + ((ang - brg) / 0.08) ** 2))
    img[(r > 1.0) | (np.abs(ang) > half)] = 0.0
    return np.clip(img, 0, 255).astype(np.uint8)


def demo_scene(params: DemoParams = DemoParams()) -> dict[str, Any]:
    """A small scene: a sloping sea floor (12 m → 16 m deep) and four pilings."""
    n = np.linspace(-35, 35, 15)
    e = np.linspace(-35, 35, 15)
    nn, ee = np.meshgrid(n, e, indexing="ij")
    dd = 14.0 + 2.0 * nn / 35.0 + 0.4 * np.sin(ee / 6.0)
    verts = np.column_stack([nn.ravel(), ee.ravel(), dd.ravel()])
    faces = []
    m = len(e)
    for i in range(len(n) - 1):
        for j in range(m - 1):
            a = i * m + j
            faces += [[a, a + 1, a + m], [a + 1, a + m + 1, a + m]]
    eye = np.eye(3).tolist()
    pilings = [
        {"label": f"piling {k}", "kind": "cylinder", "position_ned": [pn, pe, 7.0],
         "rotation": eye, "radius": 0.4, "height": 14.0}
        for k, (pn, pe) in enumerate([(28.0, -8.0), (28.0, 8.0), (-28.0, -8.0), (-28.0, 8.0)])
    ]
    return {
        "objects": [*pilings, {"label": "block", "kind": "box", "position_ned": [0.0, 25.0, 13.0],
                               "rotation": eye, "size": [2.0, 1.0, 1.0]}],
        "seafloor": {"vertices": verts.tolist(), "faces": faces},
        "bounds": [[-35.0, -35.0, 0.0], [35.0, 35.0, 16.0]],
    }


DEMO_BUTTONS: list[dict[str, str]] = [
    {"label": "DEPLOY", "agent": "videoray", "var": "DEPLOY", "value": "true"},
    {"label": "RETURN", "agent": "videoray", "var": "RETURN", "value": "true"},
]


def demo_frame(t: float, params: DemoParams = DemoParams(), *, paused: bool = False,
               speed_factor: float = 1.0, rtf: float = 1.0,
               sonar: np.ndarray | None = None) -> dict[str, Any]:
    """The live frame (docs/viewer.md schema) of the stand-in mission at time t (s)."""
    st = demo_state(t, params)
    dn, de, dd, dh, dv = st["diver"]
    rn, re_, rd, rh, rv = st["videoray"]
    frame: dict[str, Any] = {
        "t": float(t), "paused": paused, "speed_factor": speed_factor, "rtf": rtf,
        "agents": [
            {"name": "diver", "kind": "diver", "north": dn, "east": de, "depth": dd,
             "heading_deg": dh, "speed": dv, "mode": "LOITER"},
            {"name": "videoray", "kind": "rov", "north": rn, "east": re_, "depth": rd,
             "heading_deg": rh, "speed": rv, "mode": "TRAIL"},
        ],
        "overlays": {
            "polygons": [{"agent": "diver", "label": "loiter",
                          "points": octagon(params).tolist()}],
            "points": [{"agent": "videoray", "label": "trail point", "north": dn - 2.0 * math.cos(
                math.radians(dh)), "east": de - 2.0 * math.sin(math.radians(dh))}],
            "circles": [
                {"agent": "videoray", "label": "contact", "radius": params.contact_range},
                {"agent": "videoray", "label": "alert", "radius": params.alert_range},
            ],
        },
        "sonar": None,
        "plots": {
            "range_to_diver": math.dist((dn, de, dd), (rn, re_, rd)),
            "depth": {"diver": dd, "videoray": rd},
            "speed": {"diver": dv, "videoray": rv},
        },
    }
    if sonar is not None:
        frame["sonar"] = {"agent": "videoray", "sensor": "sonar", "t": float(t), "fan": sonar,
                          "fov_deg": params.sonar_fov_deg, "max_range": params.sonar_range}
    return frame


def write_demo_recording(path: Path | str, duration: float = 60.0, dt: float = 0.1,
                         sonar_period: float = 0.5, params: DemoParams = DemoParams()) -> None:
    """Record the stand-in run with ``uhrisim.record.McapRecorder``: odometry, sonar fans,
    1 Hz helm decisions (mode DEPLOYING, then TRAIL from t = 1 s), variables, scene."""
    from uhrisim.core.frames import rot_z
    from uhrisim.record.mcap_recorder import McapRecorder

    n_steps = round(duration / dt)
    every = max(1, round(sonar_period / dt))
    with McapRecorder(path) as rec:
        rec.write_scene_markers(0.0, [
            {"ns": "pilings", "id": k, "type": "cylinder", "position_ned": [pn, pe, 7.0],
             "scale": [0.8, 0.8, 14.0], "color": [0.6, 0.6, 0.6, 1.0]}
            for k, (pn, pe) in enumerate([(28.0, -8.0), (28.0, 8.0), (-28.0, -8.0), (-28.0, 8.0)])
        ])
        pts = ":".join(f"{e:.3f},{n:.3f}" for n, e in octagon(params))
        rec.write_variable("diver", 0.0, "VIEW_POLYGON", f"pts={{{pts}}},label=loiter", "demo")
        # the fan's geometry travels with the recording (it has no ProjectedSonarImage)
        rec.write_variable("videoray", 0.0, "SONAR_MAX_RANGE", params.sonar_range, "demo")
        rec.write_variable("videoray", 0.0, "SONAR_FOV_DEG", params.sonar_fov_deg, "demo")
        for k in range(n_steps + 1):
            t = k * dt
            st = demo_state(t, params)
            for name, (n, e, d, hd, v) in st.items():
                rec.write_odometry(name, t, (n, e, d), math.radians(hd), (v, 0.0, 0.0), 0.0)
            if k % every == 0:
                rn, re_, rd, rh, _ = st["videoray"]
                rec.write_sonar("videoray", "sonar", t, None, demo_fan(t, params), None, None,
                                ((rn, re_, rd), rot_z(math.radians(rh))))
            if k % round(1.0 / dt) == 0:  # 1 Hz helm decisions; DEPLOYING for the first second
                _, _, _, rh, rv = st["videoray"]
                rec.write_helm_decision("videoray", t, rh, rv, params.rov_depth, {"trail": 100.0},
                                        "DEPLOYING" if t < 1.0 else "TRAIL", ["trail"])
            if k == 0:
                rec.write_variable("diver", t, "MODE", "LOITER", "demo")


class DemoRun:
    """The stand-in mission played live into a :class:`ViewerServer`, obeying its commands.

    A background thread advances simulated time by ``dt`` per tick at ``rate_hz`` ticks per
    wall second times the speed factor, publishes :func:`demo_frame` each tick and a sonar
    fan every ``sonar_every`` ticks, and applies pause / resume / step / speed commands
    as the real loop does. ``post`` and ``select`` commands are logged and kept in
    :attr:`posts`. Meant for trying the page without a simulation and for screenshots.
    """

    def __init__(self, server: Any, *, dt: float = 0.05, rate_hz: float = 20.0,
                 sonar_every: int = 4, t0: float = 0.0, seed: int = 0,
                 params: DemoParams = DemoParams()) -> None:
        import threading

        from uhrisim.core.rng import component_rng

        self.server = server
        self.dt = dt
        self.rate_hz = rate_hz
        self.sonar_every = sonar_every
        self.params = params
        self.t = t0
        self.paused = False
        self.speed = 1.0
        self.posts: list[Any] = []
        self._rng = component_rng(seed, "viewer-demo/sonar")
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="uhrisim-viewer-demo",
                                        daemon=True)

    def start(self) -> DemoRun:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(5)

    def _apply(self, cmd: Any) -> int:
        steps = 0
        if cmd.kind == "pause":
            self.paused = True
        elif cmd.kind == "resume":
            self.paused = False
        elif cmd.kind == "step" and self.paused:
            steps = int(cmd.value or 1)
        elif cmd.kind == "speed":
            self.speed = float(cmd.value)
        else:
            self.posts.append(cmd)
        return steps

    def _run(self) -> None:
        import logging
        import time

        log = logging.getLogger(__name__)
        k = 0
        last = time.perf_counter()
        while not self._stop.is_set():
            steps = sum(self._apply(c) for c in self.server.drain_commands())
            now = time.perf_counter()
            wall = now - last
            last = now
            advance = steps * self.dt
            rtf = 0.0
            if not self.paused:
                speed = self.speed if math.isfinite(self.speed) else 50.0
                advance += wall * speed
                rtf = speed
            self.t += advance
            sonar = None
            if k % self.sonar_every == 0:
                sonar = demo_fan(self.t, self.params, size=(240, 200), rng=self._rng)
            self.server.publish(demo_frame(self.t, self.params, paused=self.paused,
                                           speed_factor=self.speed, rtf=rtf, sonar=sonar))
            k += 1
            time.sleep(1.0 / self.rate_hz)
        log.debug("demo run stopped at t=%.1f s", self.t)


def main(argv: list[str] | None = None) -> None:  # pragma: no cover - manual tool
    """``python -m uhrisim.viz.viewer.demo [--port N]``: serve the stand-in mission."""
    import argparse
    import logging
    import time

    from uhrisim.viz.viewer.server import ViewerServer

    ap = argparse.ArgumentParser(description="Serve the viewer with a stand-in mission.")
    ap.add_argument("--port", type=int, default=8765)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO)
    server = ViewerServer(demo_scene(), DEMO_BUTTONS, port=args.port)
    url = server.start()
    logging.getLogger(__name__).info("open %s (Ctrl-C to stop)", url)
    run = DemoRun(server).start()
    try:
        while True:
            time.sleep(1)
    except KeyboardInterrupt:
        pass
    finally:
        run.stop()
        server.close()


if __name__ == "__main__":  # pragma: no cover
    main()
