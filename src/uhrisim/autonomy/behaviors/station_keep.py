"""BHV_StationKeep: hold a point with inner/outer radii.

Desired speed with d = distance to ``station_pt``: 0 inside ``inner_radius``; growing
linearly to ``outer_speed`` at ``outer_radius``; ``transit_speed`` beyond. Course: ZAIC
peak at the bearing to the station (pw 0, bw 180, wrap); speed: ZAIC peak (pw 0, bw 0.4,
delta 0, as in IvP); coupled 50/50, normalised 0..100.

Parameters (IvP names and defaults): station_pt ("x,y" or "present_position"),
center_activate (false: on becoming running, hold the vehicle's position), swing_time
(0 s: with center_activate, the station keeps following the vehicle for this long after
activation, so it is set where the vehicle has swung to), inner_radius (4), outer_radius
(15), outer_speed (1.2; also raises transit_speed to it), transit_speed (2.5), radii and
speeds > 0, swing_time clipped to [0, 60] s, hibernation_radius (-1 or off; when on, the
behavior hibernates - desired speed 0 - once inside inner_radius, and seeks the station
again only after drifting beyond hibernation_radius; IvP's extra "progress" test is not
modelled). Posts PSKEEP_MODE (DISABLED / HIBERNATING / SEEKING_STATION) on change. As in
pHelmIvP (BHV_StationKeep.cpp:240-309, 355-376), the tick the station is set (first run,
activation, each swing tick) asks for speed 0 and a course to the station - 0 deg when
the station is the vehicle's own position, its heading while swinging.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.behaviors.waypoint_engine import course_speed_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import bearing_deg, distance
from uhrisim.autonomy.params import setter, to_bool, to_float, to_point_or_present, to_positive

Point = tuple[float, float]


@dataclass(frozen=True)
class StationKeepParams:
    """BHV_StationKeep parameters (IvP names and defaults; module docstring).

    ``station_pt`` MOOS local (x east, y north), m, or "present_position"; radii m
    (``hibernation_radius`` -1 = off); speeds m/s; ``swing_time`` s.
    """

    station_pt: Point | str | None = None
    center_activate: bool = False
    inner_radius: float = 4.0
    outer_radius: float = 15.0
    outer_speed: float = 1.2
    transit_speed: float = 2.5
    swing_time: float = 0.0
    hibernation_radius: float = -1.0


def _outer_speed(p: StationKeepParams, v: object, key: str, where: str) -> StationKeepParams:
    """outer_speed (> 0) also raises transit_speed to it (BHV_StationKeep.cpp:163-170)."""
    x = to_positive(v, key, where)
    return replace(p, outer_speed=x, transit_speed=max(p.transit_speed, x))


def _swing_time(v: object, key: str, where: str) -> float:
    return min(max(to_float(v, key, where), 0.0), 60.0)  # clipped to [0, 60] s, as IvP


def _hibernation_radius(v: object, key: str, where: str) -> float:
    if str(v).strip().lower() in ("off", "-1", "-1.0"):
        return -1.0
    return to_positive(v, key, where)


class StationKeep(Behavior):
    KIND = "BHV_StationKeep"
    Params = StationKeepParams
    HANDLERS: ClassVar[dict] = {
        "station_pt": setter("station_pt", to_point_or_present),
        "center_activate": setter("center_activate", to_bool),
        **{
            k: setter(k, to_positive)
            for k in ("inner_radius", "outer_radius", "transit_speed")
        },
        "outer_speed": _outer_speed,
        "swing_time": setter("swing_time", _swing_time),
        "hibernation_radius": setter("hibernation_radius", _hibernation_radius),
    }

    def reset(self) -> None:
        sp = self.params.station_pt
        self.station: Point | None = sp if isinstance(sp, tuple) else None
        self.fresh = True  # the station was just set: this tick holds still
        self.swing_until: float | None = None
        self.state = "seeking_station"
        self._posted_state: str | None = None

    def on_params_changed(self, key: str) -> None:
        if key == "station_pt":
            self.reset()

    def on_run_start(self, ctx: BehaviorContext) -> None:
        if (self.params.center_activate or self.params.station_pt == "present_position") and (
            ctx.own is not None
        ):
            self.station = (ctx.own.x, ctx.own.y)
            self.fresh = True
            self.swing_until = ctx.t + self.params.swing_time
            self.state = "hibernating"

    def desired_speed(self, d: float) -> float:
        p: StationKeepParams = self.params
        if d <= p.inner_radius:
            return 0.0
        outer = max(p.outer_radius, p.inner_radius)  # IvP lifts outer to inner (l.253-254)
        if d < outer:
            return p.outer_speed * (d - p.inner_radius) / (outer - p.inner_radius)
        return p.transit_speed

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: StationKeepParams = self.params
        own = ctx.own
        if own is None:
            return None
        if self.station is None:
            self.station, self.fresh = (own.x, own.y), True
        swinging = self.swing_until is not None and ctx.t < self.swing_until
        if swinging:
            self.station, self.fresh = (own.x, own.y), True
        elif self.swing_until is not None:
            self.swing_until = None
        sx, sy = self.station
        d = distance(own.x, own.y, sx, sy)
        # the tick the station is set pHelmIvP keeps its old distance: speed 0
        # (BHV_StationKeep.cpp:371-376, the "hibernating" reset)
        speed = 0.0 if self.fresh else self.desired_speed(d)
        self.fresh = False
        if p.hibernation_radius > 0:
            if self.state == "hibernating" and d > p.hibernation_radius:
                self.state = "seeking_station"
            elif self.state == "seeking_station" and d <= p.inner_radius:
                self.state = "hibernating"
            if self.state == "hibernating":
                speed = 0.0
        mode = self.state.upper() if p.hibernation_radius > 0 else "DISABLED"
        if mode != self._posted_state:
            ctx.post("PSKEEP_MODE", mode)
            self._posted_state = mode
        # relAng of a point to itself is 0; while swinging, the own heading (l.264-267)
        crs = own.heading if swinging else bearing_deg(own.x, own.y, sx, sy) if d > 0.0 else 0.0
        return course_speed_objective(ctx, crs, speed, (0.0, 0.4, 0.0))
