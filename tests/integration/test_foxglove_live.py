"""``uhrisim run --foxglove`` serves the run live over Foxglove's WebSocket protocol
(issue 30). Foxglove's own web app cannot run offline here, so a plain ``websockets``
client stands in for it: it reads the server's advertisements (the recording's topics,
``ros2msg`` schemas, CDR), subscribes to odometry, ``/tf``, the sonar fan and ``/clock``,
and decodes every message it gets with mcap-ros2's decoder built from the advertised
schema — not uhrisim's code.

The run (scenarios/track_and_trail_sonar.yaml, paced at real time) is its own process;
the client waits for what it needs, never for a wall-clock guess.
"""

from __future__ import annotations

import json
import re
import signal
import struct
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("foxglove")
sync_client = pytest.importorskip("websockets.sync.client")
from mcap_ros2._dynamic import generate_dynamic  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "track_and_trail_sonar.yaml"
WANTED = ("/videoray/odom", "/tf", "/videoray/sonar/fan", "/clock")
MESSAGE_DATA = 0x01  # the binary opcode of a message (foxglove.sdk.v1)


def _server_url(run: subprocess.Popen, said: list[str]) -> str:
    """The server's address, from the line the run says it in once the server listens
    (port 0: the system picks a free port as the server binds; a port picked by the test
    beforehand could be taken by another process in between). The lines read go to
    ``said``."""
    for line in run.stderr:  # until the line comes, or the run ends
        said.append(line)
        if match := re.search(r"ws://127\.0\.0\.1:\d+", line):
            return match.group(0)
    raise AssertionError("the run ended without serving: " + "".join(said)[-2000:])


def test_a_websocket_client_subscribes_and_decodes(tmp_path: Path) -> None:
    run = subprocess.Popen([sys.executable, "-m", "uhrisim", "run", str(SCENARIO), "--out",
                            str(tmp_path / "run"), "-q", "--foxglove", "--foxglove-port", "0"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    channels: dict[int, dict] = {}
    decoded: dict[str, list] = {topic: [] for topic in WANTED}
    said: list[str] = []
    try:
        url = _server_url(run, said)
        with sync_client.connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None) as ws:
            subscribed: dict[int, str] = {}
            while any(len(v) < 3 for v in decoded.values()):
                frame = ws.recv(timeout=300.0)
                if isinstance(frame, str):
                    note = json.loads(frame)
                    if note["op"] == "advertise":
                        for ch in note["channels"]:
                            channels[ch["id"]] = ch
                            if ch["topic"] in WANTED and ch["topic"] not in subscribed.values():
                                sub_id = len(subscribed) + 1
                                subscribed[sub_id] = ch["topic"]
                                ch["decode"] = generate_dynamic(ch["schemaName"],
                                                                ch["schema"])[ch["schemaName"]]
                                ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                                    {"id": sub_id, "channelId": ch["id"]}]}))
                    continue
                assert frame[0] == MESSAGE_DATA
                sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
                topic = subscribed[sub_id]
                ch = next(c for c in channels.values() if c["topic"] == topic)
                decoded[topic].append((log_time, ch["decode"](frame[13:])))
    finally:
        run.send_signal(signal.SIGINT)
        _, rest = run.communicate(timeout=120.0)
        stderr = "".join(said) + rest
    assert run.returncode == 128 + signal.SIGINT, stderr
    assert "Foxglove: open ws://127.0.0.1:" in stderr
    by_topic = {c["topic"]: c for c in channels.values()}
    assert by_topic["/videoray/odom"]["schemaName"] == "nav_msgs/msg/Odometry"
    assert all(c["encoding"] == "cdr" and c["schemaEncoding"] == "ros2msg"
               for c in channels.values())
    assert {"/scene/markers", "/videoray/sonar/image", "/diver/odom"} <= set(by_topic)
    for topic, messages in decoded.items():
        times = [t for t, _ in messages]
        assert times == sorted(times), topic  # simulation time, in order
    for log_time, odom in decoded["/videoray/odom"]:
        stamp = odom.header.stamp.sec * 1_000_000_000 + odom.header.stamp.nanosec
        assert stamp == log_time and odom.child_frame_id == "videoray/base_link"
    for _, fan in decoded["/videoray/sonar/fan"]:
        assert fan.width > 0 and len(fan.data) == fan.step * fan.height
    assert any(t.header.frame_id == "map" for _, tf in decoded["/tf"] for t in tf.transforms)
