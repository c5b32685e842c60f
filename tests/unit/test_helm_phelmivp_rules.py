"""Where pHelmIvP refuses, idles or loses mail, our helm does too: one test per rule, each
citing the MOOS-IvP source (github.com/moos-ivp/moos-ivp, ivp/src; "S/" below) it encodes.

These are the rules that decided whether a user's mission flew in the real helm: a
ConstantDepth without a duration, a spawning alert that arrives while the helm is parked,
a spawned behavior whose contact the helm has not heard of.
"""

from __future__ import annotations

import pytest

from uhrisim.autonomy import Helm, HelmConfig, load_bhv
from uhrisim.autonomy.bhv import parse_bhv
from uhrisim.autonomy.config import HelmSettings, parse_domain
from uhrisim.core.errors import ConfigError

DOMAIN = {"course": [0, 359, 360], "speed": [0, 5, 26], "depth": [0, 100, 101, "optional"]}
NAV = {"NAV_X": 0.0, "NAV_Y": 0.0, "NAV_HEADING": 0.0, "NAV_SPEED": 0.0, "NAV_DEPTH": 0.0}
DIVER = "NAME=diver,X=0,Y=-30,SPD=0.5,HDG=180,DEP=2,TYPE=swimmer,TIME={t}"
SPAWN = "name=diver # contact=diver"
TRAIL = {"type": "Trail", "name": "trail_", "templating": "spawn", "updates": "TRAIL_INFO",
         "trail_range": 5, "pwt": 300}  # fmt: skip


def helm(behaviors: list[dict], engaged: bool = True, **settings) -> Helm:
    cfg = HelmConfig.from_mapping({"behaviors": behaviors, "domain": DOMAIN},
                                  known_vars=["TRAIL_INFO", "GO"])  # fmt: skip
    cfg = HelmConfig(cfg.behaviors, cfg.modes, cfg.initialize, cfg.domain,
                     settings=HelmSettings(start_engaged=engaged, **settings))  # fmt: skip
    return Helm(cfg, "rov")


def depth_only(**params) -> dict:
    return {"type": "ConstantDepth", "name": "depth", "depth": 3, **params}


# -- durations (S/lib_behaviors/IvPBehavior.cpp:329-380, 1293-1331) -------------------------
def test_constant_depth_without_duration_completes_at_its_first_running_iteration():
    # BHV_ConstantDepth.cpp:56-60 sets m_duration = 0 "to force the user to provide one"
    with pytest.warns(UserWarning, match="has no duration"):
        h = helm([depth_only(endflag="DEPTH_DONE = true")])
    out = h.step(0.0, NAV)
    assert out.completed == ("depth",) and out.post_dict()["DEPTH_DONE"] == "true"
    assert out.all_stop_reason == "NothingToDo"  # nothing produced a function
    h = helm([depth_only(duration="no-time-limit")])
    assert h.step(0.0, NAV).active == ("depth",) and h.step(60.0, NAV).active == ("depth",)


def test_the_duration_clock_starts_with_the_conditions_and_ends_a_running_behavior():
    h = helm([depth_only(duration=1.0, condition="GO = true")])
    assert h.step(0.0, NAV).idle == ("depth",)
    assert h.step(5.0, {"GO": "true"}).active == ("depth",)  # idle time did not count
    assert h.step(5.5, {}).active == ("depth",)
    assert h.step(6.0, {}).completed == ("depth",)


# -- engagement and lost mail (S/pHelmIvP/HelmIvP.cpp:238-253, 340-405) ---------------------
def test_a_helm_that_is_not_started_engaged_waits_for_the_override_string():
    h = helm([depth_only(duration="no-time-limit")], engaged=False)
    assert h.step(0.0, NAV).helm_state == "PARK"
    assert h.step(0.25, {"MOOS_MANUAL_OVERRIDE": 0.0}).helm_state == "PARK"  # not the string
    assert h.step(0.5, {"MOOS_MANUAL_OVERIDE": "False"}).helm_state == "DRIVE"  # legacy name
    assert h.step(0.75, {"MOOS_MANUAL_OVERRIDE": "TRUE"}).helm_state == "PARK"


def test_a_spawning_alert_posted_while_parked_is_lost():
    # ManualOverride clears the buffer's deltas (HelmIvP.cpp:400-404): the one alert a
    # contact manager posts never spawns the template. This kept the user's ROV still.
    h = helm([TRAIL], engaged=False)
    h.step(0.0, {**NAV, "NODE_REPORT": DIVER.format(t=0), "TRAIL_INFO": SPAWN})
    out = h.step(0.25, {"MOOS_MANUAL_OVERRIDE": "false", "NODE_REPORT": DIVER.format(t=0.25)})
    assert h.behavior_names == () and out.all_stop_reason == "NothingToDo"
    # the same alert after deployment spawns it
    h.step(0.5, {"TRAIL_INFO": SPAWN, "NODE_REPORT": DIVER.format(t=0.5)})
    assert h.behavior_names == ("trail_diver",)
    # ... and one posted together with the deployment too (mail before the iteration)
    h = helm([TRAIL], engaged=False)
    h.step(0.0, NAV)
    h.step(0.25, {"MOOS_MANUAL_OVERRIDE": "false", "TRAIL_INFO": SPAWN,
                  "NODE_REPORT": DIVER.format(t=0.25)})  # fmt: skip
    assert h.behavior_names == ("trail_diver",)


def test_mail_is_kept_while_the_helm_waits_for_its_nav_solution():
    # holdForNavSolution returns before the deltas are cleared (HelmIvP.cpp:358-361)
    h = helm([TRAIL])
    out = h.step(0.0, {"TRAIL_INFO": SPAWN, "NODE_REPORT": DIVER.format(t=0)})
    assert out.decision is None and "IVPHELM_ALLSTOP" not in out.post_dict()
    assert "DESIRED_SPEED" not in out.post_dict()
    out = h.step(0.25, {**{k: v for k, v in NAV.items() if k != "NAV_DEPTH"}})
    assert out.decision is None  # NAV_DEPTH too, the domain has depth (l.1958-1961)
    out = h.step(0.5, {"NAV_DEPTH": 0.0})
    assert h.behavior_names == ("trail_diver",) and out.decision is not None


def test_mail_skewed_beyond_ok_skew_is_ignored():
    h = helm([depth_only(duration="no-time-limit", condition="GO = true")])
    out = h.step(100.0, [*((k, v, 100.0) for k, v in NAV.items()), ("GO", "true", 39.0)])
    assert "GO" not in h.info and out.post_dict()["IVPHELM_SKEW"].startswith(
        "Helm ignores MOOS msg due to skew: GO")
    h = helm([depth_only(duration="no-time-limit", condition="GO = true")], ok_skew=None)
    h.step(100.0, [*((k, v, 100.0) for k, v in NAV.items()), ("GO", "true", 39.0)])
    assert h.info["GO"] == "true"  # ok_skew = any


# -- contacts (S/lib_geodaid/ContactLedger.cpp, S/lib_behaviors/IvPBehavior.cpp) -----------
def test_a_report_without_time_is_refused():
    h = helm([TRAIL])
    out = h.step(0.0, {**NAV, "NODE_REPORT": "NAME=diver,X=0,Y=-30,SPD=0.5,HDG=180,DEP=2"})
    assert "diver" not in h.ledger and "Missing timestamp" in out.post_dict()["BHV_WARNING"]


def test_a_spawned_contact_behavior_without_its_contact_dies_at_once():
    # IvPBehavior.cpp:339-341; names are matched exactly (LedgerSnap.cpp:215-221)
    h = helm([TRAIL])
    out = h.step(0.0, {**NAV, "NODE_REPORT": DIVER.format(t=0),
                       "TRAIL_INFO": "name=Diver # contact=Diver"})  # fmt: skip
    assert h.behavior_names == () and out.all_stop_reason == "NothingToDo"
    h.step(0.25, {"TRAIL_INFO": SPAWN, "NODE_REPORT": DIVER.format(t=0.25)})
    assert h.behavior_names == ("trail_diver",)


def test_a_stale_contact_leaves_the_ledger_and_its_spawned_behavior_completes():
    # contact_max_age 45 s, twice that for a contact a behavior names (HelmIvP.cpp:383-386)
    h = helm([TRAIL])
    h.step(0.0, {**NAV, "NODE_REPORT": [DIVER.format(t=0), DIVER.replace("diver", "bob")
                                        .format(t=0)], "TRAIL_INFO": SPAWN})  # fmt: skip
    h.step(46.0, {})
    assert set(h.ledger) == {"diver"} and h.behavior_names == ("trail_diver",)
    out = h.step(91.0, {})
    assert h.ledger == {} and h.behavior_names == () and "trail_diver" not in out.active


def test_templates_spawn_name_rules():
    h = helm([{**TRAIL, "max_spawnings": 2}])
    reports = [DIVER.replace("diver", n).format(t=0) for n in ("diver", "bob", "al", "trail_x")]
    h.step(0.0, {**NAV, "NODE_REPORT": reports})
    # a name that already starts with the template's is used as it is (IvPBehavior.cpp:150-162)
    h.step(0.25, {"TRAIL_INFO": ["name=trail_x # contact=trail_x", SPAWN]})
    assert h.behavior_names == ("trail_x", "trail_diver")
    out = h.step(0.5, {"TRAIL_INFO": "name=bob # contact=bob"})  # max_spawnings 2 reached
    assert "trail_bob" not in h.behavior_names and "max_spawnings" in out.post_dict()[
        "BHV_WARNING"]
    # a name-less posting updates every spawned instance (IvPBehavior.cpp:1207-1224)
    h.step(0.75, {"TRAIL_INFO": "trail_range=9"})
    assert [h.behavior(n).params.trail_range for n in ("trail_x", "trail_diver")] == [9.0, 9.0]
    # a bad name aborts only that spawn, with a warning (BehaviorSet.cpp:456-483)
    h2 = helm([TRAIL])
    h2.step(0.0, {**NAV, "NODE_REPORT": DIVER.format(t=0)})
    out = h2.step(0.25, {"TRAIL_INFO": "name=di ver! # contact=diver"})
    assert h2.behavior_names == () and "Failed to spawn" in out.post_dict()["BHV_WARNING"]


# -- all-stop and errors (S/pHelmIvP/HelmIvP.cpp:499-549, 1717-1771; HelmEngine.cpp:233) ---
def test_missing_decision_variables_all_stop_after_one_iteration_of_grace():
    h = helm([depth_only(duration="no-time-limit")])
    first = h.step(0.0, NAV).post_dict()
    assert first["IVPHELM_ALLSTOP"] == "MissingDecVars:course,speed"
    assert first["BHV_ERROR"] == "MissingDecVars:course,speed" and "DESIRED_SPEED" not in first
    second = h.step(0.25, {}).post_dict()
    assert second["IVPHELM_ALLSTOP"] == "MissingDecVars:course,speed"
    assert (second["DESIRED_HEADING"], second["DESIRED_SPEED"], second["DESIRED_DEPTH"]) == (
        0.0, 0.0, 0.0)  # every domain variable, depth included
    third = h.step(0.5, {}).post_dict()
    assert "IVPHELM_ALLSTOP" not in third and "DESIRED_SPEED" not in third  # once
    assert third["BHV_ERROR"] == "MissingDecVars:course,speed"  # every iteration


def test_a_behavior_error_halts_the_whole_iteration():
    # a contact behavior with on_no_contact_ok = false and no contact: BHV_ERROR, which
    # halts the helm (IvPContactBehavior.cpp:533-541, HelmEngine.cpp:233-243)
    h = helm([depth_only(duration="no-time-limit"),
              {"type": "Waypoint", "name": "go", "points": "0,-50", "speed": 1},
              {"type": "Trail", "name": "tr", "contact": "ghost", "on_no_contact_ok": False}])
    out = h.step(0.0, NAV)
    assert out.decision is None and out.all_stop_reason == "BehaviorError"
    assert out.post_dict()["DESIRED_SPEED"] == 0.0  # at once: no grace for an error


# -- what loads and what is refused (S/lib_helmivp/BehaviorSet.cpp, ModeEntry.cpp) ---------
def test_names_that_begin_with_another_are_duplicates():
    # BehaviorSet.cpp:288-295, 1208-1221; templates are not compared
    with pytest.raises(ConfigError, match="duplicate behavior name 'loiter_2'"):
        helm([{"type": "Loiter", "name": "loiter", "polygon": "0,0:9,0:9,9"},
              {"type": "Loiter", "name": "loiter_2", "polygon": "0,0:9,0:9,9"}])
    helm([{**TRAIL, "name": "trail"}, {**TRAIL, "name": "trail_b", "updates": "TRAIL_INFO"}])


def test_templating_takes_only_spawn_or_clone():
    # BehaviorSpec.cpp:122-135: other words are ignored, the behavior is an ordinary one
    h = helm([{**TRAIL, "templating": "clone"}])
    assert h.behavior_names == () and "TRAIL_INFO" in h.templates
    h = helm([{**TRAIL, "templating": "Spawn", "contact": "diver"}])
    assert h.behavior_names == ("trail_",) and not h.templates


def test_bhv_files_spell_kinds_exactly_and_refuse_double_equals_in_modes():
    with pytest.raises(ConfigError, match="pHelmIvP knows BHV_Loiter"):
        parse_bhv("Behavior = BHV_loiter\n{\n name = l\n polygon = 0,0:9,0:9,9\n}\n", "f.bhv")
    with pytest.raises(ConfigError, match=r"f\.bhv:1: '==' is not allowed"):
        parse_bhv("set MODE = A {\n GO == true\n}\n", "f.bhv", known_vars=["GO"])


def test_deferred_initialize_only_fills_what_is_unknown(tmp_path):
    # initialize_ posts only if the variable is still unknown (HelmIvP.cpp:923-952)
    f = tmp_path / "i.bhv"
    f.write_text("initialize_ A = 1, B = 2\ninitialize C = 3\n"
                 "Behavior = BHV_Waypoint\n{\n name = w\n points = 0,9\n}\n")
    h = Helm(load_bhv(f, domain=parse_domain(DOMAIN)), "rov")
    out = h.step(0.0, {**NAV, "A": "given"})
    assert (h.info["A"], h.info["B"], h.info["C"]) == ("given", 2.0, 3.0)
    assert ("A", 1.0) not in out.posts and ("B", 2.0) in out.posts


def test_missing_required_parameters_idle_with_a_warning_as_in_phelmivp():
    # no load-time check: BHV_Loiter.cpp:366-370, BHV_Waypoint.cpp:173-176 warn and idle
    h = helm([{"type": "Loiter", "name": "l"}, {"type": "Waypoint", "name": "w"},
              {"type": "Trail", "name": "t"}])
    out = h.step(0.0, NAV)
    warnings = [v for var, v in out.posts if var == "BHV_WARNING"]
    assert warnings == ["l: Empty/NULL Loiter Specification.", "w: No waypts given"]
    assert out.running == ("l", "w", "t") and out.all_stop_reason == "NothingToDo"
