"""A run whose outside MOOS helm never drives says so (issue 24): against the project's
test MOOSDB in another process, with pHelmIvP's status variables poked into it by a
uPokeDB stand-in on the independent pymoos2 client (tests/support/moos_poke.py).

What pHelmIvP posts is MOOS-IvP's (pHelmIvP/HelmIvP.cpp): IVPHELM_STATE every iteration
(MALCONFIG when a behavior file line is rejected), BHV_ERROR with the reason.
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from uhrisim.bridges.moos.hook import MoosAgentLink, MoosBridgeHook
from uhrisim.bridges.moos.testdb import spawn
from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.schema import HelmWatchSection
from uhrisim.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "moos_external_helm.yaml"
POKE = ROOT / "tests" / "support" / "moos_poke.py"
MALCONFIG = ("IVPHELM_STATE=MALCONFIG",
             "BHV_ERROR=Problem with line 21 in the BehaviorSet file: videoray_trail.bhv")


def poke(port: int, *assignments: str) -> None:
    """uPokeDB stand-in: the DB holds each value when this returns."""
    done = subprocess.run([sys.executable, str(POKE), str(port), *assignments],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "poked" in done.stdout, done.stderr


def watched_run(port: int, seconds: float, until=None):
    """The ROV of moos_external_helm.yaml linked to the DB at ``port``; ``seconds`` of
    simulated time. With ``until``, the run steps only when mail has come in until
    ``until(hook)`` is true (simulated time waits for the mail), then freely."""
    hook = MoosBridgeHook([MoosAgentLink("videoray", port=port, community="videoray")],
                          time_source="sim", strict=True,
                          helm_watch=HelmWatchSection(silence_s=10.0, repeat_s=5.0))
    sim = Simulation(load_scenario(SCENARIO), hooks=[hook], raycast_sensors=False)
    sim.start()
    deadline = time.monotonic() + 120.0  # bound for a busy machine; mail takes ms
    while until is not None and not until(hook):
        assert time.monotonic() < deadline, "the DB's values never reached the bridge"
        if any(bridge.client.has_mail for bridge in hook.bridges.values()):
            sim.step()  # the hook takes the mail on a tick
        else:  # no simulated time passes while the mail is on its way (a fast loop
            time.sleep(0.002)  # would otherwise reach the watch's silence first)
    sim.run(seconds - sim.t)
    sim.close()
    return sim, hook


def test_malconfig_is_said_at_once_with_the_helm_error(caplog):
    with spawn(community="videoray") as db:
        poke(db.port, *MALCONFIG)
        with caplog.at_level(logging.WARNING, logger="uhrisim.bridges.moos.hook"):
            sim, hook = watched_run(db.port, 12.0,
                                    until=lambda h: h.watches["videoray"].states_seen)
    said = [r.getMessage() for r in caplog.records]
    assert said and said[0] == (
        "MOOS community 'videoray': IVPHELM_STATE=MALCONFIG — pHelmIvP rejected its "
        "configuration (its behavior file, domain or settings); see its console "
        "(BHV_ERROR=Problem with line 21 in the BehaviorSet file: videoray_trail.bhv)")
    assert 2 <= len(said) <= 4  # again every 5 s while it lasts
    events = [e.detail for e in sim.events_log if e.kind == "bridge"]
    assert said[0] in events
    summary = hook.summary()["moos"]["videoray"]
    assert summary["helm"]["helm_state"] == "MALCONFIG"
    assert summary["helm"]["first_command_s"] is None
    assert summary["helm"]["seconds_without_commands"] == pytest.approx(12.0, abs=0.1)
    assert summary["connection_attempts"] == 1 and summary["refusals"] == 0


def test_a_community_without_a_helm_is_said_after_the_silence(caplog):
    with spawn(community="videoray") as db, caplog.at_level(
            logging.WARNING, logger="uhrisim.bridges.moos.hook"):
        _, hook = watched_run(db.port, 11.0)
    said = [r.getMessage() for r in caplog.records]
    assert said == [
        "MOOS community 'videoray': no DESIRED_* since the start (10 s) and no "
        f"IVPHELM_STATE either: is pHelmIvP running in community 'videoray' at "
        f"127.0.0.1:{db.port}?"]
    assert hook.summary()["moos"]["videoray"]["helm"]["warnings"] == 1


def test_require_helm_ends_the_run_in_one_line_and_keeps_its_outputs(tmp_path):
    with spawn(community="videoray") as db:
        poke(db.port, *MALCONFIG)
        data = yaml.safe_load(SCENARIO.read_text())
        bridges = data["bridges"]
        # the ROV's link only (the diver's community is not up in this test)
        bridges["moos"]["links"] = [{**bridges["moos"]["links"][0], "port": db.port}]
        bridges["helm_watch"] = {"silence_s": 60}
        scenario = tmp_path / "moos.yaml"
        scenario.write_text(yaml.safe_dump(data))
        out = tmp_path / "run"
        done = subprocess.run(
            [sys.executable, "-m", "uhrisim", "run", str(scenario), "--out", str(out),
             "--moos", "--require-helm", "--duration", "120", "-q", "--no-figures"],
            capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert done.returncode == 2, done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert errors == [
        "error: MOOS community 'videoray': IVPHELM_STATE=MALCONFIG — pHelmIvP rejected its "
        "configuration (its behavior file, domain or settings); see its console "
        "(BHV_ERROR=Problem with line 21 in the BehaviorSet file: videoray_trail.bhv) (the "
        "run requires its outside helm to drive)"]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["completed"] is False and "MALCONFIG" in metrics["stopped_by"]
    assert metrics["moos"]["videoray"]["helm"]["helm_state"] == "MALCONFIG"
    assert (out / "metadata.yaml").exists()  # the recording was closed, a rosbag2 folder
