"""Every number of a scenario has a physical range and the scene a cost bound (issue 29):
each value the scenario fuzzer found accepted and then failing (an overflow, an index
error, a hang, gigabytes) is refused by ``uhrisim validate`` in one line naming the file,
line and field, exit status 2, before the costly part is built.

The work is bounded, not timed: the cases are the expensive ones (a camera of 67
megapixels, a helm domain of 3·10^8 points, a bubble every 0.1 ms), so a refusal that came
after building them would not finish within the guard below (which only keeps a
regression from hanging the suite)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tests.support.cli import one_line_error
from tests.support.small_scene import SMALL_SCENE
from tests.support.time_limit import time_limit
from uhrisim.cli import app

BASE = (SMALL_SCENE
        .replace("    driver: none\n", """\
    helm:
      domain: {course: [0, 359, 360], speed: [0, 2, 21], depth: [0, 20, 21]}
      behaviors:
        - {type: ConstantDepth, name: depth, depth: 2, duration: no-time-limit}
    sensors:
      - {type: sonar, preset: P900-45, rays_per_beam: 4}
      - {type: camera}
""")
        .replace("depth: 2}\nrecording", "depth: 2}\n    bubbles: {}\nrecording")
        + "metrics: {follower: rov, target: diver}\n")

CASES = [
    # (what, replace this, with this, line, what the line says)
    ("a breath every 1e-300 s living 1e300 s", "bubbles: {}",
     "bubbles: {period: 1e-300, max_age: 1e300}", 26,
     "agents[1].bubbles.period: must be in [0.5, 60] s, got 1e-300"),
    ("a breath every 0.1 ms (360 000 meshes)", "bubbles: {}", "bubbles: {period: 0.0001}", 26,
     "agents[1].bubbles.period: must be in"),
    ("bubbles kept alive by the hundred", "bubbles: {}",
     "bubbles: {period: 0.5, max_age: 600, clusters: 10}", 26,
     "agents[1].bubbles: a breath every 0.5 s whose clouds live 600 s keeps 1201 breaths"),
    ("bubbles spreading at 1e308 m/s", "bubbles: {}", "bubbles: {spread_speed: 1e308}", 26,
     "agents[1].bubbles.spread_speed: must be in [0, 2] m/s"),
    ("a current of 1e308 m/s", "bubbles: {}", "bubbles: {current: [1e308, 0]}", 26,
     "agents[1].bubbles.current: must be in [-5, 5] m/s"),
    ("a source level of 1e308 dB", "rays_per_beam: 4}", "rays_per_beam: 4, source_level_db: 1e308}",
     17, "agents[0].sensors[0].source_level_db: must be in [150, 260]"),
    ("a gain of 1e300 dB", "rays_per_beam: 4}", "rays_per_beam: 4, gain_db: 1e300}", 17,
     "agents[0].sensors[0].gain_db: must be in [0, 200] dB"),
    ("a moment arm of 1e308 m", "    helm:\n", "    videoray: {moment_arm: 1e308}\n    helm:\n",
     12, "agents[0].videoray.moment_arm: must be in (0, 10] m"),
    ("a hold of 1e308 s for the metrics", "{follower: rov, target: diver}",
     "{follower: rov, target: diver, acquire_hold_s: 1e308}", 28,
     "metrics.acquire_hold_s: Input should be less than or equal to 10000000"),
    ("a camera seeing 1e-308 m", "{type: camera}", "{type: camera, max_range_m: 1e-308}", 18,
     "agents[0].sensors[1].max_range_m: must be in [0.1, 10000] m"),
    ("an 8192 x 8192 camera sampling every pixel", "{type: camera}",
     "{type: camera, width: 8192, height: 8192, sampling: full}", 18,
     "camera.width: 8192 x 8192 pixels is more than 2.5 megapixels"),
    ("a helm axis of 3e8 points", "course: [0, 359, 360]", "course: [0, 359, 300000000]", 12,
     "domain.course: axis 'course' has 3e+08 points, more than 10000"),
    ("a helm axis of 1e308 points", "course: [0, 359, 360]", "course: [0, 359, 1e308]", 12,
     "axis 'course' has 1e+308 points"),
    ("a helm domain of 1e8 points", "speed: [0, 2, 21], depth: [0, 20, 21]",
     "speed: [0, 2, 10000], depth: [0, 20, 21]", 12,
     "the decision domain's required axes have 7.56e+07 points together, more than 50000000"),
    ("a behavior priority of 1e308", "duration: no-time-limit}",
     "duration: no-time-limit, priority: 1e308}", 12, "priority must be <= 1e+06"),
    ("an agent 1e7 m from the scene", "start: {north: 0, east: 0, depth: 1,",
     "start: {north: 10000000, east: 0, depth: 1,", 11,
     "agents[0].start.north: Input should be less than or equal to 100000"),
    ("an agent 1e308 m from the scene", "start: {north: 0, east: 0, depth: 1,",
     "start: {north: 0, east: -1e308, depth: 1,", 11, "agents[0].start.east"),
    ("a box of 1e308 m", "size: [2, 2, 2]", "size: [1e308, 2, 2]", 7,
     "world.objects[0].size[0]: Input should be less than or equal to 10000"),
    ("a boolean inside a list of numbers", "size: [2, 2, 2]", "size: [yes, 2, 2]", 7,
     "world.objects[0].size: must be numbers, got [True, 2, 2]"),
    ("an object 1e6 m above the surface", "depth: 7}}", "depth: -1000000}}", 7,
     "world.objects[0].position.depth: Input should be greater than or equal to -100"),
    ("an empty variable name", "metrics:",
     "events:\n  - {at: 1, post: {agent: rov, var: '', value: 1}}\nmetrics:", 29,
     "events[0].post.var: a MOOS variable name must be one word, got ''"),
    ("more objects than a scene may hold", "  objects:\n",
     "  objects:\n" + "".join(f"    - {{type: sphere, label: s{i}, radius: 0.1, position: "
                              f"{{north: {i % 40}, east: {i // 40}, depth: 5}}}}\n"
                              for i in range(201)), 6,
     "world.objects: Tuple should have at most 200 items"),
    ("metrics naming a missing agent", "{follower: rov, target: diver}",
     "{follower: rov, target: nobody}", 28, "metrics.target: names unknown agent 'nobody'"),
    ("a button naming a missing agent", "metrics:",
     "buttons:\n  - {label: go, agent: nobody, var: X, value: 1}\nmetrics:", 29,
     "buttons[0].agent: names unknown agent 'nobody'"),
    ("an event naming a missing agent", "metrics:",
     "events:\n  - {at: 1, post: {agent: rover, var: X, value: 1}}\nmetrics:", 29,
     "events[0].post.agent: names unknown agent 'rover'; did you mean 'rov'?"),
]


def test_the_base_scenario_validates(tmp_path: Path):
    path = tmp_path / "s.yaml"
    path.write_text(BASE)
    result = CliRunner().invoke(app, ["validate", str(path)])
    assert result.exit_code == 0 and "OK" in result.output, result.output


@pytest.mark.parametrize(("what", "old", "new", "line", "says"), CASES,
                         ids=[c[0] for c in CASES])
def test_out_of_range_or_over_budget_is_one_line(tmp_path: Path, what, old, new, line, says):
    assert old in BASE, what
    path = tmp_path / "s.yaml"
    path.write_text(BASE.replace(old, new, 1))
    with time_limit(120, what):
        result = CliRunner().invoke(app, ["validate", str(path)])
    message = one_line_error(result, says)
    assert message.startswith(f"error: {path}:{line}"), message


def test_a_bad_value_is_quoted_short(tmp_path: Path):
    """A 1.5-million-character value is quoted by its start and its length."""
    path = tmp_path / "s.yaml"
    huge = "x" * 1_500_000
    path.write_text(BASE.replace("metrics:", "events:\n  - {at: 1, post: {agent: rov, var: "
                                 f"DESIRED_HEADING, value: '{huge}'}}}}\nmetrics:"))
    message = one_line_error(CliRunner().invoke(app, ["validate", str(path)]),
                             "DESIRED_HEADING must be a finite number",
                             "characters in all)")
    assert len(message) < 600, len(message)
