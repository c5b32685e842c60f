"""Fuzzing scenario files: whatever a user writes, loading, building and a short run either
work or stop with one line naming the problem - never a traceback, never a hang.

Hypothesis mutates a small valid scenario (every section a user touches: world, agents,
helm, script, contacts, sensors, events, recording): it deletes keys, replaces values with
values of other types and extremes (booleans, None, NaN and infinity spelt in YAML,
negative, huge, strings with markup brackets, nested lists), and adds unknown keys. Each
example must finish within its time bound; a refusal must be a UhrisimError whose message
is a single line.
"""

from __future__ import annotations

import contextlib
import copy
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from tests.support.time_limit import time_limit
from uhrisim.core.errors import UhrisimError
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

BASE: dict[str, Any] = yaml.safe_load("""\
name: fuzz
duration: 5
physics_rate_hz: 60
world:
  seafloor: {type: flat, depth: 8, extent: 40}
  objects:
    - {type: cylinder, label: piling, radius: 0.3, height: 9,
       position: {north: 12, east: 3, depth: 4}}
agents:
  - name: rov
    model: videoray
    start: {north: 0, east: 0, depth: 1, heading_deg: 90}
    controller: {preset: mission}
    helm:
      rate_hz: 4
      domain: {course: [0, 359, 360], speed: [0, 2, 21], depth: [0, 20, 21, optional]}
      initialize: {DEPLOY: true}
      behaviors:
        - {type: ConstantDepth, name: depth, depth: 2, duration: no-time-limit}
        - {type: Waypoint, name: go, points: "10,10:0,20", speed: 0.8, condition: "DEPLOY = true"}
        - {type: Trail, name: trail_, templating: spawn, updates: TRAIL_INFO, trail_range: 2}
    contacts:
      rate_hz: 4
      position_noise_std: 0.1
      alerts: [{var: TRAIL_INFO, alert_range: 30}]
    sensors:
      - {type: sonar, preset: P900-45, rate_hz: 15, range_min_m: 0.5, range_max_m: 10,
         rays_per_beam: 4}
  - name: diver
    model: diver
    driver: script
    start: {north: 6, east: 0, depth: 2, heading_deg: 0}
    script:
      - {t: 0, heading_deg: 90, speed: 0.4, depth: 2}
      - {t: 2, goto: {north: 8, east: 6, depth: 3}, speed: 0.5}
events:
  - {at: 1, post: {agent: rov, var: DEPLOY, value: "true"}}
  - {when: "NAV_DEPTH > 1.5", agent: rov, post: {agent: rov, var: TRAIL, value: "false"}}
recording: {odometry_rate_hz: 10, sonar_every: 5}
metrics: {follower: rov, target: diver, range: 2.0}
""")

ODD_VALUES = st.one_of(
    st.booleans(), st.none(), st.integers(-10**12, 10**12),
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.sampled_from([".nan", ".inf", "-.inf", "", "[bold]x[/]", "uhrisim[viewer]", "0x10",
                     "1e999", "-0", "NaN", "yes", "no"]),
    st.text(max_size=12), st.lists(st.integers(-5, 5), max_size=4),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=2),
)  # fmt: skip


def _paths(node: Any, path: tuple = ()) -> list[tuple]:
    """Every key path of the document (mapping keys and sequence indices)."""
    out = [path] if path else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*path, i))
    return out


PATHS = _paths(BASE)


def _mutate(doc: dict, path: tuple, action: str, value: Any) -> dict:
    doc = copy.deepcopy(doc)
    parent = doc
    for part in path[:-1]:
        parent = parent[part]
    last = path[-1]
    if action == "delete":
        del parent[last]
    elif action == "replace":
        parent[last] = value
    elif isinstance(parent, dict):  # add an unknown key beside it
        parent[f"{last}_x"] = value
    return doc


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@example(mutations=[(("agents", 0, "contacts", "position_noise_std"), "replace", "-0")])
@given(mutations=st.lists(st.tuples(st.sampled_from(PATHS),
                                    st.sampled_from(["delete", "replace", "add"]), ODD_VALUES),
                          min_size=1, max_size=3))
def test_any_mutation_runs_or_is_refused_in_one_line(tmp_path: Path, mutations):
    doc = BASE
    for path, action, value in mutations:
        # a path an earlier mutation removed or replaced is skipped
        with contextlib.suppress(KeyError, IndexError, TypeError):
            doc = _mutate(doc, path, action, value)
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    with time_limit(20, str(mutations)):  # a hang fails the example, not the suite
        try:
            sim = Simulation(load_scenario(path), raycast_sensors=True)
            sim.run(0.5)
            event("ran")
        except UhrisimError as error:
            message = str(error)
            assert message and "\n" not in message, message
            event(f"refused: {type(error).__name__}")


def test_the_base_document_runs(tmp_path: Path):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(BASE, sort_keys=False))
    sim = Simulation(load_scenario(path), raycast_sensors=True)
    sim.run(1.0)
    assert sim.t == pytest.approx(1.0)
