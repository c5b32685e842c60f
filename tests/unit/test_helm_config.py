"""Helm configuration: .bhv loader, YAML twin, conditions, modes, and bad input."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from uhrisim.autonomy import HelmConfig, load_bhv, parse_bhv
from uhrisim.autonomy.conditions import And, HeldMemo, Relation, VarRef, parse_condition
from uhrisim.autonomy.geometry import is_convex, parse_polygon
from uhrisim.autonomy.modes import ModeEvaluator, evaluate_modes, parse_mode_entry
from uhrisim.core.errors import ConfigError

DATA = Path(__file__).resolve().parents[1] / "data" / "helm"
KNOWN = ("TRAIL_INFO", "CONTACT_INFO", "DEPTH_UPDATES", "LOITER_UPDATES")

# The authors' meta_vehicle.bhv as docs/reference/helm.md describes it (mode tree ACTIVE{DEPLOY}
# INACTIVE with children STATION-KEEPING, RETURNING, TRAILING, LOITERING; Trail and
# AvoidCollision templates spawned per contact; ConstantDepth; Loiter; Waypoint; StationKeep).
META_BHV = """\
initialize DEPLOY = false, RETURN = false
initialize STATION_KEEP = false, TRAIL = true   // the paper's ROV trails from the start

set MODE = ACTIVE {
  DEPLOY = true
} INACTIVE
set MODE = STATION-KEEPING {
  MODE = ACTIVE
  STATION_KEEP = true
}
set MODE = RETURNING { MODE = ACTIVE ; RETURN = true }
set MODE = TRAILING {
  MODE = ACTIVE
  TRAIL = true
} LOITERING

Behavior = BHV_ConstantDepth
{
  name = const_depth
  pwt = 100
  condition = DEPLOY = true
  updates = DEPTH_UPDATES
  depth = 1.5
}
Behavior = BHV_Loiter {
  name = loiter
  priority = 100
  condition = MODE == LOITERING
  polygon = format=radial, x=10, y=-20, radius=20, pts=8
  speed = 0.5
  clockwise = true
}
Behavior = BHV_Waypoint
{
  name = waypt_return
  condition = MODE==RETURNING
  endflag = STATION_KEEP = true
  endflag = RETURN = false
  speed = 1.0
  points = 0,0
}
Behavior = BHV_StationKeep
{
  name = station-keep
  condition = MODE==STATION-KEEPING
  center_activate = true
}
Behavior = BHV_Trail
{
  name = trail_
  pwt = 300
  condition = MODE==TRAILING
  templating = spawn
  updates = TRAIL_INFO
  trail_range = 2
  trail_angle = 180
  radius = 5
  nm_radius = 15
}
Behavior = BHV_AvoidCollision
{
  name = avd_
  pwt = 200
  condition = (DEPLOY = true) and (MODE != INACTIVE)
  templating = spawn
  updates = CONTACT_INFO
  pwt_outer_dist = 50
  pwt_inner_dist = 20
  completed_dist = 75
  min_util_cpa_dist = 8
  max_util_cpa_dist = 25
}
"""

META_YAML = {
    "initialize": {"DEPLOY": False, "RETURN": "false", "STATION_KEEP": False, "TRAIL": True},
    "modes": [
        "MODE = ACTIVE { DEPLOY = true } INACTIVE",
        "set MODE = STATION-KEEPING { MODE = ACTIVE ; STATION_KEEP = true }",
        {"var": "MODE", "value": "RETURNING", "conditions": ["MODE = ACTIVE", "RETURN = true"]},
        {
            "var": "MODE",
            "value": "TRAILING",
            "conditions": ["MODE=ACTIVE", "TRAIL=true"],
            "else": "LOITERING",
        },
    ],
    "behaviors": [
        {
            "type": "ConstantDepth",
            "name": "const_depth",
            "pwt": 100,
            "condition": "DEPLOY=true",
            "updates": "DEPTH_UPDATES",
            "depth": 1.5,
        },
        {
            "type": "Loiter",
            "name": "loiter",
            "priority": 100,
            "condition": "MODE==LOITERING",
            "polygon": "format=radial, x=10, y=-20, radius=20, pts=8",
            "speed": 0.5,
            "clockwise": True,
        },
        {
            "type": "BHV_Waypoint",
            "name": "waypt_return",
            "condition": ["MODE==RETURNING"],
            "endflag": ["STATION_KEEP = true", "RETURN = false"],
            "speed": 1,
            "points": [[0, 0]],
        },
        {
            "type": "StationKeep",
            "name": "station-keep",
            "condition": "MODE==STATION-KEEPING",
            "center_activate": "true",
        },
        {
            "type": "Trail",
            "name": "trail_",
            "pwt": 300,
            "condition": "MODE==TRAILING",
            "templating": "spawn",
            "updates": "TRAIL_INFO",
            "trail_range": 2,
            "trail_angle": 180,
            "radius": 5,
            "nm_radius": 15,
        },
        {
            "type": "AvoidCollision",
            "name": "avd_",
            "pwt": 200,
            "condition": "(DEPLOY = true) and (MODE != INACTIVE)",
            "templating": "spawn",
            "updates": "CONTACT_INFO",
            "pwt_outer_dist": 50,
            "pwt_inner_dist": 20,
            "completed_dist": 75,
            "min_util_cpa_dist": 8,
            "max_util_cpa_dist": 25,
        },
    ],
}


def test_meta_vehicle_bhv_equals_yaml_twin(tmp_path):
    f = tmp_path / "meta_vehicle.bhv"
    f.write_text(META_BHV)
    a = load_bhv(f, known_vars=KNOWN)
    b = HelmConfig.from_mapping(META_YAML, "scenario.yaml:helm", known_vars=KNOWN)
    assert a == b
    assert [s.kind for s in a.behaviors] == [
        "BHV_ConstantDepth",
        "BHV_Loiter",
        "BHV_Waypoint",
        "BHV_StationKeep",
        "BHV_Trail",
        "BHV_AvoidCollision",
    ]
    assert [s.name for s in a.behaviors if s.is_template] == ["trail_", "avd_"]
    assert a.initialize == (
        ("DEPLOY", "false"),
        ("RETURN", "false"),
        ("STATION_KEEP", "false"),
        ("TRAIL", "true"),
    )
    trail = a.behaviors[4]
    assert (trail.common.priority, trail.params.trail_range, trail.params.nm_radius) == (
        300.0,
        2.0,
        15.0,
    )
    # IvP defaults where the file is silent (ConstantDepth ZAIC pw 3, bw 100, delta 50)
    cd = a.behaviors[0].params
    assert (cd.peakwidth, cd.basewidth, cd.summitdelta) == (3.0, 100.0, 50.0)
    # a difference is noticed
    changed = dict(META_YAML, behaviors=[dict(META_YAML["behaviors"][0], depth=2.0)])
    assert HelmConfig.from_mapping(changed, known_vars=KNOWN).behaviors[0] != a.behaviors[0]


def test_data_file_pair_is_equal():
    a = load_bhv(DATA / "meta_vehicle.bhv", known_vars=KNOWN)
    b = HelmConfig.from_mapping(
        yaml.safe_load((DATA / "meta_vehicle.yaml").read_text()), known_vars=KNOWN
    )
    assert a == b


def test_radial_octagon_vertices():
    pts = parse_polygon("format=radial, x=10, y=-20, radius=20, pts=8")
    assert len(pts) == 8
    for k, (x, y) in enumerate(pts):  # bearing 22.5 + 45 k from the centre, clockwise order
        b = math.radians(22.5 + 45 * k)
        assert (x, y) == pytest.approx((10 + 20 * math.sin(b), -20 + 20 * math.cos(b)))
    # counter-clockwise input is stored clockwise, same first vertex
    ccw = parse_polygon("0,0 : 10,0 : 10,10 : 0,10")
    assert ccw == ((0, 0), (0, 10), (10, 10), (10, 0))
    assert is_convex(ccw) and not is_convex(((0, 0), (10, 0), (5, 2), (10, 10), (0, 10)))


def _err(text: str, tmp_path, known=KNOWN) -> ConfigError:
    f = tmp_path / "bad.bhv"
    f.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_bhv(f, known_vars=known)
    return e.value


def test_bad_input_names_file_and_line(tmp_path):
    ok_head = "initialize DEPLOY = false\n"
    e = _err(ok_head + "\nBehavior = BHV_Teleport\n{\n  name = x\n}\n", tmp_path)
    assert e.where.endswith("bad.bhv:3") and "unknown behavior 'BHV_Teleport'" in str(e)

    e = _err(
        ok_head + "Behavior = BHV_Loiter\n{\n name = l\n polygon = 0,0:9,0:9,9\n sped = 1\n}\n",
        tmp_path,
    )
    assert e.where.endswith("bad.bhv:6") and "'sped'" in str(e) and "speed" in str(e)

    e = _err(
        ok_head + "Behavior = BHV_Loiter\n{\n name = l\n"
        " polygon = 0,0 : 10,0 : 5,2 : 10,10 : 0,10\n}\n",
        tmp_path,
    )
    assert e.where.endswith("bad.bhv:5") and "convex" in str(e)

    e = _err(
        ok_head + "Behavior = BHV_ConstantDepth\n{\n name = d\n condition = DEPLOY = true\n"
        " condition = DEPLOYED = true\n depth = 2\n}\n",
        tmp_path,
    )
    assert e.where.endswith("bad.bhv:6") and "'DEPLOYED'" in str(e)

    e = _err("set MODE = ACTIVE {\n  GO = true\n} INACTIVE\n", tmp_path)
    assert e.where.endswith("bad.bhv:1") and "'GO'" in str(e)

    # pHelmIvP refuses a negative duration other than -1 (IvPBehavior.cpp:285-296)
    e = _err(ok_head + "Behavior = BHV_Trail\n{\n name = t\n duration = -5\n}\n", tmp_path)
    assert e.where.endswith("bad.bhv:5") and "duration must be >= 0" in str(e)

    e = _err(ok_head + "Behavior = BHV_ConstantDepth\n{\n name = d\n depth = deep\n}\n", tmp_path)
    assert e.where.endswith("bad.bhv:5") and "number" in str(e)

    e = _err("Behavior = BHV_ConstantDepth\n{\n name = d\n", tmp_path)
    assert e.where.endswith("bad.bhv:1") and "never closed" in str(e)

    e = _err("ProcessConfig = pHelmIvP\n", tmp_path)
    assert e.where.endswith("bad.bhv:1") and "cannot read line" in str(e)

    e = _err(
        "Behavior = BHV_ConstantDepth\n{\n name = d\n}\n"
        "Behavior = BHV_ConstantDepth\n{\n name = d\n}\n",
        tmp_path,
    )
    assert "duplicate behavior name 'd'" in str(e)


def test_condition_variable_known_from_other_sources(tmp_path):
    text = (
        "Behavior = BHV_ConstantDepth\n{\n name = d\n endflag = DONE = true\n depth = 1\n}\n"
        "Behavior = BHV_ConstantDepth\n{\n name = e\n condition = DONE = true\n"
        " condition = DIVER_NAV_TYPE = swimmer\n condition = BUTTON = 1\n depth = 2\n}\n"
    )
    f = tmp_path / "ok.bhv"
    f.write_text(text)
    with pytest.raises(ConfigError, match="BUTTON"):
        load_bhv(f)
    # DONE from an endflag, DIVER_NAV_TYPE from the diver's reports (HelmIvP.cpp:1788-1790)
    cfg = load_bhv(f, known_vars=["BUTTON"])
    assert len(cfg.behaviors[1].common.conditions) == 3


def test_mapping_errors_name_the_field():
    with pytest.raises(ConfigError, match=r"helm: unknown key 'behaviours' \(did you mean"):
        HelmConfig.from_mapping({"behaviours": []})
    with pytest.raises(ConfigError, match=r"helm.behaviors\[0\].spd: BHV_Loiter has no"):
        HelmConfig.from_mapping(
            {"behaviors": [{"type": "Loiter", "name": "l", "polygon": "0,0:1,0:1,1", "spd": 1}]}
        )
    with pytest.raises(ConfigError, match="needs a 'depth' domain axis"):
        HelmConfig.from_mapping(
            {
                "behaviors": [{"type": "ConstantDepth", "name": "d", "depth": 1}],
                "domain": {"course": [0, 359, 360], "speed": [0, 5, 26]},
            }
        )


def test_conditions_parse_and_evaluate():
    c = parse_condition("(DEPLOY = true) and (RETURN != true) or MODE==STATION-KEEPING")
    assert c == parse_condition("DEPLOY=true && RETURN!=true || (MODE == STATION-KEEPING)")
    assert c != parse_condition("DEPLOY==true && RETURN!=true || MODE == STATION-KEEPING")
    assert c.evaluate({"DEPLOY": "true", "RETURN": "false"})
    assert not c.evaluate({"DEPLOY": "true", "RETURN": "true"})
    assert not c.evaluate({"DEPLOY": "TRUE", "RETURN": "false"})  # IvP: case-sensitive
    # '==' is IvP's field match, '=' exact equality
    assert c.evaluate({"MODE": "ACTIVE:STATION-KEEPING"})
    assert not parse_condition("MODE = STATION-KEEPING").evaluate(
        {"MODE": "ACTIVE:STATION-KEEPING"}
    )
    assert parse_condition("MODE == ACTIVE:SURVEY").evaluate({"MODE": "ACTIVE:SURVEY:DEEP"})
    assert not parse_condition("MODE == TIVE").evaluate({"MODE": "ACTIVE:SURVEY"})
    assert not parse_condition("X < 3").evaluate({})  # unknown variable: false
    assert not parse_condition("X != 3").evaluate({})  # ... whatever the operator
    assert parse_condition("X < 3.5").evaluate({"X": "2"})  # numeric string vs number
    assert not parse_condition("X != 3").evaluate({"X": "abc"})  # non-numeric vs number
    assert not parse_condition("X != abc").evaluate({"X": 3.0})
    assert parse_condition("X >= 2").evaluate({"X": 2.0})
    assert parse_condition("X == 2").evaluate({"X": 2.0})
    assert not parse_condition("X > 2").evaluate({"X": 2.0})
    assert parse_condition("X <= -1e3").evaluate({"X": -1000.0})
    assert parse_condition("NAME < bob").evaluate({"NAME": "alice"})  # lexical
    assert parse_condition('NAME = "a b"') == Relation("NAME", "=", "a b")
    assert parse_condition("not (A = 1)").evaluate({"A": 2.0})
    # right-hand variables: $(VAR)
    r = parse_condition("DEPTH > $(MIN_DEPTH)")
    assert r == Relation("DEPTH", ">", VarRef("MIN_DEPTH")) and r.variables() == {
        "DEPTH",
        "MIN_DEPTH",
    }
    assert r.evaluate({"DEPTH": 3.0, "MIN_DEPTH": 2.0})
    assert not r.evaluate({"DEPTH": 3.0})
    assert isinstance(parse_condition("A=1 and B=2 and C=3"), And)
    for bad in ("A ==", "== 3", "(A = 1", "A = 1 B = 2", ""):
        with pytest.raises(ConfigError):
            parse_condition(bad)


def test_held_memo_agrees_with_evaluating_every_time():
    """A behavior's run conditions are evaluated again only when a variable they read
    changed; 1.0 and True are equal in Python but not to a relation."""
    conditions = (parse_condition("MODE == TRAILING"), parse_condition("GO = 1"))
    held = HeldMemo(conditions)
    info: dict[str, object] = {}
    for var, value in [("NAV_X", 1.0), ("MODE", "ACTIVE:TRAILING"), ("GO", 1.0),
                       ("GO", True), ("NAV_X", 2.0), ("GO", 0.0), ("MODE", "ACTIVE")]:
        info[var] = value
        assert held(info) == all(c.evaluate(info) for c in conditions), (var, value)


def test_mode_tree_of_the_meta_vehicle():
    entries = tuple(
        parse_mode_entry(s)
        for s in (
            "set MODE = ACTIVE { DEPLOY = true } INACTIVE",
            "MODE = STATION-KEEPING { MODE = ACTIVE ; STATION_KEEP = true }",
            "MODE = RETURNING { MODE = ACTIVE ; RETURN = true }",
            "MODE = TRAILING {\n MODE = ACTIVE\n TRAIL = true\n} LOITERING",
        )
    )

    def mode(**kv):
        info = {"DEPLOY": "false", "RETURN": "false", "STATION_KEEP": "false", "TRAIL": "false"}
        info.update({k: str(v).lower() for k, v in kv.items()})
        return evaluate_modes(entries, info)["MODE"]

    assert mode() == "INACTIVE"
    assert mode(DEPLOY=True, TRAIL=True) == "ACTIVE:TRAILING"
    assert mode(DEPLOY=True) == "ACTIVE:LOITERING"
    assert mode(DEPLOY=True, RETURN=True, TRAIL=True) == "ACTIVE:RETURNING"  # first sibling wins
    assert mode(DEPLOY=True, STATION_KEEP=True, RETURN=True) == "ACTIVE:STATION-KEEPING"
    assert mode(RETURN=True, TRAIL=True) == "INACTIVE"
    with pytest.raises(ConfigError):
        parse_mode_entry("MODE = A { X = 1 } B C")
    # the helm's evaluator redoes the tree only when a variable it reads changed, and
    # always agrees with evaluate_modes (no entry reads NAV_X, nor MODE from the buffer:
    # it is built afresh)
    evaluator = ModeEvaluator(entries)
    info: dict[str, object] = {"MODE": "ACTIVE"}
    steps = [("NAV_X", 1.0), ("DEPLOY", "true"), ("NAV_X", 2.0), ("TRAIL", "true"),
             ("RETURN", "true"), ("RETURN", "false"), ("DEPLOY", "false"), ("MODE", "X")]
    built = evaluator(info)
    for var, value in steps:
        info[var] = value
        again = evaluator(info)
        assert again == evaluate_modes(entries, info)
        assert (again is built) == (var in ("NAV_X", "MODE"))
        built = again


def test_parse_bhv_domain_and_comments():
    cfg = parse_bhv(
        "// only a comment\nBehavior = BHV_ConstantDepth  // trailing comment\n{\n"
        " name = d // the name\n depth = 4\n}\n"
    )
    assert cfg.behaviors[0].params.depth == 4.0 and cfg.behaviors[0].where == "<bhv>:2"


MACROS = {"VNAME": "videoray", "HOME": "0,0", "LOITER_CENTER": "x=10,y=-20",
          "TRAIL_ENABLED": "yes"}  # fmt: skip


def test_mission_style_file_with_nsplug_macros_and_ivp_aliases():
    cfg = load_bhv(DATA / "rov_nsplug.bhv", known_vars=KNOWN, macros=MACROS)
    by = {b.name: b for b in cfg.behaviors}
    assert [m.value for m in cfg.modes] == [
        "ACTIVE", "STATION-KEEPING", "RETURNING", "TRAILING", "LOITERING",
    ]  # fmt: skip
    assert dict(cfg.initialize)["TRAIL"] == "true"
    assert by["hold_depth"].common.duration == -1.0  # no-time-limit
    orbit = by["orbit"].params
    assert (orbit.capture_radius, orbit.slip_radius, orbit.post_suffix) == (2.0, 6.0, "rov")
    assert orbit.polygon == parse_polygon("format=radial, x=10, y=-20, radius=15, pts=8, snap=0.5")
    assert ("visual_hints", "nextpt_color=white, edge_color=orange") in by["orbit"].common.display
    assert by["follow_"].params.pwt_outer_dist == 500.0
    assert by["go_home"].params.points == ((0.0, 0.0),) and by["go_home"].params.lead == 4.0
    sk = by["hold_station"].params
    assert (sk.swing_time, sk.hibernation_radius) == (3.0, 8.0)
    # without TRAIL_ENABLED the #else branches are taken; a missing macro is an error
    other = load_bhv(DATA / "rov_nsplug.bhv", known_vars=KNOWN,
                     macros={k: v for k, v in MACROS.items() if k != "TRAIL_ENABLED"})  # fmt: skip
    assert dict(other.initialize)["TRAIL"] == "false"
    assert [m.value for m in other.modes][-1] == "LOITERING" and len(other.modes) == 4
    with pytest.raises(ConfigError, match=r"macro \$\(HOME\) is not defined") as e:
        load_bhv(
            DATA / "rov_nsplug.bhv", known_vars=KNOWN, macros={"LOITER_CENTER": "1,2", "VNAME": "v"}
        )
    assert e.value.where.endswith("rov_nsplug.bhv:108")


def test_preprocessor_errors(tmp_path):
    for text, msg, line in (
        ("#ifdef A\ninitialize X = 1\n", "never closed", 1),
        ("#endif\n", "without #ifdef", 1),
        ("initialize X = 1\n#include other.bhv\n", "unsupported directive", 2),
    ):
        e = _err(text, tmp_path)
        assert msg in str(e) and e.where.endswith(f"bad.bhv:{line}")
    f = tmp_path / "def.bhv"
    f.write_text("#define D 7\n#ifndef E\ninitialize X = $(D)\n#endif\n"
                 "Behavior = BHV_Waypoint\n{\n name = w\n points = 0,9\n}\n")
    assert load_bhv(f).initialize == (("X", 7.0),)
