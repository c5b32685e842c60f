"""Team-mission metrics (``metrics.json``, key ``team``): how the diver's orders went, what
was grasped, handed over and dropped, how long each gripper held something, how close
the agents came, how much silt was stirred up and how much of it the agents swam in.

Definitions (SI):

* a step is one order's run (``uhrisim.teamwork.executor.StepRecord``): start, end,
  outcome (done, failed, or running at the end), duration; ``fetched`` marks a pick-up
  the executor inserted to fetch a dropped tool; ``completed_s`` is the end of the last
  step when every order is done (None otherwise);
* ``waiting_s``: time in ``wait until`` steps;
* grasp attempts count ``grasp`` and ``grasp_failed`` events; hand-overs ``handover``
  and ``handover_failed``; drops ``drop``;
* ``hold_s``: per gripper, the time it held an object (sampled every stage tick);
* ``min_separation_m``: smallest distance between any two agents' reference points;
* silt ``exposure_kg_s_m3``: per agent, the time integral of the silt concentration at
  its reference point.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from typing import TYPE_CHECKING, Any

import numpy as np

from uhrisim.sim.hooks import BaseHook, TickFrame
from uhrisim.teamwork import orders as od

if TYPE_CHECKING:
    from uhrisim.sim.simulation import Simulation
    from uhrisim.sim.teamwork import TeamStage


class TeamMetrics(BaseHook):
    """Collects the team metrics from the frames and the teamwork stage (read only)."""

    def __init__(self) -> None:
        self.team: TeamStage | None = None
        self.hold_s: dict[str, float] = {}
        self.exposure: dict[str, float] = {}
        self.min_separation = math.inf
        self._every = 1
        self._dt = 0.0

    def on_start(self, sim: Simulation) -> None:
        self.team = sim.team
        if self.team is not None:
            self._every, self._dt = self.team.period, self.team.dt
            self.hold_s = {f"{name}/gripper": 0.0 for name in self.team.grippers}
            self.exposure = {name: 0.0 for name in sim.agents}

    def on_tick(self, frame: TickFrame) -> None:
        if self.team is None or frame.tick % self._every:
            return
        ws = self.team.workspace
        for carrier in self.hold_s:
            if ws.held_by(carrier) is not None:
                self.hold_s[carrier] += self._dt
        positions = {name: frame.agents[name].nav.position_ned for name in frame.agents}
        for a, b in itertools.combinations(positions.values(), 2):
            self.min_separation = min(self.min_separation, float(np.linalg.norm(a - b)))
        if self.team.silt is not None and self.team.silt.n_puffs:
            names = list(positions)
            c = self.team.silt.concentration(np.array([positions[n] for n in names]), frame.t)
            for name, value in zip(names, np.atleast_1d(c), strict=True):
                self.exposure[name] += float(value) * self._dt

    def summary(self) -> dict[str, Any]:
        if self.team is None:
            return {}
        divers: dict[str, Any] = {}
        for name, body in self.team.divers.items():
            if body.executor is None:
                continue
            steps = [{"order": od.describe(s.order), "start_s": s.started, "end_s": s.ended,
                      "duration_s": None if s.ended is None else s.ended - s.started,
                      "outcome": s.outcome, "fetched": s.fetched, "reason": s.reason}
                     for s in body.executor.steps]
            done = sum(s["outcome"] == "done" and not s["fetched"] for s in steps)
            finished = body.executor.finished and not body.executor.failed
            waiting = sum(s["duration_s"] or 0.0 for s in steps
                          if s["order"].startswith("wait until"))
            divers[name] = {"orders": len(body.executor.orders), "orders_done": done,
                            "failed": body.executor.failed,
                            "completed_s": steps[-1]["end_s"] if finished and steps else None,
                            "waiting_s": waiting, "steps": steps}
        c = Counter(event.kind for event in self.team.events)
        silt = self.team.silt
        return {"team": {
            "divers": divers,
            "grasps": {"attempts": c.get("grasp", 0) + c.get("grasp_failed", 0),
                       "successes": c.get("grasp", 0)},
            "handovers": {"attempts": c.get("handover", 0) + c.get("handover_failed", 0),
                          "successes": c.get("handover", 0)},
            "drops": c.get("drop", 0),
            "hold_s": self.hold_s,
            "min_separation_m": None if math.isinf(self.min_separation)
            else self.min_separation,
            "silt": None if silt is None else {"released_kg": silt.released_kg,
                                               "footfalls": silt.n_puffs,
                                               "exposure_kg_s_m3": self.exposure},
        }}

