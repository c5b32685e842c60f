"""Every shipped .bhv and .moos file would fly in the real pHelmIvP (MOOS-IvP 24.8 rules,
docs/helm.md): it loads without a warning under those rules, every file a shipped .moos
points pHelmIvP at is pHelmIvP's input as it stands (pHelmIvP does not run nsplug), and the
contact manager of a shipped community hands the helm its alerts."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from uhrisim.autonomy import load_bhv
from uhrisim.autonomy.bhv import expand_nsplug, refuse_nsplug, strip_comment
from uhrisim.autonomy.moos_file import load_helm_from_moos, load_moos

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
BHV_FILES = sorted(SCENARIOS.glob("*.bhv"))
MOOS_FILES = sorted(SCENARIOS.glob("*.moos"))
HELM_FILES = [p for p in MOOS_FILES if "phelmivp" in {b.lower() for b in load_moos(p).blocks}]


def test_there_is_something_to_check():
    assert BHV_FILES and HELM_FILES


@pytest.mark.parametrize("path", BHV_FILES, ids=[p.name for p in BHV_FILES])
def test_shipped_bhv_loads_without_a_warning(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. a ConstantDepth without its duration
        cfg = load_bhv(path, domain=load_helm_from_moos(HELM_FILES[0]).domain,
                       known_vars=("TRAIL_INFO", "CONTACT_INFO", "DEPTH_UPDATES"))
    for spec in cfg.behaviors:
        if spec.kind == "BHV_ConstantDepth":  # pHelmIvP: duration 0 unless given
            assert spec.common.duration != 0.0, f"{spec.where}: {spec.name} has no duration"


@pytest.mark.parametrize("path", HELM_FILES, ids=[p.name for p in HELM_FILES])
def test_every_file_a_shipped_moos_gives_phelmivp_is_read_as_it_stands(path: Path):
    # pHelmIvP rejects a '#...' line (Populator_BehaviorSet.cpp: "Problem with line N",
    # MALCONFIG) and takes $(NAME) literally: none may be left in what it reads
    block = load_moos(path).block("pHelmIvP")
    behavior_files = [path.parent / line.value for line in block
                      if line.key.lower() == "behaviors"]
    assert behavior_files
    for bhv in (path, *behavior_files):
        lines = [strip_comment(s) for s in bhv.read_text().splitlines()]
        refuse_nsplug(lines, str(bhv))  # raises at the first such line


def test_the_plain_helm_is_its_meta_file_expanded_by_nsplug():
    # the file pHelmIvP reads is what `nsplug meta_videoray_trail.bhv videoray_trail.bhv`
    # writes, byte for byte; expand_nsplug wrote both variants exactly as MOOS-IvP 24.8's
    # nsplug did when checked by hand (docs/bridges-moos.md)
    meta = SCENARIOS / "meta_videoray_trail.bhv"
    plain = SCENARIOS / "videoray_trail.bhv"
    assert expand_nsplug(meta.read_text(), {}, str(meta)) == plain.read_text()
    sonar = expand_nsplug(meta.read_text(), {"SONAR_CONTACTS": "true"}, str(meta))
    assert "name       = reacquire" in sonar
    assert "name       = reacquire" not in plain.read_text()


@pytest.mark.parametrize("path", HELM_FILES, ids=[p.name for p in HELM_FILES])
def test_shipped_community_hands_the_helm_its_alerts(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cfg = load_helm_from_moos(path)
    moos = load_moos(path)
    cm = {line.key.lower(): line.value for line in moos.block("pContactMgrV20")}
    alerts = [line.value for line in moos.block("pContactMgrV20") if line.key.lower() == "alert"]
    # an alert without alert_range never fires (CMAlert.cpp:258-267)
    assert alerts and all("alert_range=" in a for a in alerts)
    # a parked helm loses an alert posted before it drives: the manager must hold them
    if not cfg.settings.start_engaged:
        assert cm.get("hold_alerts_for_helm") == "true"
    # each alert's variable spawns a template of the helm
    templates = {b.common.updates for b in cfg.behaviors if b.is_template}
    for a in alerts:
        var = next(f.split("=", 1)[1] for f in a.split(",") if f.startswith("var="))
        assert var in templates
