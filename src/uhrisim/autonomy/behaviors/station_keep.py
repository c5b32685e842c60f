"""BHV_StationKeep: hold a point with inner/outer radii.

Desired speed with d = distance to ``station_pt``: 0 inside ``inner_radius``; growing
linearly to ``outer_speed`` at ``outer_radius``; ``transit_speed`` beyond. Course: ZAIC
peak at the bearing to the station (pw 0, bw 180, wrap); speed: ZAIC peak (pw 0, bw 1.0,
our choice) at the desired speed; coupled 50/50, normalised 0..100.

Parameters (IvP names and defaults): station_pt ("x,y" or "present_position"),
center_activate (false: on becoming running, hold the vehicle's position), inner_radius
(4), outer_radius (15), outer_speed (1.2), transit_speed (2.0).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext
from uhrisim.autonomy.behaviors.loiter import _center
from uhrisim.autonomy.behaviors.waypoint_engine import course_speed_objective
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import bearing_deg, distance
from uhrisim.autonomy.params import setter, to_bool, to_float

Point = tuple[float, float]


@dataclass(frozen=True)
class StationKeepParams:
    station_pt: Point | str | None = None
    center_activate: bool = False
    inner_radius: float = 4.0
    outer_radius: float = 15.0
    outer_speed: float = 1.2
    transit_speed: float = 2.0


class StationKeep(Behavior):
    KIND = "BHV_StationKeep"
    Params = StationKeepParams
    HANDLERS: ClassVar[dict] = {
        "station_pt": setter("station_pt", _center),
        "center_activate": setter("center_activate", to_bool),
        **{
            k: setter(k, to_float)
            for k in ("inner_radius", "outer_radius", "outer_speed", "transit_speed")
        },
    }

    def reset(self) -> None:
        sp = self.params.station_pt
        self.station: Point | None = sp if isinstance(sp, tuple) else None

    def on_params_changed(self, key: str) -> None:
        if key == "station_pt":
            self.reset()

    def on_run_start(self, ctx: BehaviorContext) -> None:
        if (self.params.center_activate or self.params.station_pt == "present_position") and (
            ctx.own is not None
        ):
            self.station = (ctx.own.x, ctx.own.y)

    def desired_speed(self, d: float) -> float:
        p: StationKeepParams = self.params
        if d <= p.inner_radius:
            return 0.0
        if d < p.outer_radius:
            return p.outer_speed * (d - p.inner_radius) / (p.outer_radius - p.inner_radius)
        return p.transit_speed

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        own = ctx.own
        if own is None:
            return None
        if self.station is None:
            self.station = (own.x, own.y)
        sx, sy = self.station
        d = distance(own.x, own.y, sx, sy)
        crs = bearing_deg(own.x, own.y, sx, sy) if d > 1e-9 else own.heading
        return course_speed_objective(ctx, crs, self.desired_speed(d), (0.0, 1.0, 0.0))
