"""Every shipped .bhv and .moos file would fly in the real pHelmIvP (MOOS-IvP 24.8 rules,
docs/helm.md): it loads without a warning under those rules, and the contact manager of a
shipped community hands the helm its alerts."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from uhrisim.autonomy import load_bhv
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
