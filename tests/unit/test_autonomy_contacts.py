"""Node reports and the contact manager."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.autonomy import (
    ContactManager,
    ContactManagerConfig,
    NodeReport,
    OwnNav,
    format_node_report,
    parse_node_report,
)
from uhrisim.autonomy.contacts import _parse_text, node_report_text
from uhrisim.core.errors import ConfigError

PAPER_EXAMPLE = (
    "NAME=videoray,X=12.30,Y=-4.10,SPD=1.20,HDG=87.00,DEP=1.50,LAT=43.8,LON=-70.3,"
    "TYPE=UUV,MODE=ACTIVE:TRAILING,TIME=1374600000.12,LENGTH=1"
)


def test_parse_reference_example():
    r = parse_node_report(PAPER_EXAMPLE)
    assert (r.name, r.x, r.y, r.speed, r.heading, r.depth) == (
        "videoray",
        12.3,
        -4.1,
        1.2,
        87.0,
        1.5,
    )
    assert (r.type, r.mode, r.time, r.length) == ("UUV", "ACTIVE:TRAILING", 1374600000.12, 1.0)
    assert (r.lat, r.lon) == (43.8, -70.3)


def test_keys_case_insensitive_aliases_and_unknown_kept():
    r = parse_node_report("name=diver, x=1, y=2, Speed=0.5, heading=370, depth=3, COLOR=red")
    assert (r.name, r.speed, r.heading, r.depth) == ("diver", 0.5, 10.0, 3.0)  # 370 -> 10
    assert r.extra == (("COLOR", "red"),)
    assert parse_node_report("NAME=a,X=0,Y=0,SPEED=2,HDG=5,DEPTH=1").speed == 2.0
    assert "COLOR=red" in format_node_report(r)


def test_round_trip():
    r = NodeReport(
        "diver", 10.125, -3.5, 0.25, 181.5, 2.0, time=12.75, type="DIVER", extra=(("ID", "7"),)
    )
    assert parse_node_report(format_node_report(r)) == r
    s = format_node_report(NodeReport("rov", 0.0, -0.0004, 0.0, 0.0))
    assert s == "NAME=rov,X=0,Y=0,SPD=0,HDG=0,DEP=0"


def test_reports_in_the_written_layout_read_as_the_general_parser_reads_them():
    """parse_node_report reads node_report_text's layout with one match; the report (signed
    zeros included) or the error is the general parser's, field for field."""
    rng = np.random.default_rng(5)
    texts = [node_report_text("diver", *rng.normal(0.0, 500.0, 5), time=float(t),
                              **extra)
             for t, extra in zip(rng.uniform(0.0, 1e9, 40), [
                 {}, {"type": "DIVER"}, {"mode": "M:A", "length": 1.8},
                 {"lat": 43.1, "lon": -70.2, "type": "UUV", "mode": "X"}] * 10, strict=True)]
    texts += ["NAME=a,X=-0,Y=0,SPD=0,HDG=-0.0,DEP=0", "NAME=a,X=1,Y=2,SPD=3,HDG=725,DEP=4,TIME=5",
              "NAME=a,X=nan,Y=2,SPD=3,HDG=4,DEP=5", "NAME=a,X=1,Y=inf,SPD=3,HDG=4,DEP=5",
              "NAME=a,X=1e308,Y=1e308,SPD=3,HDG=4,DEP=5", "NAME=a,X=1,Y=2,SPD=x,HDG=4,DEP=5",
              "NAME=a,X=1,Y=2,SPD=3,HDG=4,DEP=1_0,TIME=0x1", "NAME=a,X=1 ,Y=2,SPD=3,HDG=4,DEP=5",
              "NAME=a,X=1,Y=2,SPD=3,HDG=4,DEP=5,TIME=1,TIME=2", "NAME=a,X=1,Y=2,SPD=3,HDG=4,DEP=5,"]
    for text in texts:
        try:
            expected = repr(_parse_text(text))
        except ConfigError as e:
            expected = f"error: {e}"
        try:
            got = repr(parse_node_report(text))
        except ConfigError as e:
            got = f"error: {e}"
        assert got == expected, text


def test_remembered_reports_equal_the_parsed_text():
    """A report made with remember=True is what parsing its text gives, field for field
    (signed zeros, headings past 360 and rounding included); one the parser would reject
    or read differently is not remembered."""
    rng = np.random.default_rng(3)
    cases = [(-0.0, -0.0004, 0.0, 359.999, 0.0, 0.0), (1e6 + 0.0005, -2.5, 1.2345, 720.0, 3.0, 1e9)]
    cases += [tuple(rng.normal(0.0, 500.0, 6)) for _ in range(200)]
    for x, y, spd, hdg, dep, t in cases:
        text = node_report_text("diver", x, y, spd, hdg, dep, type="DIVER", mode="M:A",
                                time=t, length=1.8, lat=43.1, lon=-70.2, remember=True)
        made = parse_node_report(text)
        parsed = _parse_text(text)
        assert made == parsed
        assert [math.copysign(1.0, v) for v in (made.x, made.y, made.depth)] == [
            math.copysign(1.0, v) for v in (parsed.x, parsed.y, parsed.depth)]
    for odd in ({"name": " diver"}, {"extra": (("SPEED", "9"),)}, {"x": math.inf}):
        fields = {"name": "rov", "x": 1.0, "extra": ()} | odd
        text = node_report_text(fields["name"], fields["x"], 2.0, 0.5, 10.0, 1.0,
                                time=3.0, extra=fields["extra"], remember=True)
        if math.isfinite(fields["x"]):
            assert parse_node_report(text) == _parse_text(text)
        else:
            with pytest.raises(ConfigError, match="not finite"):
                parse_node_report(text)


@pytest.mark.parametrize(
    "bad",
    ["", "NAME=a,X=1", "X=1,Y=2", "NAME=a,X=one,Y=2", "NAME=a,X=1,Y=2,SPD", "NAME=a,X=nan,Y=0"],
)
def test_malformed_reports(bad):
    with pytest.raises(ConfigError) as e:
        parse_node_report(bad)
    assert isinstance(e.value, ValueError) and "NODE_REPORT" in str(e.value)


def _cm(**alert):
    spec = {"id": "trail", "var": "TRAIL_INFO", "alert_range": 20.0}
    spec.update(alert)
    cfg = ContactManagerConfig.from_mapping(
        {
            "alerts": [
                spec,
                'id=avd, var=CONTACT_INFO, val="name=$[VNAME] # contact=$[VNAME]", alert_range=10',
            ],
            "decay": "5,10",
        }
    )
    return ContactManager(cfg, "videoray")


def test_alert_posted_once_per_contact_when_in_range():
    cm = _cm()
    own = OwnNav(0.0, 0.0, 0.0, 0.0)
    cm.on_node_report("NAME=diver,X=30,Y=0,SPD=0,HDG=270,TIME=0", 0.0)
    cm.on_node_report("NAME=videoray,X=0,Y=0,SPD=0,HDG=0,TIME=0", 0.0)  # own: ignored
    posts = dict(cm.step(0.0, own))
    assert "TRAIL_INFO" not in posts and posts["CONTACTS_LIST"] == "diver"
    cm.on_node_report("NAME=diver,X=15,Y=0,SPD=0,HDG=270,TIME=1", 1.0)
    posts = cm.step(1.0, own)
    assert ("TRAIL_INFO", "name=diver # contact=diver") in posts
    assert not any(v == "CONTACT_INFO" for v, _ in posts)  # 15 m > 10 m
    cm.on_node_report("NAME=diver,X=5,Y=0,SPD=0,HDG=270,TIME=2", 2.0)
    posts = cm.step(2.0, own)
    assert [v for v, _ in posts if v.endswith("_INFO")] == ["CONTACT_INFO"]  # trail not again
    assert dict(posts)["CONTACTS_ALERTED"] == "(diver,avd),(diver,trail)"
    assert cm.step(3.0, own) == []  # nothing changed, nothing posted


def test_lists_posted_once_per_arrival_alert_and_retirement(monkeypatch):
    """CONTACTS_LIST/ALERTED/RETIRED are posted on the tick a contact arrives, is alerted
    or is retired (each text once), and on no quiet tick - where the lists are not even
    rebuilt."""
    cfg = ContactManagerConfig.from_mapping(
        {"alerts": [{"id": "trail", "var": "TRAIL_INFO", "alert_range": 10.0}],
         "contact_max_age": 30})
    cm = ContactManager(cfg, "videoray")
    rebuilt: list[float] = []
    post_lists = cm._post_lists

    def counting_post_lists(posts):
        rebuilt.append(now)
        post_lists(posts)

    monkeypatch.setattr(cm, "_post_lists", counting_post_lists)
    own = OwnNav(0.0, 0.0, 0.0, 0.0)
    far, near = "NAME=diver,X=30,Y=0,SPD=0,HDG=0,TIME={}", "NAME=diver,X=5,Y=0,SPD=0,HDG=0,TIME={}"
    ticks = [(0.0, far), (1.0, far), (2.0, near), (3.0, near), (4.0, None), (40.0, None),
             (41.0, None)]
    lists = {}
    for now, report in ticks:
        posts = cm.step(now, own, [report.format(now)] if report else [])
        lists[now] = [(v, x) for v, x in posts if v.startswith("CONTACTS_")]
    assert lists[0.0] == [("CONTACTS_LIST", "diver"), ("CONTACTS_ALERTED", ""),
                          ("CONTACTS_RETIRED", "")]  # arrival
    assert lists[2.0] == [("CONTACTS_ALERTED", "(diver,trail)")]  # alert
    assert lists[40.0] == [("CONTACTS_LIST", ""), ("CONTACTS_ALERTED", ""),
                           ("CONTACTS_RETIRED", "diver")]  # retirement
    assert all(lists[t] == [] for t in (1.0, 3.0, 4.0, 41.0))  # quiet ticks
    assert rebuilt == [0.0, 2.0, 40.0]


def test_dead_reckoned_positions_and_cpa_alert():
    cm = _cm(alert_range=5.0, cpa_range=40.0, cpa_time=60.0)
    own = OwnNav(0.0, 0.0, 0.0, 0.0)
    # diver 30 m east going west at 1 m/s: reported at t=0, seen at t=4 (no decay yet)
    cm.on_node_report("NAME=diver,X=30,Y=0.5,SPD=1,HDG=270,TIME=0", 4.0)
    posts = dict(cm.step(4.0, own))
    rec = cm.contacts["diver"]
    assert (rec.x, rec.y) == pytest.approx((26.0, 0.5)) and not rec.decay_maxed
    assert rec.range == pytest.approx(math.hypot(26.0, 0.5))
    # 26 m > alert 5 m, but within cpa_range 40 and its CPA (0.5 m) is inside 5 m
    assert posts["TRAIL_INFO"] == "name=diver # contact=diver"
    # at t=20 the decay (5, 10) has maxed: travelled 5 + 5/2 = 7.5 m
    cm.step(20.0, own)
    assert (rec.x, rec.decay_maxed) == (pytest.approx(22.5), True)


def test_type_filters_and_retirement():
    cfg = ContactManagerConfig.from_mapping(
        {
            "alerts": [{"var": "TRAIL_INFO", "alert_range": 50, "match_type": "diver"}],
            "contact_max_age": 30,
        }
    )
    cm = ContactManager(cfg, "videoray")
    own = {"NAV_X": 0, "NAV_Y": 0, "NAV_HEADING": 0, "NAV_SPEED": 0}
    posts = cm.step(0.0, own, ["NAME=boat,X=1,Y=1,TYPE=kayak", "NAME=bob,X=2,Y=2,TYPE=DIVER"])
    assert [v for v, _ in posts if v == "TRAIL_INFO"] == ["TRAIL_INFO"]
    assert dict(posts)["TRAIL_INFO"] == "name=bob # contact=bob"
    posts = dict(cm.step(31.0, own))
    assert posts["CONTACTS_RETIRED"] == "boat,bob" and posts["CONTACTS_LIST"] == ""


def test_config_errors():
    with pytest.raises(ConfigError, match=r"unknown alert field 'rang'"):
        ContactManagerConfig.from_mapping({"alerts": [{"var": "X", "rang": 3}]})
    with pytest.raises(ConfigError, match="needs var"):
        ContactManagerConfig.from_mapping({"alerts": ["id=a, alert_range=3"]})
    with pytest.raises(ConfigError, match="unknown key"):
        ContactManagerConfig.from_mapping({"alert": []})
    assert _cm().config.alert_vars == ("TRAIL_INFO", "CONTACT_INFO")


def test_relay_follows_the_diver_depth():
    cfg = ContactManagerConfig.from_mapping(
        {"relays": [{"var": "DEPTH_UPDATES", "pattern": "depth=$[DEP]", "contact": "Diver"}]}
    )
    assert cfg.alert_vars == ("DEPTH_UPDATES",)
    cm = ContactManager(cfg, "videoray")
    own = OwnNav(0.0, 0.0, 0.0, 0.0)
    assert dict(cm.step(0.0, own, ["NAME=diver,X=1,Y=1,DEP=2.5"]))["DEPTH_UPDATES"] == "depth=2.5"
    assert "DEPTH_UPDATES" not in dict(cm.step(0.25, own, ["NAME=diver,X=2,Y=1,DEP=2.5"]))
    assert dict(cm.step(0.5, own, ["NAME=diver,X=2,Y=1,DEP=3"]))["DEPTH_UPDATES"] == "depth=3"
    with pytest.raises(ConfigError, match="relay needs"):
        ContactManagerConfig.from_mapping({"relays": [{"var": "X", "pattern": "p"}]})
