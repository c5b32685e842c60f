"""A MOOS-IvP user's own .moos file: read as MOOS reads it, its pHelmIvP block checked as
pHelmIvP checks it (MOOS_Jul2724 MOOSFileReader.cpp / ProcessConfigReader.cpp, MOOS-IvP
pHelmIvP/HelmIvP.cpp:1230-1519), the helm it describes built from it."""

from __future__ import annotations

from pathlib import Path

import pytest

from uhrisim.autonomy import Helm
from uhrisim.autonomy.moos_file import load_helm_from_moos, parse_moos
from uhrisim.core.errors import AssetError, ConfigError
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "scenarios" / "moos_external_helm_videoray.moos"

BHV = """\
initialize DEPLOY = true
Behavior = BHV_ConstantDepth
{
  name     = depth
  duration = no-time-limit
  depth    = 2
}
Behavior = BHV_Waypoint
{
  name   = go
  points = 0,-50
  speed  = 1.2
}
"""

HEAD = """\
ServerHost = localhost
ServerPort = 9000
Community  = rov
LatOrigin  = 42.358456
LongOrigin = -71.087589
"""


def mission(tmp_path: Path, helm_block: str, head: str = HEAD, bhv: str = BHV) -> Path:
    (tmp_path / "rov.bhv").write_text(bhv)
    path = tmp_path / "rov.moos"
    path.write_text(f"{head}\nProcessConfig = pHelmIvP\n{{\n{helm_block}\n}}\n")
    return path


def test_moos_reader_follows_moos():
    text = """// a comment
ServerPort = 9000   // trailing comment
define: HOME = 3,4
processconfig = pFoo
{
  Key Word = a b c      // MOOS removes every blank inside a block
  empty =
  home = ${HOME}
}
ProcessConfig = pFoo
{
  key = second block of the same name: MOOS reads the first
}
"""
    moos = parse_moos(text, "m.moos")
    assert moos.global_value("serverport") == "9000"
    lines = moos.block("PFOO")  # names compare without regard to case, as MOOS's GoTo
    assert [(x.key, x.value) for x in lines] == [("KeyWord", "abc"), ("home", "3,4")]
    assert lines[0].where == "m.moos:6"
    with pytest.raises(ConfigError, match=r"m\.moos: no ProcessConfig = pHelmIvP block"):
        moos.block("pHelmIvP")


@pytest.mark.parametrize(
    ("text", "where", "match"),
    [
        ("ProcessConfig = pHelmIvP {\n}\n", 1, "own line"),  # MOOS finds no block there
        ("ProcessConfig = pHelmIvP\nAppTick = 4\n}\n", 2, "must open with"),
        ("ProcessConfig = pHelmIvP\n{\nAppTick = 4\n", 1, "never closed"),
        ("ProcessConfig = p\n{\n{\n}\n", 3, "inside a ProcessConfig block"),
        ("x = ${NOPE}\n", 1, r"\$\{NOPE\} is not defined"),
        ("#include plugs.moos\n", 1, "'#include' is an nsplug directive"),
    ],
)
def test_malformed_moos_files_name_file_and_line(text: str, where: int, match: str):
    with pytest.raises(ConfigError, match=match) as e:
        parse_moos(text, "m.moos")
    assert e.value.where == f"m.moos:{where}"


def test_helm_from_the_phelmivp_block(tmp_path):
    path = mission(tmp_path, """
  AppTick   = 4
  CommsTick = 4
  Behaviors = rov.bhv
  Domain    = course:0:359:360
  Domain    = speed:0:4:delta=0.2
  Domain    = depth:0:100:101:optional
  ok_skew   = any
  contact_max_age = 30
  verbose   = terse
""")
    cfg = load_helm_from_moos(path)
    assert [b.name for b in cfg.behaviors] == ["depth", "go"]
    speed = cfg.domain.axis("speed")
    assert (speed.low, speed.high, speed.npts) == (0.0, 4.0, 21)  # delta=0.2: 4/0.2 + 1
    assert cfg.domain.axis("depth").optional and not speed.optional
    # pHelmIvP's own defaults and the block's settings
    assert (cfg.settings.start_engaged, cfg.settings.ok_skew) == (False, None)
    assert cfg.settings.contact_max_age == 30.0
    # the helm starts parked, as pHelmIvP does, and drives once deployed
    h = Helm(cfg, "rov")
    nav = {"NAV_X": 0.0, "NAV_Y": 0.0, "NAV_HEADING": 0.0, "NAV_SPEED": 0.0, "NAV_DEPTH": 0.0}
    assert h.step(0.0, nav).helm_state == "PARK"
    out = h.step(0.25, {"MOOS_MANUAL_OVERRIDE": "false"})
    assert out.helm_state == "DRIVE" and out.decision.heading_deg == 180.0


def test_several_behavior_files_are_read_as_phelmivp_reads_them(tmp_path):
    (tmp_path / "b.bhv").write_text(BHV)
    (tmp_path / "a.bhv").write_text(
        "Behavior = BHV_Loiter\n{\n name = orbit\n polygon = 0,0:10,0:10,10:0,10\n}\n")
    path = mission(tmp_path, "Behaviors = b.bhv\nBehaviors = a.bhv\nDomain = course:0:359:360"
                             "\nDomain = speed:0:4:21\nDomain = depth:0:100:101:optional")
    # a sorted set of files (Populator_BehaviorSet::populate): a.bhv first
    assert [b.name for b in load_helm_from_moos(path).behaviors] == ["orbit", "depth", "go"]


@pytest.mark.parametrize(
    ("block", "match"),
    [
        ("Behaviors = rov.bhv\nDomain = course:0:359:360\nDomain = speed:0:4:21\n"
         "IterateMode = 1", "does not handle 'IterateMode'"),
        ("Behaviors = rov.bhv\nBehaviors = rov.bhv\nDomain = course:0:359:360",
         "named twice"),
        ("Behaviors = rov.bhv", "no Domain lines"),
        ("Domain = course:0:359:360", "names no Behaviors file"),
        ("Behaviors = rov.bhv\nDomain = course:0:359", "name:low:high:npts"),
        ("Behaviors = rov.bhv\nDomain = speed:4:0:21", "high 0 is below low 4"),
        ("Behaviors = rov.bhv\nDomain = course:0:359:360\nDomain = course:0:359:360",
         "given twice"),
        ("Behaviors = rov.bhv\nDomain = course:0:359:360\ncontact_max_age = 5",
         r"\[10, 1800\]"),
        ("Behaviors = rov.bhv\nDomain = course:0:359:360\nstart_engaged = maybe",
         "true or false"),
    ],
)
def test_what_phelmivp_refuses_is_refused_with_file_and_line(tmp_path, block: str, match: str):
    path = mission(tmp_path, block)
    with pytest.raises(ConfigError, match=match) as e:
        load_helm_from_moos(path)
    assert str(path) in str(e.value)


@pytest.mark.parametrize("key", ["Community", "LatOrigin", "LongOrigin"])
def test_phelmivp_needs_community_and_origin(tmp_path, key: str):
    head = "\n".join(x for x in HEAD.splitlines() if not x.startswith(key))
    path = mission(tmp_path, "Behaviors = rov.bhv\nDomain = course:0:359:360", head=head)
    with pytest.raises(ConfigError, match=f"no {key}"):
        load_helm_from_moos(path)


def test_bad_files_are_one_line_errors(tmp_path):
    path = mission(tmp_path, "Behaviors = missing.bhv\nDomain = course:0:359:360\n"
                             "Domain = speed:0:4:21")
    with pytest.raises(AssetError, match=r"missing\.bhv: cannot read behavior file"):
        load_helm_from_moos(path)
    with pytest.raises(AssetError, match="cannot read MOOS file"):
        load_helm_from_moos(tmp_path / "nope.moos")
    binary = tmp_path / "bin.moos"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(AssetError, match="not a text file"):
        load_helm_from_moos(binary)
    bad_bhv = mission(tmp_path, "Behaviors = rov.bhv\nDomain = course:0:359:360\n"
                                "Domain = speed:0:4:21",
                      bhv=BHV.replace("speed  = 1.2", "sped = 1"))
    with pytest.raises(ConfigError, match=r"rov\.bhv:12: BHV_Waypoint has no parameter 'sped'"):
        load_helm_from_moos(bad_bhv)


@pytest.mark.parametrize(
    ("bhv", "moos_extra", "where", "match"),
    [
        (BHV.replace("  depth    = 2\n", "#ifdef DEEP\n  depth    = 2\n#endif\n"), "",
         "rov.bhv:6", "'#ifdef' is an nsplug directive: pHelmIvP .* MALCONFIG"),
        (BHV.replace("speed  = 1.2", "speed  = $(SPEED)"), "", "rov.bhv:12",
         r"\$\(SPEED\) is an nsplug macro left unexpanded"),
        (BHV, "#ifdef SIM\nServerPort = 9001\n#endif\n", "rov.moos:6",
         "'#ifdef' is an nsplug directive: MOOS .* every branch would apply"),
    ],
)
def test_nsplug_left_in_what_phelmivp_reads_is_refused_at_its_line(
        tmp_path, bhv: str, moos_extra: str, where: str, match: str):
    # pHelmIvP does not run nsplug (lib_helmivp/Populator_BehaviorSet.cpp)
    path = mission(tmp_path, "Behaviors = rov.bhv\nDomain = course:0:359:360",
                   head=HEAD + moos_extra, bhv=bhv)
    with pytest.raises(ConfigError, match=match) as e:
        load_helm_from_moos(path)
    assert str(e.value).startswith(f"{tmp_path / where}: ")


def test_the_shipped_community_file_loads_as_the_helm_it_describes():
    cfg = load_helm_from_moos(SHIPPED)
    assert cfg.domain.names == ("course", "speed", "depth")
    assert cfg.domain.axis("speed").npts == 41 and cfg.domain.axis("depth").optional
    assert not cfg.settings.start_engaged  # pHelmIvP's default, deployed by the user
    names = {b.name for b in cfg.behaviors}
    assert {"const_depth", "trail_", "avd_"} <= names
    assert next(b for b in cfg.behaviors if b.name == "const_depth").common.duration == -1.0


def test_scenario_helm_from_a_moos_file_and_its_errors(tmp_path):
    sim = Simulation(load_scenario(ROOT / "scenarios" / "moos_file_helm.yaml"))
    helm = sim.agents["videoray"].driver.autonomy.helm
    assert helm.config.source == str(SHIPPED) and not helm.engaged  # until the t = 0 event
    text = (ROOT / "scenarios" / "moos_file_helm.yaml").read_text()
    bad = tmp_path / "s.yaml"
    (tmp_path / "m.moos").write_text(HEAD + "ProcessConfig = pHelmIvP\n{\n Behaviors = x.bhv\n}\n")
    bad.write_text(text.replace("moos_file: moos_external_helm_videoray.moos",
                                "moos_file: m.moos"))
    with pytest.raises(ConfigError, match=r"m\.moos:6: pHelmIvP has no Domain lines"):
        Simulation(load_scenario(bad))
    both = text.replace("moos_file: moos_external_helm_videoray.moos",
                        "moos_file: m.moos\n      domain: *domain")
    bad.write_text(both)
    with pytest.raises(ConfigError, match="the domain comes from its Domain lines"):
        load_scenario(bad)
    bad.write_text(text.replace("moos_file: moos_external_helm_videoray.moos",
                                "moos_file: m.moos\n      macros: {SONAR_CONTACTS: 'true'}"))
    with pytest.raises(ConfigError, match="macros apply to a bhv_file: a moos_file is read"):
        load_scenario(bad)


def test_the_mission_file_api_is_exported_from_autonomy():
    from uhrisim import autonomy

    assert autonomy.load_helm_from_moos is load_helm_from_moos
    axes = autonomy.parse_domain(["course:0:359:360", "speed:0:5:26", "depth:0:10:11:optional"])
    assert axes.names == ("course", "speed", "depth") and axes.axis("depth").optional
