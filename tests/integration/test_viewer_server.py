"""Viewer server without a browser: protocol, HTTP, websocket streaming, commands.

A Python websocket client plays the page. Numbers checked: exact round trips of
commands and frames, the latest-frame-wins rule, the per-client frame cap, loopback-only
binding, PNG round trip of a sonar fan.
"""

from __future__ import annotations

import base64
import gzip
import json
import math
import socket
import threading
import time
import urllib.error
import urllib.request

import cv2
import numpy as np
import pytest

pytest.importorskip("websockets")

from websockets.sync.client import connect

from uhrisim.core.errors import ConfigError, UhrisimError
from uhrisim.viz.viewer import Command, ViewerServer, parse_command
from uhrisim.viz.viewer.demo import DEMO_BUTTONS, demo_fan, demo_frame, demo_scene
from uhrisim.viz.viewer.protocol import encode_json, encode_png_b64


def _ws_url(url: str) -> str:
    return url.replace("http://", "ws://") + "ws"


def _recv_until(ws, pred, timeout=5.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = json.loads(ws.recv(timeout=max(0.01, deadline - time.monotonic())))
        if pred(msg):
            return msg
    raise AssertionError("expected message did not arrive")


@pytest.fixture
def server():
    s = ViewerServer(demo_scene(), DEMO_BUTTONS, port=0, max_fps=20)
    s.start()
    yield s
    s.close()


# ---------------------------------------------------------------- pure protocol
@pytest.mark.parametrize(
    ("msg", "expected"),
    [
        ({"kind": "pause"}, Command("pause")),
        ({"kind": "resume"}, Command("resume")),
        ({"kind": "step", "value": 1}, Command("step", value=1.0)),
        ({"kind": "step"}, Command("step")),
        ({"kind": "speed", "value": 0.5}, Command("speed", value=0.5)),
        ({"kind": "speed", "value": "max"}, Command("speed", value=math.inf)),
        ({"kind": "post", "agent": "videoray", "name": "DEPLOY", "value": "true"},
         Command("post", "videoray", "DEPLOY", "true")),
        ({"kind": "post", "agent": "v", "name": "X", "value": True},
         Command("post", "v", "X", "true")),
        ({"kind": "post", "agent": "v", "name": "X", "value": 3}, Command("post", "v", "X", 3.0)),
        ({"kind": "select", "agent": "diver"}, Command("select", agent="diver")),
    ],
)
def test_parse_command_accepts(msg, expected):
    assert parse_command({"type": "command", **msg}) == expected


@pytest.mark.parametrize(
    "msg",
    [
        {"kind": "explode"},
        {"kind": "speed", "value": 0},
        {"kind": "speed", "value": -2},
        {"kind": "speed", "value": "fast"},
        {"kind": "step", "value": 0.5},
        {"kind": "post", "agent": "v", "value": "1"},
        {"kind": "post", "name": "X", "value": "1"},
        {"kind": "post", "agent": "v", "name": "X"},
        {"kind": "select"},
        {"kind": "pause", "agent": 7},
        [1, 2],
    ],
)
def test_parse_command_rejects(msg):
    with pytest.raises(ConfigError, match="viewer command"):
        parse_command(msg)


def test_encode_json_is_browser_parsable():
    # JSON.parse rejects NaN/Infinity: they must become null; numpy types become plain.
    text = encode_json({"a": math.nan, "b": [np.float32(1.5), np.int64(3)], "c": math.inf,
                        "d": np.arange(3)})
    assert json.loads(text) == {"a": None, "b": [1.5, 3], "c": None, "d": [0, 1, 2]}
    assert "NaN" not in text and "Infinity" not in text


def test_png_round_trip_is_lossless():
    img = demo_fan(3.0, rng=np.random.default_rng(0))
    back = cv2.imdecode(np.frombuffer(base64.b64decode(encode_png_b64(img)), np.uint8),
                        cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(back, img)


def test_large_fans_are_shrunk_for_display_keeping_aspect_and_mean():
    img = demo_fan(3.0, size=(512, 400), rng=np.random.default_rng(1))
    h, w = img.shape
    back = cv2.imdecode(np.frombuffer(base64.b64decode(encode_png_b64(img, 400)), np.uint8),
                        cv2.IMREAD_UNCHANGED)
    assert back.shape == (400, round(w * 400 / h))
    # area averaging keeps the mean echo level (to the rounding of 8-bit pixels)
    assert abs(float(back.mean()) - float(img.mean())) < 0.5


def test_refuses_non_loopback_and_bad_args():
    with pytest.raises(ConfigError, match="loopback"):
        ViewerServer({}, [], host="0.0.0.0")
    with pytest.raises(ConfigError, match="max_fps"):
        ViewerServer({}, [], max_fps=0)
    with pytest.raises(ConfigError, match=r"buttons\[0\]"):
        ViewerServer({}, [{"label": "X"}])


def test_port_in_use_is_a_config_error(server):
    other = ViewerServer({}, [], port=server.port)
    with pytest.raises(ConfigError, match="cannot listen"):
        other.start()


def test_start_is_idempotent_and_close_is_final():
    s = ViewerServer({}, [], port=0)
    url = s.start()
    assert s.start() == url
    s.close()
    s.close()
    assert s.url is None
    with pytest.raises(UhrisimError, match="make a new one"):
        s.start()


# ---------------------------------------------------------------- HTTP
def test_http_serves_page_and_assets_only_from_package(server):
    url = server.url
    assert url.startswith("http://127.0.0.1:")
    with urllib.request.urlopen(url) as r:
        html = r.read().decode()
        assert r.headers["Content-Type"].startswith("text/html")
    assert '<canvas id="map">' in html and "/static/viewer.js" in html
    # no external URLs anywhere in what the page loads (offline by construction)
    for name in ("viewer.js", "viewer.css"):
        with urllib.request.urlopen(url + "static/" + name) as r:
            body = r.read().decode()
        assert "http://" not in body and "https://" not in body, name
    req = urllib.request.Request(url + "static/three.module.min.js",
                                 headers={"Accept-Encoding": "gzip"})
    with urllib.request.urlopen(req) as r:
        assert r.headers["Content-Encoding"] == "gzip"
        js = gzip.decompress(r.read())
    assert js.startswith(b"/**\n * @license") and b'REVISION' not in js[:10]
    for bad in ("static/../server.py", "static/nope.js", "etc/passwd"):
        with pytest.raises(urllib.error.HTTPError) as e:
            urllib.request.urlopen(url + bad)
        assert e.value.code == 404
        e.value.close()


# ---------------------------------------------------------------- websocket
def test_hello_then_latest_frame_and_sonar(server):
    with connect(_ws_url(server.url)) as ws:
        hello = json.loads(ws.recv(timeout=5))
        assert hello["type"] == "hello" and hello["mode"] == "live"
        assert [b["var"] for b in hello["buttons"]] == ["DEPLOY", "RETURN"]
        assert len(hello["scene"]["objects"]) == 5
        # a burst of frames: only the latest survives (latest frame wins)
        fan = demo_fan(10.0)
        for k in range(500):
            server.publish(demo_frame(k * 0.02, sonar=fan if k == 250 else None))
        seen: dict[str, dict] = {}

        def both(m):
            if m["type"] == "sonar" or m["t"] == pytest.approx(9.98):
                seen[m["type"]] = m
            return len(seen) == 2

        _recv_until(ws, both)
        msg, sonar = seen["frame"], seen["sonar"]
        assert "sonar" not in msg
        assert msg["agents"][0]["name"] == "diver"
        exp = demo_frame(9.98)
        assert msg["agents"][1]["north"] == pytest.approx(exp["agents"][1]["north"], abs=1e-12)
        assert sonar["agent"] == "videoray" and sonar["t"] == pytest.approx(5.0)
        img = cv2.imdecode(np.frombuffer(base64.b64decode(sonar["fan_png_b64"]), np.uint8),
                           cv2.IMREAD_UNCHANGED)
        np.testing.assert_array_equal(img, fan)
    # 500 publishes, far fewer encodes: encoding is paced by max_fps, not by publish()
    assert server.frames_encoded < 50


def test_publish_copies_fan_so_sim_may_reuse_its_buffer(server):
    fan = demo_fan(1.0)
    orig = fan.copy()
    server.publish(demo_frame(1.0, sonar=fan))
    fan[:] = 0  # the simulation overwrites its buffer right after publishing
    with connect(_ws_url(server.url)) as ws:
        ws.recv(timeout=5)
        sonar = _recv_until(ws, lambda m: m["type"] == "sonar")
    img = cv2.imdecode(np.frombuffer(base64.b64decode(sonar["fan_png_b64"]), np.uint8),
                       cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(img, orig)


def test_frame_rate_is_capped_per_client():
    s = ViewerServer({}, [], port=0, max_fps=10)
    s.start()
    stop = threading.Event()

    def sim():
        k = 0
        while not stop.is_set():
            s.publish(demo_frame(k * 1e-3))
            k += 1
            time.sleep(1e-4)

    th = threading.Thread(target=sim)
    try:
        with connect(_ws_url(s.url)) as ws:
            ws.recv(timeout=5)
            th.start()
            t0 = time.monotonic()
            seqs = []
            while time.monotonic() - t0 < 1.5:
                m = json.loads(ws.recv(timeout=2))
                if m["type"] == "frame":
                    seqs.append(m["seq"])
            elapsed = time.monotonic() - t0
    finally:
        stop.set()
        if th.is_alive():
            th.join()
        s.close()
    # at most max_fps·elapsed (+ the frame pending at connect, + one in flight at each end)
    assert len(seqs) <= 10 * elapsed + 3
    assert seqs == sorted(set(seqs)), "frames are newest-first, never repeated"
    assert seqs[-1] - seqs[0] > 10 * len(seqs), "intermediate frames skipped"


def _stalled_client(url: str) -> socket.socket:
    """A websocket client that completes the handshake and then never reads."""
    host, port = url.removeprefix("http://").rstrip("/").split(":")
    sock = socket.create_connection((host, int(port)))
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.sendall(
        f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
        "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
        "Sec-WebSocket-Version: 13\r\n\r\n".encode()
    )
    return sock


def test_stalled_client_does_not_starve_another(server):
    # One client never reads; the other must keep receiving every new frame it can.
    stalled = _stalled_client(server.url)
    try:
        with connect(_ws_url(server.url)) as ws:
            ws.recv(timeout=5)
            big = {"pad": "x" * 200_000}  # fills the stalled client's buffers in a few frames
            got = []
            for k in range(40):
                server.publish({**demo_frame(k * 0.1), **big})
                time.sleep(0.03)
                while True:
                    try:
                        m = json.loads(ws.recv(timeout=0))
                    except TimeoutError:
                        break
                    if m["type"] == "frame":
                        got.append(m["t"])
            if not got or got[-1] != pytest.approx(3.9):
                _recv_until(ws, lambda m: m["type"] == "frame" and m["t"] == pytest.approx(3.9))
            assert server.n_clients == 2
            # 40 frames 30 ms apart at max_fps=20: about 40·0.03·20 = 24 can go out
            assert len(got) >= 10
    finally:
        stalled.close()


def test_commands_from_page_reach_drain_in_order(server):
    with connect(_ws_url(server.url)) as ws:
        ws.recv(timeout=5)
        for msg in (
            {"type": "command", "kind": "pause"},
            {"type": "command", "kind": "step", "value": 1},
            {"type": "command", "kind": "bogus"},  # dropped with a warning
            "not json",
            {"type": "command", "kind": "post", "agent": "videoray", "name": "DEPLOY",
             "value": "true"},
            {"type": "command", "kind": "speed", "value": "max"},
            {"type": "command", "kind": "resume"},
        ):
            ws.send(msg if isinstance(msg, str) else json.dumps(msg))
        deadline = time.monotonic() + 5
        got: list[Command] = []
        while len(got) < 5 and time.monotonic() < deadline:
            got += server.drain_commands()
            time.sleep(0.01)
    assert got == [
        Command("pause"),
        Command("step", value=1.0),
        Command("post", "videoray", "DEPLOY", "true"),
        Command("speed", value=math.inf),
        Command("resume"),
    ]
    assert server.drain_commands() == []


def test_late_client_gets_trail_history():
    s = ViewerServer({}, [], port=0, max_fps=50, history_period=0.5)
    s.start()
    try:
        for k in range(21):  # t = 0 … 10 s, one frame per 0.5 s, each taken in by the server
            s.publish(demo_frame(k * 0.5))
            deadline = time.monotonic() + 10
            while s.processed_seq != k + 1 and time.monotonic() < deadline:
                time.sleep(0.002)
        with connect(_ws_url(s.url)) as ws:
            hello = json.loads(ws.recv(timeout=5))
    finally:
        s.close()
    hist = hello["history"]["diver"]
    assert [round(p[0], 6) for p in hist] == [k * 0.5 for k in range(21)]
    exp = demo_frame(10.0)["agents"][0]
    assert hist[-1][1:] == pytest.approx([exp["north"], exp["east"], exp["depth"]])


def test_foreign_origins_and_hosts_are_refused(server):
    # another web site open in the user's browser must not steer the simulation
    from websockets.exceptions import InvalidStatus

    with pytest.raises(InvalidStatus) as e:
        connect(_ws_url(server.url), origin="http://evil.example")
    assert e.value.response.status_code == 403
    for ok in (f"http://127.0.0.1:{server.port}", "http://localhost:9000"):
        with connect(_ws_url(server.url), origin=ok) as ws:
            assert json.loads(ws.recv(timeout=5))["type"] == "hello"
    # DNS rebinding: a request for our port under another host name
    req = urllib.request.Request(server.url, headers={"Host": "evil.example:80"})
    with pytest.raises(urllib.error.HTTPError) as e2:
        urllib.request.urlopen(req)
    assert e2.value.code == 403
    e2.value.close()
    req = urllib.request.Request(server.url, headers={"Host": "[::1]:8765"})
    with urllib.request.urlopen(req) as r:
        assert r.status == 200


def test_camera_frames_go_out_as_camera_messages(server):
    """A frame's camera entry is copied at publish, PNG-encoded in the server thread and
    sent as a ``camera`` message; the frame message itself carries no image."""
    image = np.zeros((60, 80, 3), np.uint8)
    image[:, :40] = (200, 120, 30)  # RGB
    orig = image.copy()
    server.publish({**demo_frame(2.0), "camera": [{"agent": "videoray", "t": 2.0,
                                                   "image": image}]})
    image[:] = 0  # the simulation may reuse its buffer
    with connect(_ws_url(server.url)) as ws:
        ws.recv(timeout=5)
        seen: dict[str, dict] = {}

        def both(m):
            seen[m["type"]] = m
            return {"frame", "camera"} <= set(seen)

        _recv_until(ws, both)
    assert "camera" not in seen["frame"]
    msg = seen["camera"]
    assert msg["agent"] == "videoray" and msg["t"] == pytest.approx(2.0)
    img = cv2.imdecode(np.frombuffer(base64.b64decode(msg["png_b64"]), np.uint8),
                       cv2.IMREAD_COLOR)
    np.testing.assert_array_equal(img[:, :, ::-1], orig)
