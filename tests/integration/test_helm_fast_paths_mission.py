"""The paper's track-and-trail mission decides exactly as the helm's reference paths do.

60 s of ``scenarios/track_and_trail.yaml`` (no sonar) are run with the fast helm while
every autonomy step's inputs (time, own nav, node reports, extra mail) and outputs are
recorded. Fresh autonomy stacks built from the same scenario then replay those inputs
with the plain reference implementations swapped in (ZAIC, coupler, CPA over the grid,
its utilities at every grid point in numpy, solver). The fast paths perform the same
floating-point operations, so the decisions (heading, speed, depth), the fused totals and
every behavior's contribution must be equal - not merely close - at each of the 480 helm
steps of both vehicles.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

import uhrisim.autonomy.behaviors.avoid_collision as avoid_mod
import uhrisim.autonomy.behaviors.trail as trail_mod
import uhrisim.autonomy.behaviors.waypoint_engine as wpt_mod
import uhrisim.autonomy.cpa as cpa_mod
import uhrisim.autonomy.helm as helm_mod
import uhrisim.autonomy.zaic as zaic_mod
from uhrisim.autonomy.community import VehicleAutonomy
from uhrisim.autonomy.coupler import couple_reference
from uhrisim.autonomy.cpa import CpaGrid, cpa_distance
from uhrisim.autonomy.domain import Objective
from uhrisim.autonomy.solver import solve_reference

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"
SECONDS = 60.0


def _outcome(out) -> tuple:
    d = out.decision
    dec = None if d is None else (d.heading_deg, d.speed, d.depth)
    return dec, out.total, tuple(sorted(out.contributions.items()))


def _reference_cpa(self, osx, osy, cnx, cny, cnh_deg, cnv, horizon, utility=None):
    cpa = cpa_distance(osx, osy, self.courses_deg[:, None], self.speeds[None, :],
                       cnx, cny, cnh_deg, cnv, horizon)  # fmt: skip
    return cpa if utility is None else utility.apply(cpa)


def _reference_coupled(domain, f_course, f_speed, weights=(50.0, 50.0)):
    table = couple_reference(f_course, f_speed, *weights)
    return Objective.over(domain, ("course", "speed"), table, (table.min(), table.max()))


def _simulation():
    pytest.importorskip("yaml")
    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim.simulation import Simulation

    return Simulation(load_scenario(SCENARIO), raycast_sensors=False)


def test_mission_decisions_equal_reference_paths(monkeypatch):
    calls: list[tuple] = []
    fast_step = VehicleAutonomy.step

    def recording_step(self, t, nav, node_reports=(), extra_mail=None):
        inputs = (self.name, t, nav, copy.deepcopy(list(node_reports)),
                  copy.deepcopy(extra_mail))  # fmt: skip
        out = fast_step(self, t, nav, node_reports, extra_mail)
        calls.append((inputs, _outcome(out)))
        return out

    with monkeypatch.context() as m:
        m.setattr(VehicleAutonomy, "step", recording_step)
        _simulation().run(SECONDS)
    names = {c[0][0] for c in calls}
    assert names == {"diver", "videoray"} and len(calls) == 2 * 4 * int(SECONDS)

    # the reference paths, swapped in where the fast ones are looked up
    monkeypatch.setattr(zaic_mod, "zaic_peak", zaic_mod.zaic_peak_reference)
    monkeypatch.setattr(wpt_mod, "coupled_objective", _reference_coupled)
    monkeypatch.setattr(trail_mod, "coupled_objective", _reference_coupled)
    monkeypatch.setattr(CpaGrid, "distance", _reference_cpa)
    monkeypatch.setattr(cpa_mod, "avoid_utility_inplace", avoid_mod.cpa_utility)
    monkeypatch.setattr(helm_mod, "solve", solve_reference)
    stacks = {a.name: a.driver.autonomy for a in _simulation().agents.values()
              if a.driver is not None}  # fmt: skip
    active = set()
    for (name, t, nav, reports, extra), expected in calls:
        out = stacks[name].step(t, nav, copy.deepcopy(reports), copy.deepcopy(extra))
        assert _outcome(out) == expected, (name, t)
        active.update(out.active)
    # the run exercised what the swap covers: trail and avoidance on the ROV, loiter on
    # the diver, depth on both
    assert {"trail_diver", "avd_diver", "loiter", "hold_depth", "const_depth"} <= active
    assert np.isfinite([c[1][1] for c in calls]).all()
