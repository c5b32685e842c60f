"""Helm iteration: spawning, updates, flags, durations, audit, all-stop (no vehicle)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uhrisim.autonomy import Helm, HelmConfig, NodeReport, load_bhv
from uhrisim.autonomy.zaic import zaic_peak
from uhrisim.core.errors import ConfigError

DATA = Path(__file__).resolve().parents[1] / "data" / "helm"
KNOWN = ("TRAIL_INFO", "CONTACT_INFO", "DEPTH_UPDATES", "LOITER_UPDATES")
NAV = {"NAV_X": 0.0, "NAV_Y": 0.0, "NAV_HEADING": 180.0, "NAV_SPEED": 0.0, "NAV_DEPTH": 0.0}


def meta_helm() -> Helm:
    return Helm(load_bhv(DATA / "meta_vehicle.bhv", known_vars=KNOWN), "videoray")


def test_inactive_until_deploy_then_spawn_per_contact():
    h = meta_helm()
    out = h.step(0.0, NAV)
    assert out.mode == "INACTIVE" and out.decision is None
    # pHelmIvP's all-stop: NothingToDo, with one iteration's grace before DESIRED_* = 0
    # (HelmIvP.cpp:1730-1753)
    assert out.all_stop_reason == "NothingToDo" and out.post_dict()["DEPLOY"] == "false"
    assert out.post_dict()["IVPHELM_ALLSTOP"] == "NothingToDo"
    assert "DESIRED_SPEED" not in out.post_dict()
    report = "NAME=diver,X=10,Y=0,SPD=0.5,HDG=180,DEP=2,TIME=0.25"
    spawn = "name=diver # contact=diver"
    out = h.step(
        0.25, {"DEPLOY": "true", "NODE_REPORT": report, "TRAIL_INFO": spawn, "CONTACT_INFO": spawn}
    )
    assert out.mode == "ACTIVE:TRAILING"
    assert set(h.behavior_names) >= {"trail_diver", "avd_diver"}
    assert h.behavior("trail_diver").params.contact == "diver"
    assert out.active == ("const_depth", "trail_diver")  # avd: diver beyond pwt_outer_dist
    assert "avd_diver" in out.running and out.decision is not None
    assert out.post_dict()["IVPHELM_ALLSTOP"] == "clear"
    assert (h.ledger["diver"].depth, h.ledger["diver"].t_report) == (2.0, 0.25)
    # a second alert for the same contact does not duplicate it; a list = several postings;
    # bob is not in the contact ledger: his spawn dies at once (IvPBehavior.cpp:339-341)
    out = h.step(0.5, {"TRAIL_INFO": [spawn, "contact=bob # name=bob"]})
    assert "BHV_WARNING" not in out.post_dict()
    assert h.behavior("trail_diver").params.contact == "diver"  # untouched by bob's alert
    assert h.behavior_names.count("trail_diver") == 1 and "trail_bob" not in h.behavior_names
    bob = "NAME=bob,X=-10,Y=0,SPD=0.5,HDG=0,DEP=2,TIME=0.5"
    out = h.step(0.5, {"NODE_REPORT": bob, "TRAIL_INFO": "contact=bob # name=bob"})
    assert h.behavior("trail_bob").params.contact == "bob"
    out = h.step(0.75, {"TRAIL": "false"})
    assert out.mode == "ACTIVE:LOITERING" and "loiter" in out.active
    assert "trail_diver" in out.idle


def test_behavior_lists_are_posted_when_they_change():
    """IVPHELM_BHV_ACTIVE/RUNNING/IDLE/COMPLETED: all at the first iteration, then each
    only when its names change (a spawn, a status change), as pHelmIvP posts them."""
    lists = ("IVPHELM_BHV_ACTIVE", "IVPHELM_BHV_RUNNING", "IVPHELM_BHV_IDLE",
             "IVPHELM_BHV_COMPLETED")
    h = meta_helm()

    def posted(t, mail):
        return {v: x for v, x in h.step(t, mail).posts if v in lists}

    first = posted(0.0, NAV)
    assert set(first) == set(lists) and first["IVPHELM_BHV_ACTIVE"] == ""
    assert posted(0.25, NAV) == {}
    spawn = "name=diver # contact=diver"
    changed = posted(0.5, {"DEPLOY": "true", "TRAIL_INFO": spawn, "CONTACT_INFO": spawn,
                           "NODE_REPORT": "NAME=diver,X=10,Y=0,SPD=0.5,HDG=180,TIME=0.5"})
    assert changed["IVPHELM_BHV_ACTIVE"] == "const_depth,trail_diver"
    assert "avd_diver" in changed["IVPHELM_BHV_RUNNING"].split(",")
    assert "IVPHELM_BHV_COMPLETED" not in changed
    assert posted(0.75, {"NODE_REPORT": "NAME=diver,X=10,Y=0,SPD=0.5,HDG=180,TIME=0.75"}) == {}


def test_audit_contributions_add_up_to_the_maximum():
    h = meta_helm()
    h.step(0.0, NAV)
    spawn = "name=diver # contact=diver"
    out = h.step(
        0.25,
        {
            "DEPLOY": "true",
            "TRAIL_INFO": spawn,
            "CONTACT_INFO": spawn,
            "NODE_REPORT": "NAME=diver,X=3,Y=-1,SPD=0.4,HDG=200,DEP=2,TIME=0.25",
        },
    )
    # avd_diver's first build yields nothing (BHV_AvoidCollision.cpp:51-54, 315-331)
    assert set(out.contributions) == {"const_depth", "trail_diver"}
    out = h.step(0.5, {"NODE_REPORT": "NAME=diver,X=3,Y=-1,SPD=0.4,HDG=200,DEP=2,TIME=0.5"})

    assert set(out.contributions) == {"const_depth", "trail_diver", "avd_diver"}
    assert sum(out.contributions.values()) == pytest.approx(out.total)
    assert 0.0 < h.behavior("avd_diver").priority_scale < 1.0  # relevance-weighted
    # brute force over the full course x speed x depth grid
    full = np.zeros((360, 26, 101))
    shapes = {("course", "speed"): (360, 26, 1), ("depth",): (1, 1, 101)}
    for w in out.objectives:
        full += w.priority * w.objective.values.reshape(shapes[w.objective.axes])
    assert out.total == pytest.approx(full.max())
    i, j, k = np.unravel_index(np.argmax(full), full.shape)
    assert (out.decision.heading_deg, out.decision.speed, out.decision.depth) == pytest.approx(
        (float(i), 0.2 * j, float(k))
    )
    # depth: ConstantDepth alone on its axis; summit 1.5 falls between 1 and 2 -> tie, lower
    dep = zaic_peak(np.arange(101.0), 1.5, 3.0, 100.0, 50.0)
    assert dep[1] == dep[2] and out.decision.depth == 1.0
    assert out.contributions["const_depth"] == pytest.approx(100.0 * dep[1])


def test_updates_change_parameters_at_run_time():
    h = meta_helm()
    h.step(0.0, NAV)
    out = h.step(0.25, {"DEPLOY": "true"})
    assert out.decision is None  # trailing mode but no contact yet -> only depth: all-stop
    assert "course" in out.all_stop_reason and out.contributions.keys() == {"const_depth"}
    h.step(0.5, {"DEPTH_UPDATES": "depth=4"})
    assert h.behavior("const_depth").params.depth == 4.0
    out = h.step(0.75, {"TRAIL": "false"})
    assert out.decision.depth == 4.0 and out.mode == "ACTIVE:LOITERING"
    out = h.step(1.0, {"DEPTH_UPDATES": "depth=deep", "LOITER_UPDATES": "speed=0.8"})
    assert ("BHV_WARNING" in out.post_dict()) and h.behavior("const_depth").params.depth == 4.0
    assert h.behavior("loiter").params.speed == 0.8


def test_flags_durations_and_perpetual():
    cfg = HelmConfig.from_mapping(
        {
            "initialize": {"GO": "false"},
            "behaviors": [
                {
                    "type": "ConstantDepth",
                    "name": "a",
                    "depth": 2,
                    "condition": "GO = true",
                    "runflag": "A_RUN = 1",
                    "idleflag": "A_IDLE = 1",
                    "activeflag": "A_ACT = 1",
                    "inactiveflag": "A_INACT = 1",
                    "endflag": ["A_DONE = true"],
                    "duration": 1.0,
                },
                {
                    "type": "ConstantDepth",
                    "name": "b",
                    "depth": 5,
                    "condition": "A_DONE = true",
                    "duration": 0.5,
                    "perpetual": True,
                    "endflag": "B_END = $(nothing)",
                    "duration_idle_decay": False,
                },
            ],
        }
    )
    h = Helm(cfg, "v")
    posts = h.step(0.0, NAV).post_dict()
    assert posts["A_IDLE"] == 1.0 and "A_RUN" not in posts
    posts = h.step(0.25, {"GO": "true"}).post_dict()
    assert posts["A_RUN"] == 1.0 and posts["A_ACT"] == 1.0
    assert "A_RUN" not in h.step(0.5, {}).post_dict()  # flags on transitions only
    h.step(1.0, {})
    out = h.step(1.25, {})  # 1.0 s after it started running: completes, endflag posted
    assert out.post_dict()["A_DONE"] == "true" and out.completed == ("a",)
    out = h.step(1.5, {})  # b runs (A_DONE came back through the info buffer)
    assert out.active == ("b",) and out.decision is None  # depth only -> all-stop
    out = h.step(2.0, {})
    assert out.post_dict()["B_END"] == "$(nothing)"
    assert "b" not in out.completed  # perpetual: reset, not completed
    out = h.step(2.25, {})
    assert out.active == ("b",)


def test_mode_variable_keeps_its_value_when_no_entry_matches():
    # pHelmIvP posts a mode variable only when an entry gives it a value (ModeSet.cpp:66)
    cfg = HelmConfig.from_mapping(
        {
            "initialize": {"DEPLOY": "true"},
            "modes": ["MODE = ACTIVE { DEPLOY = true }"],
            "behaviors": [{"type": "ConstantDepth", "name": "d", "condition": "MODE==ACTIVE",
                           "duration": "no-time-limit"}],
            "domain": {"course": [0, 359, 360], "speed": [0, 5, 26], "depth": [0, 10, 11]},
        }
    )
    h = Helm(cfg, "v")
    assert h.step(0.0, NAV).mode == "ACTIVE"
    out = h.step(0.25, {"DEPLOY": "false"})
    assert out.mode == "ACTIVE" and "MODE" not in out.post_dict() and out.active == ("d",)
    with pytest.raises(ConfigError, match="non-optional 'speed'"):
        HelmConfig.from_mapping({"domain": {"course": [0, 359, 360]}})


def test_manual_override_parks_the_helm():
    h = meta_helm()
    out = h.step(0.0, {**NAV, "MOOS_MANUAL_OVERRIDE": "true", "DEPLOY": "true"})
    assert out.helm_state == "PARK" and out.decision is None
    # parked: ManualOverride and DESIRED_* = 0 for every domain variable, once
    # (HelmIvP.cpp:400-404, 1717-1771)
    posted = out.post_dict()
    assert posted["IVPHELM_STATE"] == "PARK" and posted["IVPHELM_ALLSTOP"] == "ManualOverride"
    assert (posted["DESIRED_HEADING"], posted["DESIRED_SPEED"], posted["DESIRED_DEPTH"]) == (
        0.0, 0.0, 0.0)
    out = h.step(0.1, {})
    assert "DESIRED_SPEED" not in out.post_dict() and "IVPHELM_ALLSTOP" not in out.post_dict()
    out = h.step(0.25, {"MOOS_MANUAL_OVERRIDE": "false"})
    assert out.helm_state == "DRIVE" and out.post_dict()["IVPHELM_STATE"] == "DRIVE"


def test_numpy_scalars_and_report_objects_in_mail():
    h = meta_helm()
    out = h.step(
        0.0,
        {
            "NAV_X": np.float32(1.5),
            "NAV_Y": np.int64(2),
            "NAV_HEADING": 90.0,
            "NAV_SPEED": np.float64(0.0),
            "NAV_DEPTH": np.int32(0),
            "DEPLOY": np.bool_(True),
            "NODE_REPORT": NodeReport("diver", 4.0, 5.0, 0.5, 90.0, 2.0, time=0.0),
        },
    )
    assert "BHV_WARNING" not in out.post_dict()
    assert (h.info["NAV_X"], h.info["NAV_Y"], h.info["DEPLOY"]) == (1.5, 2.0, "true")
    assert h.ledger["diver"].x == 4.0 and out.mode == "ACTIVE:TRAILING"


def test_bad_node_report_is_reported_not_fatal():
    h = meta_helm()
    out = h.step(0.0, {**NAV, "NODE_REPORT": "NAME=diver,X=oops,Y=1"})
    assert "Bad NodeReport" in out.post_dict()["BHV_WARNING"]


def test_mission_style_file_runtime_flags_suffix_and_spawn_completion():
    macros = {"VNAME": "videoray", "HOME": "0,0", "LOITER_CENTER": "x=10,y=-20",
              "TRAIL_ENABLED": "yes"}  # fmt: skip
    h = Helm(load_bhv(DATA / "rov_nsplug.bhv", known_vars=KNOWN, macros=macros), "videoray")
    h.step(0.0, NAV)
    near = "NAME=diver,X=0,Y=-5,SPD=0,HDG=0,DEP=2,TIME=0.25"
    out = h.step(0.25, {"DEPLOY": "true", "CONTACT_INFO": "name=diver # contact=diver",
                        "NODE_REPORT": near, "TRAIL": "false"})  # fmt: skip
    assert out.mode == "ACTIVE:LOITERING" and "avoid_diver" in h.behavior_names
    posts = out.post_dict()
    assert posts["UNDERWAY"] == "true"  # Loiter runflag
    assert "LOITER_INDEX_ROV" in posts and "LOITER_ACQUIRE_ROV" in posts  # post_suffix
    # the diver moves beyond completed_dist (12 m): the spawned avoidance completes,
    # posts its endflag with $[CONTACT] expanded, and is removed
    out = h.step(0.5, {"NODE_REPORT": "NAME=diver,X=0,Y=-20,SPD=0,HDG=0,DEP=2,TIME=0.5"})
    assert out.post_dict()["CONTACT_RESOLVED"] == "diver"
    assert "avoid_diver" not in h.behavior_names and out.completed == ()
    # a later alert spawns a fresh one (which lives while the diver is within 12 m)
    h.step(0.75, {"CONTACT_INFO": "name=diver # contact=diver", "NODE_REPORT": near})
    assert "avoid_diver" in h.behavior_names


def test_as_mail_groups_repeated_postings_in_order():
    from uhrisim.autonomy import as_mail

    mail = as_mail([("A", 1), ("B", "x"), ("A", 2), ("A", 3)], base={"NAV_X": 0.0, "B": "w"})
    assert mail == {"NAV_X": 0.0, "B": ["w", "x"], "A": [1, 2, 3]}


def test_ned_adapters():
    from uhrisim.autonomy import Decision, OwnNav

    # NED north 3, east 4, depth 2, yaw -pi/2 (west) -> MOOS x 4, y 3, heading 270
    nav = OwnNav.from_ned(3.0, 4.0, 2.0, -np.pi / 2, 0.5)
    assert (nav.x, nav.y, nav.heading, nav.speed, nav.depth) == pytest.approx(
        (4.0, 3.0, 270.0, 0.5, 2.0)
    )
    assert nav.mail()["NAV_HEADING"] == pytest.approx(270.0)
    assert Decision(270.0, 1.0).yaw_rad == pytest.approx(-np.pi / 2)
    assert Decision(90.0, 1.0).yaw_rad == pytest.approx(np.pi / 2)
