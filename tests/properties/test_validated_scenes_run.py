"""A scene that ``uhrisim validate`` accepts runs (issue 29): Hypothesis draws scenes whose
numbers sit anywhere in their declared ranges, the edges above all (where the overflows
were: a breath every half second, a current of 5 m/s, a hold of 10^7 s, a camera at its
shortest range, a priority of 10^6, a box of 10 km, an agent 100 km out); each scene is
either refused in one line or, once validated (:func:`uhrisim.app.runner.build_run`, what
``validate`` builds), runs one simulated second with its sensors without an error or a
RuntimeWarning (the suite turns uhrisim's into errors)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tests.support.time_limit import time_limit
from uhrisim.app.runner import build_run
from uhrisim.core.errors import UhrisimError
from uhrisim.scenario.load import load_scenario


def within(low: float, high: float) -> st.SearchStrategy[float]:
    """A number in [low, high], its edges and its middle drawn often."""
    return st.one_of(st.sampled_from([low, high, (low + high) / 2]),
                     st.floats(low, high, allow_nan=False))


@st.composite
def scenes(draw: st.DrawFn) -> dict:
    """A small scene: a VideoRay with a sonar and a camera on a helm, a breathing diver
    on a script, objects, an event and the trail metrics, every number drawn in range."""
    objects = [draw(st.one_of(
        st.fixed_dictionaries({"type": st.just("box"), "label": st.just(f"o{i}"),
                               "size": st.lists(within(0.01, 1.0e4), min_size=3, max_size=3)}),
        st.fixed_dictionaries({"type": st.just("sphere"), "label": st.just(f"o{i}"),
                               "radius": within(0.01, 50.0)})))
        | {"position": {"north": draw(within(-1.0e5, 1.0e5)), "east": draw(within(-200, 200)),
                        "depth": draw(within(-100.0, 40.0))}}
        for i in range(draw(st.integers(0, 3)))]
    return {
        "name": "drawn", "duration": 1.0,
        "world": {"seafloor": {"type": "flat", "depth": draw(within(5.0, 60.0)),
                               "extent": draw(within(20.0, 1.0e4))},
                  "objects": objects},
        "agents": [
            {"name": "rov", "model": "videoray",
             "start": {"north": draw(within(-1.0e5, 1.0e5)), "east": 0.0, "depth": 1.0},
             "videoray": {"moment_arm": draw(within(0.01, 10.0))},
             "helm": {"domain": {"course": [0, 359, 360], "speed": [0, 2, 21]},
                      "behaviors": [{"type": "ConstantHeading", "name": "h", "heading": 90,
                                     "priority": draw(within(0.0, 1.0e6)),
                                     "duration": "no-time-limit"}]},
             "sensors": [
                 {"type": "sonar", "preset": "P900-45", "rays_per_beam": 4,
                  "source_level_db": draw(within(150.0, 260.0)),
                  "gain_db": draw(within(0.0, 200.0))},
                 {"type": "camera", "width": 64, "height": 48,
                  "max_range_m": draw(within(0.1, 1.0e4))}]},
            {"name": "diver", "model": "diver", "driver": "script",
             "start": {"north": 4.0, "east": 0.0, "depth": 2.0},
             "script": [{"t": 0, "heading_deg": 0, "speed": draw(within(0.0, 10.0))}],
             "bubbles": {"period": draw(within(0.5, 60.0)), "max_age": draw(within(0.1, 60.0)),
                         "spread_speed": draw(within(0.0, 2.0)),
                         "current": [draw(within(-5.0, 5.0)), draw(within(-5.0, 5.0))]}},
        ],
        "events": [{"at": draw(within(0.0, 1.0e7)),
                    "post": {"agent": "rov", "var": "DESIRED_SPEED", "value": 1.0}}],
        "metrics": {"follower": "rov", "target": "diver",
                    "acquire_hold_s": draw(within(0.01, 1.0e7)),
                    "range": draw(within(0.1, 1.0e4))},
    }


@pytest.mark.slow
@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(scene=scenes())
def test_every_scene_validate_accepts_runs_one_second(tmp_path: Path, scene: dict):
    path = tmp_path / "drawn.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    with time_limit(300, "a drawn scene"):  # a hang fails the example, not the suite
        try:
            sim = build_run(load_scenario(path))  # what validate builds
        except UhrisimError as refused:  # out of the scene (under the floor, in a box...)
            assert "\n" not in str(refused), str(refused)
            event(f"refused: {str(refused).split(': ', 2)[-1][:40]}")
            return
        sim.run(1.0)
        event("ran")
        assert sim.t == pytest.approx(1.0)
