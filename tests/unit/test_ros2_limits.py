"""Command validation (uhrisim.bridges.ros2.limits) without ROS: each rule's outcome, the
counts per topic and reason, and the rate-limited report with the number suppressed."""

from __future__ import annotations

import math

import pytest

from uhrisim.bridges.ros2.limits import CommandEnvelope, CommandValidator
from uhrisim.core.errors import ConfigError


def test_each_rule_refuses_or_clamps_and_counts() -> None:
    lines: list[str] = []
    v = CommandValidator({"rov": CommandEnvelope(max_speed=1.2)}, log=lines.append)
    assert v.desired("rov", "desired_heading", 370.0) == pytest.approx(10.0)
    assert v.desired("rov", "desired_heading", math.nan) is None
    assert v.desired("rov", "desired_speed", 0.5) == 0.5
    assert v.desired("rov", "desired_speed", 1e6) == 1.2
    assert v.desired("rov", "desired_speed", -5.0) is None
    assert v.desired("rov", "desired_depth", -1.0) == 0.0
    assert v.desired("rov", "desired_depth", 1e6) == 1e6  # the floor: where it takes effect
    assert v.depth_above_floor("rov", 1e6, 9.5) == 9.5
    assert v.depth_above_floor("rov", 3.0, 9.5) == 3.0
    assert v.desired("rov", "desired_depth", math.inf) is None
    assert v.thrusters("rov", [200.0, -20.0, 30.0]) == (150.0, -20.0, 30.0)
    assert v.thrusters("rov", [1.0, 2.0]) is None
    assert v.thrusters("rov", [1.0, math.nan, 2.0]) is None
    assert (v.refused, v.clamped) == (5, 4)
    assert v.counts()["/rov/cmd/desired_speed"] == {
        "outside the speed envelope": 1, "negative speed (the controller cannot reverse)": 1}
    assert len(lines) == 9  # one per topic and reason (not yet rate-limited)
    assert v.depth_above_floor("rov", 1e6, math.nan) == 1e6  # no floor known: no limit


def test_a_reversing_controller_may_back_up_within_its_envelope() -> None:
    v = CommandValidator({"auv": CommandEnvelope(max_speed=2.0, reverse=True)})
    assert v.desired("auv", "desired_speed", -1.0) == -1.0
    assert v.desired("auv", "desired_speed", -5.0) == -2.0
    assert v.refused == 0 and v.clamped == 1


def test_reports_are_rate_limited_and_say_how_many_were_suppressed() -> None:
    lines: list[str] = []
    now = [0.0]  # the validator's clock (s): the 50 calls share one period, however slow
    v = CommandValidator({"rov": CommandEnvelope()}, log=lines.append, log_period_s=0.2,
                         clock=lambda: now[0])
    for _ in range(50):
        v.thrusters("rov", [1.0])
    assert len(lines) == 1 and v.refused == 50
    now[0] = 0.25
    v.thrusters("rov", [1.0])
    assert len(lines) == 2
    assert lines[1].endswith("(49 more since the last report: 49× 1 values, need 3)")


def test_suppressed_counts_are_per_value() -> None:
    """A report's suppressed count never mixes values: each value with its own count,
    the most frequent first, beyond four the rest summed up."""
    lines: list[str] = []
    now = [0.0]
    v = CommandValidator({"rov": CommandEnvelope(max_speed=1.0)}, log=lines.append,
                         log_period_s=5.0, clock=lambda: now[0])
    for speed in [-5.0] * 7 + [-7.0] * 3 + [-1.0, -2.0, -3.0, -4.0]:
        v.desired("rov", "desired_speed", speed)
    now[0] = 5.0
    v.desired("rov", "desired_speed", -5.0)
    assert len(lines) == 2 and lines[1].endswith(
        "(13 more since the last report: 6× -5 m/s, 3× -7 m/s, 1× -1 m/s, 1× -2 m/s, "
        "2× 2 other values)")


def test_envelope_checks_its_fields() -> None:
    with pytest.raises(ConfigError, match="max_speed"):
        CommandEnvelope(max_speed=0.0)
    with pytest.raises(ConfigError, match="thruster_limit"):
        CommandEnvelope(thruster_limit=math.inf)
