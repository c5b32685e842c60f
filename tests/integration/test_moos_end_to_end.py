"""`uhrisim run --moos` against a MOOS community in other processes (issue 6).

A test MOOSDB runs in its own process; the simulation connects to it through the
command line; an independent pymoos2 client in a third process plays pHelmIvP. The DB is
killed and restarted while the simulation runs; the simulation reconnects and then
obeys the DESIRED_* the stand-in helm posts, which hears NAV_* and NODE_REPORT back.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.support.moos_ready import wait_for_clients
from uhrisim.autonomy.contacts import parse_node_report
from uhrisim.bridges.moos.testdb import spawn
from uhrisim.core.frames import wrap_180
from uhrisim.record.reader import iter_messages, read_odometry

pytest.importorskip("pymoos2", reason="pymoos2 (PyPI) is the independent MOOS peer")

ROOT = Path(__file__).resolve().parents[2]
SUPPORT = ROOT / "tests" / "support"


def test_moos_community_drives_the_rov_and_survives_a_db_restart(tmp_path: Path):
    db = spawn(community="videoray")
    port = db.port
    scenario = tmp_path / "moos.yaml"
    scenario.write_text((ROOT / "scenarios" / "moos_external_helm.yaml").read_text()
                        .replace("port: 9000", f"port: {port}")
                        .replace("port: 9001", f"port: {port}"))
    out = tmp_path / "run"
    # 40 simulated s at twice real time: the helm's orders arrive ~6 s in (its 12 s of
    # posting end ~28 s in) and the depth is within 0.3 m of them from ~19 s on (measured)
    sim = subprocess.Popen(
        [sys.executable, "-m", "uhrisim", "run", str(scenario), "--out", str(out), "--moos",
         "--rtf", "2", "--duration", "40", "-q", "--no-figures"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        wait_for_clients(port, {"uhrisim_videoray", "uhrisim_diver"})  # the run is up
        db.kill()  # the DB goes away under a running simulation...
        time.sleep(2.0)  # (an outage of 2 s: the bridges lose it and retry)
        db = spawn(port=port, community="videoray")  # ...and comes back on the same port
        helm = subprocess.run(
            [sys.executable, str(SUPPORT / "moos_helm_standin.py"), str(port), "45", "0.5",
             "3", "12"], capture_output=True, text=True, timeout=60)
        assert helm.returncode == 0, helm.stderr
        heard = json.loads(helm.stdout)
        _stdout, stderr = sim.communicate(timeout=90)
    finally:
        if sim.poll() is None:
            sim.kill()
        db.kill()
    assert sim.returncode == 0, stderr[-2000:]

    # The stand-in helm heard the simulated vehicles (MOOS frame: x east, y north).
    assert {"NAV_X", "NAV_Y", "NAV_HEADING", "NAV_DEPTH", "NODE_REPORT"} <= set(heard)
    report = parse_node_report(heard["NODE_REPORT"])
    assert report.name in {"videoray", "diver"}

    # The ROV obeyed: heading 45 deg, depth 3 m at the end of the commanded period.
    track = read_odometry(out / "recording.mcap")["videoray"]
    headings = np.degrees(track.yaw) % 360.0
    obeying = np.abs(np.asarray(wrap_180(headings - 45.0))) < 3.0
    assert obeying.any()
    first = int(np.argmax(obeying))
    assert abs(track.depth[-1] - 3.0) < 0.3
    assert np.hypot(track.x_north[-1] - track.x_north[first],
                    track.y_east[-1] - track.y_east[first]) > 1.0  # and it moved
    # The outage was reported as events in the recording, and the run completed.
    details = [m.message.detail for m in iter_messages(out / "recording.mcap", ["/events"])]
    assert any("reconnect" in d.lower() or "connected" in d.lower() for d in details), details
    assert json.loads((out / "metrics.json").read_text())["completed"] is True
