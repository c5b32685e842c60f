"""A scripted diver (the paper's future work: "controlling the human via script files").

A script is a list of timed legs. From its time ``t`` a leg either holds a compass heading
or swims to a point (``goto``), at a speed and depth; the driver posts DESIRED_* into the
agent's community exactly as a helm would.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

from uhrisim.dynamics.plants import NavState
from uhrisim.scenario.schema import ScriptLeg

GOTO_CAPTURE_RADIUS = 0.5  # m: within it the diver stops and holds position


class ScriptDriver:
    """Posts DESIRED_HEADING/SPEED/DEPTH from the leg active at the current time."""

    def __init__(self, legs: Sequence[ScriptLeg]) -> None:
        self.replace(legs)

    def replace(self, legs: Sequence[ScriptLeg]) -> None:
        """Swap in a new plan (a scripted event can change the diver's plan)."""
        self.legs = sorted(legs, key=lambda leg: leg.t)
        self._starts = [leg.t for leg in self.legs]

    def desired(self, t: float, nav: NavState) -> tuple[float, float, float | None] | None:
        """(heading deg, speed m/s, depth m or None) of the active leg; None before the first."""
        index = bisect.bisect_right(self._starts, t) - 1
        if index < 0:
            return None
        leg = self.legs[index]
        if leg.goto is None:
            return float(leg.heading_deg), leg.speed, leg.depth
        d_north = leg.goto.north - nav.position_ned[0]
        d_east = leg.goto.east - nav.position_ned[1]
        heading = math.degrees(math.atan2(d_east, d_north)) % 360.0
        speed = leg.speed if math.hypot(d_north, d_east) > GOTO_CAPTURE_RADIUS else 0.0
        depth = leg.goto.depth if leg.depth is None else leg.depth
        return heading, speed, depth
