"""Scenarios that cannot be flown are refused before the run, in one line naming the file,
line and field (issue 20's reproducers, each a case here).

Each case is a small, valid scenario with one thing broken; loading and building it must
raise a ConfigError (or AssetError) whose message is one line and names where.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.small_scene import SMALL_SCENE
from tests.support.work_bound import peak_memory
from uhrisim.core.errors import UhrisimError
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

BASE = SMALL_SCENE


def build(tmp_path: Path, text: str) -> Simulation:
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return Simulation(load_scenario(path), raycast_sensors=False)


def test_the_base_scenario_is_valid(tmp_path):
    sim = build(tmp_path, BASE)
    sim.run(1.0)


CASES = [
    # (what, replace this, with this, message part, line)
    ("start under the sea floor", "depth: 1, heading_deg: 0}", "depth: 50, heading_deg: 0}",
     "below the sea floor", 11),
    ("start above the surface", "depth: 1, heading_deg: 0}", "depth: -2, heading_deg: 0}",
     "above the surface", 11),
    ("start inside a box", "start: {north: 0, east: 0, depth: 1,",
     "start: {north: 10, east: 10, depth: 7,", "inside a 'crate' mesh", 11),
    ("agents at the same point", "start: {north: 5, east: 0, depth: 2",
     "start: {north: 0, east: 0, depth: 1", "inside its collision distance", 16),
    ("duplicate key", "duration: 10\n", "duration: 10\nduration: 20\n",
     "duplicate key 'duration' (first at line 2)", 3),
    ("a YAML boolean for a number", "duration: 10", "duration: yes",
     "duration: must be a number, got True", 2),
    ("script legs out of time order", "- {t: 5, heading_deg: 180",
     "- {t: 0, heading_deg: 180", "in time order", 17),
    ("recording rate not whole steps", "odometry_rate_hz: 10", "odometry_rate_hz: 7",
     "not a whole number of physics steps", 20),
    ("a model too stiff for the step", "    driver: none\n",
     "    driver: none\n    videoray: {J: 0.000001}\n", "too stiff", 10),
    ("a procedural floor too big", "{type: flat, depth: 8, extent: 50}",
     "{type: procedural, depth: 8, extent: 600}", "cells, more than 250000", 5),
    ("moving an object that does not exist", "recording:",
     "events:\n  - {at: 1, move_object: {label: crat, position: {north: 1}}}\nrecording:",
     "no movable object 'crat'", 21),
    ("adding a mesh that does not exist", "recording:",
     "events:\n  - {at: 1, add_object: {type: mesh, label: w, file: nope.obj}}\nrecording:",
     "nope.obj", 21),
]


@pytest.mark.parametrize(("what", "old", "new", "message", "line"), CASES,
                         ids=[c[0] for c in CASES])
def test_refused_in_one_line_naming_file_line_and_field(tmp_path, what, old, new, message,
                                                        line):
    assert old in BASE
    with pytest.raises(UhrisimError) as e:
        build(tmp_path, BASE.replace(old, new, 1))
    text = str(e.value)
    assert message in text and "\n" not in text
    assert f"s.yaml:{line}" in text


#: Python memory a refusal may take (MiB): building first would take hundreds.
MAX_REFUSAL_MIB = 64.0  # measured 16-34 MiB


def test_helm_with_no_behaviors_and_huge_polygons_are_refused(tmp_path):
    helm = ("    driver: helm\n    helm: {bhv_file: rov.bhv, domain: {course: [0, 359, 360], "
            "speed: [0, 2, 21]}}\n")
    (tmp_path / "rov.bhv").write_text("initialize DEPLOY = true\n")
    with pytest.raises(UhrisimError, match=r"rov\.bhv: the helm declares no behaviors"):
        build(tmp_path, BASE.replace("    driver: none\n", helm))
    (tmp_path / "rov.bhv").write_text(
        "Behavior = BHV_Loiter\n{\n name = l\n polygon = format=radial, x=0, y=0, radius=9, "
        "pts=10000000\n}\n")
    with peak_memory() as peak, \
            pytest.raises(UhrisimError, match=r"rov\.bhv:4: polygon: radial polygon needs"):
        build(tmp_path, BASE.replace("    driver: none\n", helm))
    assert peak.mib < MAX_REFUSAL_MIB  # refused up front, not built first
    (tmp_path / "rov.bhv").write_bytes(b"Behavior = BHV_Loiter\n{\n name = \xff\xfe\n}\n")
    with pytest.raises(UhrisimError, match=r"rov\.bhv: not a text file"):
        build(tmp_path, BASE.replace("    driver: none\n", helm))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        # "billion laughs": 675 bytes that would expand to 9^8 values
        ("a: &a [x,x,x,x,x,x,x,x,x]\n" + "".join(
            f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n" for a, b in zip("abcdefg", "bcdefgh",
                                                                       strict=True)),
         "expands to more than 200000 values"),
        ("x: " + "[" * 5000 + "]" * 5000 + "\n", "nested deeper than 64 levels"),
        ("".join("  " * i + f"k{i}:\n" for i in range(3000)),
         r"s\.yaml:65: values nested deeper than 64 levels"),  # seen before composing
        ("- " * 3000 + "x\n", "nested deeper than 64 levels"),  # the composer's recursion
    ],
    ids=["alias-bomb", "deep-flow", "deep-block", "deep-compact"],
)
def test_documents_too_big_or_too_deep_are_refused_quickly(tmp_path, text: str, message: str):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with peak_memory() as peak, pytest.raises(UhrisimError, match=message) as e:
        load_scenario(path)
    assert peak.mib < MAX_REFUSAL_MIB and "\n" not in str(e.value)
    assert str(path) in str(e.value)
