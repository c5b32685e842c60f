"""The gesture language: the shipped gestures load, say the commands the issue asks for,
are executable by the articulated diver (joint limits and speeds), and bad files are
refused with one line naming the field."""

from __future__ import annotations

import copy
import json
import math
from importlib import resources

import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.perception.gestures import ARM_JOINTS, GestureSet
from uhrisim.perception.signals import COMMANDS, Command

# The articulated diver's joints (issue 25's body model): AAOS normal active ranges x 0.8
# for a dry suit and the assumed speeds (deg, deg/s), as dynamics/diver_body.py states
# them; part 2 checks against the model itself.
_RANGES_DEG = {"shoulder_flex": (-60, 180, 90), "shoulder_abd": (-45, 180, 90),
               "shoulder_rot": (-90, 70, 90), "elbow": (0, 150, 120), "wrist": (-70, 80, 120),
               "fingers": (0, 90, 144)}
LIMITS = {f"{side}_{kind}": (math.radians(0.8 * lo), math.radians(0.8 * hi))
          for side in ("left", "right") for kind, (lo, hi, _) in _RANGES_DEG.items()}
SPEEDS = {f"{side}_{kind}": math.radians(v)
          for side in ("left", "right") for kind, (_, _, v) in _RANGES_DEG.items()}

SHIPPED = json.loads(resources.files("uhrisim.perception").joinpath(
    "data/gestures.json").read_text())


def test_every_command_the_issue_names_has_a_gesture():
    gestures = GestureSet.load()
    said = {g.command for g in gestures.gestures.values() if g.channel == "gesture"}
    assert said == set(COMMANDS)  # follow me, stop, come here, go up, bring X, light, OK, done
    sonar = [g for g in gestures.gestures.values() if g.channel == "sonar"]
    assert [g.command for g in sonar] == ["come_here"]


def test_gestures_fit_the_body_models_limits_and_speeds():
    assert GestureSet.load().check_motion(LIMITS, SPEEDS) == []


def test_motion_check_finds_a_too_fast_move_and_a_joint_out_of_range():
    data = copy.deepcopy(SHIPPED)
    frames = data["gestures"]["stop"]["keyframes"]
    frames[1]["t"] = 0.5  # the elbow would have to straighten 110° in half a second
    frames[2]["joints"] = {"{s}_elbow": 130}  # beyond 0.8 × 150°
    problems = GestureSet.from_mapping(data).check_motion(LIMITS, SPEEDS)
    assert any("stop 0-0.5 s: right_elbow moves 110° in 0.50 s" in p for p in problems)
    assert any("right_elbow 130° outside [0°, 120°]" in p for p in problems)


def test_timeline_resolves_the_sides_and_carries_joints_forward():
    come = GestureSet.load().gestures["come_here"]
    frames = come.timeline("left")
    assert [k.t for k in frames] == [0.0, 1.2, 2.2, 3.2, 4.2, 5.2]
    # the beckon pulls the forearm in and out; the shoulder stays where keyframe 1 put it
    elbow = [math.degrees(k.joints["left_elbow"]) for k in frames]
    assert elbow == pytest.approx([110, 20, 100, 20, 100, 20])
    assert all(math.degrees(k.joints["left_shoulder_flex"]) == pytest.approx(80)
               for k in frames[1:])
    assert math.degrees(frames[0].joints["right_elbow"]) == pytest.approx(15)  # other arm
    assert set(frames[0].joints) == {f"{s}_{k}" for s in ("left", "right") for k in ARM_JOINTS}


def test_bring_tool_counts_the_tools_number():
    gestures = GestureSet.load()
    gesture, count = gestures.for_command(Command("bring_tool", "lift_bag"))
    assert count == gestures.tool_numbers["lift_bag"] == 4
    frames = gesture.timeline(count=count)
    # each count raises the straight arm sideways and lowers it; then it drops to his side
    abduction = [round(math.degrees(k.joints["right_shoulder_abd"])) for k in frames]
    assert abduction[3:] == [60, 120, 60, 120, 60, 120, 60, 120, 60, 5, 5]
    assert gesture.duration_s(count) == pytest.approx(3.1 + 4 * 1.9 + 1.5)
    assert gesture.duration_s(1) == pytest.approx(3.1 + 1.9 + 1.5)
    with pytest.raises(ConfigError, match="needs a count"):
        gesture.timeline()
    with pytest.raises(ConfigError, match="no number for tool 'crowbar'"):
        gestures.for_command(Command("bring_tool", "crowbar"))


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["gestures"]["ok"]["keyframes"][1]["joints"].update({"{s}_knuckle": 3}),
     r"gestures.ok.keyframes\[1\].joints.\{s\}_knuckle: unknown joint"),
    (lambda d: d["gestures"]["ok"].update(command="wave"), r"gestures.ok.command: unknown "),
    (lambda d: d["gestures"]["ok"]["keyframes"][2].update(t=0.5),
     r"gestures.ok.keyframes\[2\].t: t must be a number after"),
    (lambda d: d["gestures"]["ok"]["keyframes"][1].update(hand="claw"),
     r"keyframes\[1\].hand: unknown hand shape 'claw'"),
    (lambda d: d["gestures"]["stop"]["keyframes"][0].update(pose="salute"),
     r"keyframes\[0\].pose: unknown pose 'salute'"),
    (lambda d: d["gestures"]["go_up"]["keyframes"][1]["joints"].update({"{s}_elbow": "x"}),
     r"joints.\{s\}_elbow: must be a finite angle"),
    (lambda d: d["gestures"]["bring_tool"].pop("count"), r"bring_tool.count: bring_tool, and"),
    (lambda d: d["gestures"]["ok"].update(end=[{"t": 1.0, "joints": {}}]),
     r"gestures.ok.end: only a gesture with a count has end keyframes"),
])
def test_bad_language_file_is_a_one_line_error_naming_the_field(edit, message):
    data = copy.deepcopy(SHIPPED)
    edit(data)
    with pytest.raises(ConfigError, match=message) as error:
        GestureSet.from_mapping(data, "gestures.json")
    assert "\n" not in str(error.value)


def test_a_language_file_is_read_from_disk(tmp_path):
    path = tmp_path / "lang.json"
    path.write_text(json.dumps(SHIPPED))
    assert set(GestureSet.load(path).gestures) == set(SHIPPED["gestures"])
    path.write_text("{not json")
    with pytest.raises(ConfigError, match=r"lang\.json: not JSON"):
        GestureSet.load(path)
