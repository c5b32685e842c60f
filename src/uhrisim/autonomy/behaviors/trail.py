"""BHV_Trail: keep station at ``trail_range`` from a contact at ``trail_angle``.

docs/reference/helm.md and MOOS-IvP's BHV_Trail.cpp. The trail point P is ``trail_range``
from the contact (as last reported) at ``trail_angle`` relative to the contact's heading
(180 = straight behind; ``trail_angle_type = absolute`` makes it a compass bearing). With
D = own distance to P:

* D > nm_radius: intercept - utility 100 (1 - cpa/D), clipped to 0..100, where cpa is the
  CPA to a virtual contact at P moving with the contact's heading and speed over
  ``time_on_leg`` (60 s); built into 3 x 2-index linear pieces and normalised 0..100 as
  pHelmIvP's reflector does (l.43, 219-243; :func:`~uhrisim.autonomy.ivp_build.reflect`);
* radius < D <= nm_radius: course ZAIC (pw 30, bw 150, delta 50, wrap) at the bearing to
  the point nm_radius ahead of P along the contact heading, speed ZAIC (pw 0.1, bw 2.0,
  delta 50) at v_c (1 - 0.5 ahead_by / nm_radius), never negative (ahead_by = own
  position ahead of P along the contact heading); coupled 50/50;
* D <= radius: the same ZAICs at the contact's heading and speed (match the contact).

With ``extrapolate = false`` the speed summit is 0 in the two near regimes (l.273-274,
314-315). ``pwt_outer_dist`` (0 = no limit) switches the behavior off at and beyond that
range (l.361-376). Defaults (IvP): trail_range 50, trail_angle 180 relative, radius 5,
nm_radius 20, pwt_outer_dist 0. The authors' mission used trail_range 5, radius 5,
nm_radius 15; the paper's text 2 m behind. Each active tick posts the trail point as
VIEW_POINT (``x=..,y=..,label=<name>``, pMarineViewer style).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from uhrisim.autonomy.behaviors.base import BehaviorContext
from uhrisim.autonomy.behaviors.contact_base import CONTACT_HANDLERS, ContactBehavior
from uhrisim.autonomy.coupler import coupled_objective
from uhrisim.autonomy.cpa import CutRangeUtility
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.geometry import bearing_deg, distance
from uhrisim.autonomy.ivp_build import reflect_cpa
from uhrisim.autonomy.params import one_of, setter, to_float
from uhrisim.autonomy.zaic import zaic_peak_on_axis

FAR_PIECE = (3, 2)
"""Build pieces beyond nm_radius, grid indices (course, speed):
``uniform_piece = discrete @ course:3,speed:2`` (BHV_Trail.cpp:43)."""


@dataclass(frozen=True)
class TrailParams:
    """BHV_Trail parameters (IvP names and defaults; module docstring).

    ``contact`` the NODE_REPORT name; ``decay`` the dead-reckoning decay (start, end), s;
    ``trail_range``, ``radius``, ``nm_radius``, ``pwt_outer_dist`` m (0 = no limit);
    ``trail_angle`` deg, relative to the contact heading or a compass bearing
    (``trail_angle_type``); ``time_on_leg`` s.
    """

    contact: str = ""
    extrapolate: bool = True
    decay: tuple[float, float] = (5.0, 10.0)
    on_no_contact_ok: bool = True
    no_alert_request: bool = True  # IvP default (BHV_Trail.cpp:60)
    trail_range: float = 50.0
    trail_angle: float = 180.0
    trail_angle_type: str = "relative"
    radius: float = 5.0
    nm_radius: float = 20.0
    pwt_outer_dist: float = 0.0
    time_on_leg: float = 60.0


class Trail(ContactBehavior):
    KIND = "BHV_Trail"
    Params = TrailParams
    HANDLERS: ClassVar[dict] = {
        **CONTACT_HANDLERS,
        **{
            k: setter(k, to_float)
            for k in ("trail_range", "trail_angle", "radius", "nm_radius", "pwt_outer_dist")
        },
        "time_on_leg": setter("time_on_leg", to_float),
        "trail_angle_type": setter("trail_angle_type", one_of("relative", "absolute")),
    }

    def trail_point(self, cx: float, cy: float, ch: float) -> tuple[float, float]:
        """Trail point (x east, y north) for a contact at (cx, cy) heading ``ch`` deg."""
        p: TrailParams = self.params
        a = p.trail_angle + (ch if p.trail_angle_type == "relative" else 0.0)
        r = math.radians(a)
        return cx + p.trail_range * math.sin(r), cy + p.trail_range * math.cos(r)

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        p: TrailParams = self.params
        own = ctx.own
        tr = self.track(ctx)
        if own is None or tr is None:
            return None
        if p.pwt_outer_dist > 0 and distance(own.x, own.y, tr.x, tr.y) >= p.pwt_outer_dist:
            return None
        ch, cv = tr.heading, tr.speed
        px, py = self.trail_point(tr.x, tr.y, ch)
        ctx.post("VIEW_POINT", f"x={px:.2f},y={py:.2f},label={self.name}")
        dist = distance(own.x, own.y, px, py)
        crs_axis, spd_axis = ctx.domain.axis("course"), ctx.domain.axis("speed")
        if dist > p.nm_radius:
            grid = self.cpa_grid(ctx.domain)
            table, lo, hi = reflect_cpa(grid, own.x, own.y, px, py, ch, cv, p.time_on_leg,
                                        CutRangeUtility(dist), FAR_PIECE)
            return Objective.over(ctx.domain, ("course", "speed"), table, (lo, hi))
        if dist > p.radius:
            hx, hy = math.sin(math.radians(ch)), math.cos(math.radians(ch))
            ax, ay = px + p.nm_radius * hx, py + p.nm_radius * hy
            crs = bearing_deg(own.x, own.y, ax, ay)
            ahead_by = (own.x - px) * hx + (own.y - py) * hy
            spd = max(0.0, cv * (1.0 - 0.5 * ahead_by / p.nm_radius))
        else:
            crs, spd = ch, max(cv, 0.0)
        if not p.extrapolate:
            spd = 0.0
        fc = zaic_peak_on_axis(crs_axis, crs, 30.0, 150.0, 50.0)
        fs = zaic_peak_on_axis(spd_axis, spd, 0.1, 2.0, 50.0)
        return coupled_objective(ctx.domain, fc, fs)
