"""Mission metrics of a trail (``metrics.json``): how well the follower held its trail point.

Definitions (NED, compass degrees, metres):

* range = horizontal distance follower-target; range error = range - trail range;
* bearing error = wrap_180(bearing target->follower - (target heading + trail angle));
* acquisition = the first moment from which |range error| <= range tolerance and
  |bearing error| <= bearing tolerance hold for ``acquire_hold_s`` seconds without a
  break; "after acquisition" statistics use every sample from then on;
* depth error = follower depth - target depth (the ROV holds the diver's depth);
* minimum separation = smallest 3-D distance between the two bodies' centres;
* real-time factor = simulated seconds / wall-clock seconds of the run.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uhrisim.core.frames import wrap_180
from uhrisim.scenario.schema import TrailMetricConfig
from uhrisim.sim.hooks import BaseHook, TickFrame

if TYPE_CHECKING:
    from uhrisim.sim.simulation import Simulation

SAMPLE_RATE_HZ = 10.0


def _stats(values: np.ndarray) -> dict[str, float | None]:
    if values.size == 0:
        return {"mean": None, "rms": None, "p95_abs": None, "max_abs": None}
    return {"mean": float(np.mean(values)), "rms": float(np.sqrt(np.mean(values ** 2))),
            "p95_abs": float(np.percentile(np.abs(values), 95)),
            "max_abs": float(np.max(np.abs(values)))}


class TrailMetrics(BaseHook):
    """Samples the follower/target pair at 10 Hz and summarises the trail."""

    def __init__(self, config: TrailMetricConfig) -> None:
        self.config = config
        self._rows: list[tuple[float, ...]] = []
        self._period = 1
        self._sim: Simulation | None = None

    def on_start(self, sim: Simulation) -> None:
        self._sim = sim
        self._period = max(1, round(1.0 / (SAMPLE_RATE_HZ * sim.dt)))
        self._sample(sim.t, sim.snapshots())

    def on_tick(self, frame: TickFrame) -> None:
        if frame.tick % self._period == 0:
            self._sample(frame.t, frame.agents)

    def _sample(self, t: float, agents: Any) -> None:
        follower, target = agents[self.config.follower].nav, agents[self.config.target].nav
        self._rows.append((t, *follower.position_ned, *target.position_ned, target.yaw))

    def series(self) -> dict[str, np.ndarray]:
        """Time series (s, m, deg) of range, range error, bearing error, depth error."""
        rows = np.array(self._rows) if self._rows else np.empty((0, 8))
        t, f, g, target_yaw = rows[:, 0], rows[:, 1:4], rows[:, 4:7], rows[:, 7]
        d_north, d_east = f[:, 0] - g[:, 0], f[:, 1] - g[:, 1]
        horizontal = np.hypot(d_north, d_east)
        bearing = np.degrees(np.arctan2(d_east, d_north))
        wanted = np.degrees(target_yaw) + self.config.angle_deg
        return {
            "t": t, "range": horizontal, "range_error": horizontal - self.config.range,
            "bearing_error": np.asarray(wrap_180(bearing - wanted)),
            "depth_error": f[:, 2] - g[:, 2], "separation": np.linalg.norm(f - g, axis=1),
            "follower_ned": f, "target_ned": g,
        }

    def acquisition_index(self, s: dict[str, np.ndarray]) -> int | None:
        c = self.config
        ok = (np.abs(s["range_error"]) <= c.acquire_range_tolerance) & (
            np.abs(s["bearing_error"]) <= c.acquire_bearing_tolerance_deg)
        need = max(1, math.ceil(c.acquire_hold_s * SAMPLE_RATE_HZ))
        run = 0
        for i, good in enumerate(ok):
            run = run + 1 if good else 0
            if run >= need:
                return i - need + 1
        return None

    def summary(self) -> dict[str, Any]:
        s = self.series()
        sim = self._sim
        start = self.acquisition_index(s)
        after = slice(start, None) if start is not None else slice(0, 0)
        wall = sim.wall_time if sim else 0.0
        simulated = float(s["t"][-1] - s["t"][0]) if s["t"].size else 0.0
        return {
            "follower": self.config.follower, "target": self.config.target,
            "trail_range_m": self.config.range, "trail_angle_deg": self.config.angle_deg,
            "simulated_s": simulated,
            "acquired": start is not None,
            "time_to_acquire_s": float(s["t"][start] - s["t"][0]) if start is not None else None,
            "range_error_m": _stats(s["range_error"][after]),
            "bearing_error_deg": _stats(s["bearing_error"][after]),
            "depth_error_m": _stats(s["depth_error"][after]),
            "min_separation_m": float(np.min(s["separation"])) if s["t"].size else None,
            "collisions": sim.collisions if sim else 0,
            "wall_s": wall,
            "real_time_factor": simulated / wall if wall > 0 else None,
        }

    def write(self, path: Path) -> Path:
        path.write_text(json.dumps(self.summary(), indent=2) + "\n")
        return path
