"""`uhrisim run --ros2` on the sonar-only trail: a plain rclpy process (another process,
reliable QoS like RViz2's) receives the perception's detections and tracks as
visualization_msgs/MarkerArray, the same markers the recording holds for the same pings.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from tests.support.children import Child
from uhrisim.viz.viewer.replay import load_replay

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "track_and_trail_sonar.yaml"
SIM_SECONDS = 30.0


def test_perception_markers_reach_a_ros2_node(ros_env: int, tmp_path: Path):
    out = tmp_path / "run"
    sim = subprocess.Popen(
        [sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out", str(out), "--ros2",
         "--rtf", "3", "--duration", str(SIM_SECONDS), "-q", "--no-figures"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    listener = Child("ros2_marker_listener.py", ["--agent", "videoray"], tmp_path)
    try:
        listener.expect("READY")
        # the run's end (a bound only: 91-124 s here with the load average at 15-19)
        _stdout, stderr = sim.communicate(timeout=600.0)
        listener.send("STOP")
        result = json.loads(listener.expect("RESULT", timeout=10.0))
        listener.finish()
    finally:
        if listener.proc.poll() is None:
            listener.proc.kill()
        if sim.poll() is None:
            sim.kill()
    assert sim.returncode == 0, stderr[-2000:]

    tracks = result["/videoray/perception/tracks"]
    assert len(tracks) > 100 and len(result["/videoray/perception/detections"]) > 100
    for msg in tracks:
        assert msg["markers"][0][2] == 3  # DELETEALL first, then this ping's markers
        assert all(m[3] == "map" for m in msg["markers"])
    # The live diver track equals the recorded one at the same ping (stamp).
    times, recorded = load_replay(out / "recording.mcap").perception["videoray"]
    recorded_at = {round(t, 6): seen for t, seen in zip(times, recorded, strict=True)}
    compared = 0
    for msg in tracks:
        live = [m for m in msg["markers"]
                if m[0] == "tracks" and re.match(r"track \d+ \(diver\)", m[6])]
        seen = recorded_at.get(round(msg["stamp"], 6))
        if not live or seen is None:
            continue
        (diver,) = [s for s in seen if s["kind"] == "diver"]
        assert live[0][4] == pytest.approx(diver["east"], abs=1e-6)  # ENU x = east
        assert live[0][5] == pytest.approx(diver["north"], abs=1e-6)  # ENU y = north
        compared += 1
    assert compared > 100
