"""The MOOS bridge against a real-protocol MOOSDB in another process (127.0.0.1 only).

The DB is :mod:`uhrisim.bridges.moos.testdb` in a child process. The independent peer is
``pymoos2`` (a separate pure-Python MOOS implementation from PyPI, synchronous client), run
in its own process; our own :class:`MoosClient` serves as a second observer.

Provenance of the expected numbers: the simulator state posted here (north 10, east -3,
depth 2, heading 370 deg -> 10 deg, speed 1.2) maps to MOOS x = east = -3, y = north = 10
(docs/conventions.md); DESIRED_* values are those the other process posts.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.support.moos_trace import trace_streams
from tests.support.ports import held_port
from uhrisim.autonomy.contacts import parse_node_report
from uhrisim.bridges.moos.bridge import MoosAgentBridge
from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.testdb import spawn
from uhrisim.bridges.moos.wire import (
    HANDSHAKE,
    MoosMessage,
    MoosStreamParser,
    encode_packet,
)
from uhrisim.core.errors import BridgeError

SRC = str(Path(__file__).resolve().parents[2] / "src")
#: The bound of a wait for an event (a post, a connection, a status): only against a hang;
#: a wait ends when its event comes (a busy machine delays it by an unknown time).
HANG_S = 120.0
NAV_VARS = ("NAV_X", "NAV_Y", "NAV_DEPTH", "NAV_HEADING", "NAV_SPEED", "NAV_LAT", "NAV_LONG",
            "NODE_REPORT")


def wait_until(pred, timeout_s: float, period_s: float = 0.01) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(period_s)
    return bool(pred())


@pytest.fixture(scope="module")
def db():
    with spawn(community="vehicle") as proc:
        yield proc


# A pymoos2 "helm" in its own process: posts DESIRED_* and reports the NAV_* it received.
_PYMOOS2_HELM = r"""
import json, sys, time
from pymoos2.core.MOOSCommClient import MOOSCommClient
port = int(sys.argv[1])
c = MOOSCommClient("127.0.0.1", port, "pHelmStandIn", comm_tick=50)
c.start()
assert c.wait_until_connected(120.0)
for v in sys.argv[2].split(","):
    c.register(v)
got = {}
deadline = time.time() + 120.0
while time.time() < deadline and "NODE_REPORT" not in got:
    c.notify("DESIRED_HEADING", 123.5)
    c.notify("DESIRED_SPEED", 1.5)
    c.notify("DESIRED_DEPTH", 2.0)
    time.sleep(0.05)
    for m in c.fetch():
        got[m.key] = [m.val if m.is_double() else m.string(), m.src, m.community]
print(json.dumps(got))
c.stop()
"""


def test_pymoos2_process_and_bridge_exchange_nav_and_desired(db):
    pytest.importorskip("pymoos2", reason="pymoos2 (PyPI) is the independent MOOS peer")
    bridge = MoosAgentBridge("videoray", port=db.port, community="vehicle", strict=True,
                             lat_origin=42.358456, long_origin=-71.087589)
    try:
        env = dict(os.environ, PYTHONPATH=SRC)
        helm = subprocess.Popen([sys.executable, "-c", _PYMOOS2_HELM, str(db.port),
                                 ",".join(NAV_VARS)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=env)
        t0 = time.monotonic()
        while helm.poll() is None:  # it ends once it has what it waits for
            assert time.monotonic() - t0 < HANG_S, "the pymoos2 helm hung"
            bridge.publish_nav(time.monotonic() - t0, x_north=10.0, y_east=-3.0, depth=2.0,
                               heading_deg=370.0, speed_mps=1.2)
            time.sleep(0.02)
        out, err = helm.communicate(timeout=HANG_S)
        assert helm.returncode == 0, err
        got = json.loads(out)
        assert got["NAV_X"][0] == -3.0 and got["NAV_Y"][0] == 10.0  # x east, y north
        assert got["NAV_DEPTH"][0] == 2.0 and got["NAV_SPEED"][0] == 1.2
        assert got["NAV_HEADING"][0] == 10.0
        assert got["NAV_X"][1] == "uhrisim_videoray" and got["NAV_X"][2] == "vehicle"
        rep = parse_node_report(got["NODE_REPORT"][0])
        assert (rep.x, rep.y, rep.heading) == (-3.0, 10.0, 10.0)
        assert rep.name == "videoray" and rep.type == "UUV"
        assert rep.lat == pytest.approx(got["NAV_LAT"][0], abs=1e-8)
        # and the bridge obeyed what the other process posted
        assert wait_until(lambda: len(bridge.received()) == 3, HANG_S)
        heading, speed, depth = bridge.desired()
        assert (heading, speed, depth) == (123.5, 1.5, 2.0)
    finally:
        bridge.close()


def test_our_client_observes_bridge_and_posts_desired(db):
    bridge = MoosAgentBridge("diver", port=db.port, strict=True, extra_vars=("DEPLOY",),
                             time_warp=4.0)
    obs = MoosClient(time_warp=4.0)
    try:
        obs.connect("127.0.0.1", db.port, "observer", strict=True)
        for v in NAV_VARS:
            obs.register(v)
        assert wait_until(lambda: obs.n_sent >= len(NAV_VARS), HANG_S)
        seen: dict[str, MoosMessage] = {}

        def pump() -> bool:
            bridge.publish_nav(0.0, x_north=-7.5, y_east=2.25, depth=1.0, heading_deg=45.0,
                               speed_mps=0.5)
            # the shared DB also replays other tests' last values: keep only the diver's
            seen.update({m.key: m for m in obs.drain() if m.source == "uhrisim_diver"})
            return set(NAV_VARS) <= set(seen)

        posted_from = time.time()
        assert wait_until(pump, HANG_S, 0.02)
        assert seen["NAV_X"].value == 2.25 and seen["NAV_Y"].value == -7.5
        # MOOS time with MOOSTimeWarp 4: wall clock x 4 (MOOSLocalTime), stamped while
        # the pump posted (not within a guessed window of now)
        assert 4.0 * posted_from - 1e-3 <= seen["NAV_X"].time <= 4.0 * time.time() + 1e-3
        obs.notify("DESIRED_SPEED", 0.75)
        obs.notify("DEPLOY", "true")
        obs.notify("UNRELATED", 1.0)
        assert wait_until(lambda: "DEPLOY" in bridge.received(), HANG_S)
        r = bridge.received()
        assert r["DESIRED_SPEED"][0] == 0.75 and r["DEPLOY"][0] == "true"
        assert "UNRELATED" not in r
    finally:
        obs.close()
        bridge.close()


def test_wildcard_registration_and_duplicate_name_poison(db):
    pytest.importorskip("pymoos2")
    from pymoos2.core.MOOSCommClient import MOOSCommClient

    watcher = MOOSCommClient("127.0.0.1", db.port, "wildwatch", comm_tick=50)
    watcher.start()
    poster = MoosClient()
    try:
        assert watcher.wait_until_connected(HANG_S)
        watcher.wildcard_register("WILD_*", "poster")
        poster.connect("127.0.0.1", db.port, "poster", strict=True)
        got = []

        def pump() -> bool:
            poster.notify("WILD_A", 1.0)
            poster.notify("TAME_B", 2.0)
            got.extend(watcher.fetch())
            return any(m.key == "WILD_A" for m in got)

        assert wait_until(pump, HANG_S, 0.05)
        assert {m.key for m in got} == {"WILD_A"}
        # a second client with the same name is refused with a K (poison) message
        twin = MoosClient()
        with pytest.raises(BridgeError, match="already exists"):
            twin.connect("127.0.0.1", db.port, "poster", strict=True)
    finally:
        watcher.stop()
        poster.close()


def test_strict_connect_to_nothing_raises_and_lax_connect_waits(db):
    holder = held_port()
    port = holder.getsockname()[1]
    with pytest.raises(BridgeError, match=rf"127\.0\.0\.1:{port}.*refused"):
        MoosAgentBridge("rov", port=port, strict=True)
    # the first refusal is reported, not the timeout: an hour's timeout ends at once
    client = MoosClient()
    with pytest.raises(BridgeError, match="refused"):
        client.connect("127.0.0.1", port, "probe", strict=True, timeout_s=3600.0)
    assert client.n_attempts == 1
    # lax: returns at once, retries in the background, connects when a DB appears
    bridge = MoosAgentBridge("rov", port=port)
    try:
        assert not bridge.connected
        assert bridge.publish_nav(0.0, 1.0, 2.0, 0.0, 0.0, 0.0) is False  # kept for later
        assert wait_until(lambda: "retrying" in bridge.status, HANG_S)
        holder.close()  # (from here until the DB binds it, the port could still be taken)
        with spawn(port=port) as late_db:
            assert late_db.port == port
            assert bridge.client.wait_connected(HANG_S)
            assert bridge.connected
    finally:
        holder.close()
        bridge.close()


def test_db_killed_and_restarted_is_survived_without_blocking():
    first = spawn()
    port = first.port
    bridge = MoosAgentBridge("videoray", port=port, strict=True)
    obs = MoosClient(reconnect_max_s=0.2)
    obs.connect("127.0.0.1", port, "observer", strict=True)
    obs.register("NAV_X")
    second = None
    worst = 0.0
    try:
        def step(i: int) -> None:
            nonlocal worst
            t = time.perf_counter()
            bridge.publish_nav(i * 0.02, x_north=0.0, y_east=float(i), depth=0.0,
                               heading_deg=0.0, speed_mps=0.0)
            bridge.received()
            worst = max(worst, time.perf_counter() - t)

        i = 0
        while not any(m.key == "NAV_X" for m in obs.drain()):
            step(i := i + 1)
            assert i < 200, "no NAV_X before the kill"
            time.sleep(0.01)
        first.kill()  # SIGKILL: sockets die without a goodbye
        assert wait_until(lambda: not bridge.connected, HANG_S)
        for _ in range(25):  # the simulation keeps stepping while the DB is gone
            step(i := i + 1)
            time.sleep(0.01)
        # (the client's thread says so just after it clears ``connected``)
        assert wait_until(lambda: "retrying" in bridge.status and "last error" in bridge.status,
                          HANG_S), bridge.status
        second = spawn(port=port)
        values: list[float] = []

        def resumed() -> bool:
            nonlocal i
            step(i := i + 1)
            values.extend(m.value for m in obs.drain() if m.key == "NAV_X")
            return bool(values) and values[-1] > 30
        assert wait_until(resumed, HANG_S, 0.02), bridge.status
        assert bridge.client.n_connects == 2 and obs.n_connects == 2
        # re-registration after the restart: DESIRED_HEADING reaches the bridge again
        obs.notify("DESIRED_HEADING", 271.0)
        assert wait_until(lambda: bridge.desired()[0] == 271.0, HANG_S)
        # a call that waited on the network would wait out the 1 s connect timeout; the
        # generous bound leaves room for a loaded CI machine
        assert worst < 0.25, f"a bridge call blocked for {worst * 1e3:.1f} ms"
    finally:
        bridge.close()
        obs.close()
        first.kill()
        if second is not None:
            second.terminate()


def raw_client(port: int, name: str) -> socket.socket:
    """A connection that says hello as ``name`` and is welcomed (then holds the name)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=60.0)
    hello = MoosMessage(-1, "i", "S", "", "", "", "asynchronous", time.time(), -1.0, -1.0,
                        name.encode())
    s.sendall(HANDSHAKE + encode_packet([hello]))
    assert MoosStreamParser().feed(s.recv(4096))[0].messages[0].msg_type == "W"
    return s


def test_a_busy_db_is_given_time_to_welcome():
    # the DB takes the name at once and welcomes 2.5 s later (a loaded MOOSDB was seen to
    # take longer than the 1 s earlier clients gave it, then refuse the retry by name):
    # one attempt, no refusal, connected
    with spawn(welcome_delay_s=2.5) as slow:
        client = MoosClient()
        try:
            client.connect("127.0.0.1", slow.port, "uhrisim_videoray")
            assert wait_until(lambda: "waiting for the welcome" in client.status, 60.0)
            assert client.wait_connected(120.0), client.status
            assert (client.n_attempts, client.n_refusals, client.n_connects) == (1, 0, 1)
        finally:
            client.close()


def test_a_name_the_db_still_holds_is_retried_until_it_is_free(caplog):
    # a stale connection holds our name: the DB refuses us ('K'); the client says so once,
    # keeps retrying with backoff, and gets in as soon as the stale one is gone
    with spawn() as dbp:
        stale = raw_client(dbp.port, "uhrisim_videoray")
        client = MoosClient(reconnect_max_s=0.2)
        try:
            with caplog.at_level("WARNING", logger="uhrisim.bridges.moos.client"):
                client.connect("127.0.0.1", dbp.port, "uhrisim_videoray")
                assert wait_until(lambda: client.n_refusals >= 3, 120.0), client.status
                assert not client.connected and "already exists" in client.status
                stale.close()
                assert client.wait_connected(120.0), client.status
                # said by the client's thread once it is in
                assert wait_until(lambda: any(f"(attempt {client.n_attempts})" in r.getMessage()
                                              for r in caplog.records), 60.0)
            said = [r.getMessage() for r in caplog.records]
            refused = [m for m in said if "refused the name" in m]
            assert len(refused) == 1, said
            assert 'A client of this name ("uhrisim_videoray") already exists' in refused[0]
            assert client.n_attempts == client.n_refusals + 1 and client.n_connects == 1
        finally:
            stale.close()
            client.close()


def test_db_drops_a_client_sending_garbage_and_keeps_serving(db):
    with socket.create_connection(("127.0.0.1", db.port), timeout=2.0) as s:
        hello = MoosMessage(-1, "i", "S", "", "", "", "asynchronous", time.time(), -1.0, -1.0,
                            b"vandal")
        s.sendall(HANDSHAKE + encode_packet([hello]))
        assert MoosStreamParser().feed(s.recv(4096))[0].messages[0].msg_type == "W"
        s.sendall(b"\xff\xff\xff\x7f" + bytes(60))  # absurd packet size
        assert s.recv(4096) == b""  # dropped
    c = MoosClient()
    try:
        c.connect("127.0.0.1", db.port, "vandal", strict=True)  # the name is free again
    finally:
        c.close()


def test_client_survives_a_server_speaking_garbage():
    """A peer that welcomes us and then sends nonsense: typed error, drop, reconnect."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    srv.settimeout(5.0)
    port = srv.getsockname()[1]
    served = []

    def serve() -> None:
        for _ in range(2):
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            with conn:
                conn.recv(4096)
                welcome = MoosMessage(-1, "W", "D", "", "", "evil", "", time.time(), 0.0, -1.0,
                                      b"asynchronous")
                conn.sendall(encode_packet([welcome]))
                time.sleep(0.05)  # connected now; then a packet with a 10-byte "size"
                conn.sendall(b"\x0a\x00\x00\x00" + bytes(20))
                served.append(1)
                time.sleep(0.2)

    th = threading.Thread(target=serve, daemon=True)
    th.start()
    c = MoosClient(reconnect_min_s=0.01)
    try:
        c.connect("127.0.0.1", port, "victim")
        assert wait_until(lambda: len(served) == 2 and c.n_connects >= 2, HANG_S)
        assert wait_until(lambda: c.last_error is not None and "MoosProtocolError" in
                          c.last_error, HANG_S), c.status
        assert c.drain() == []
    finally:
        c.close()
        srv.close()
        th.join(2.0)


def test_client_talks_like_the_real_client_to_a_replayed_real_db():
    """Replay the real MOOSDB's welcome (trace, conn 2) to our client; what our client sends
    back must have the real client's shape, message by message (times and ids aside)."""
    streams = trace_streams()
    real_c2s = [m for p in MoosStreamParser(expect_handshake=True).feed(streams[(2, "c2s")])
                for m in p.messages]
    real_s2c = MoosStreamParser().feed(streams[(2, "s2c")])
    welcome_bytes = encode_packet(real_s2c[0].messages)
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    srv.settimeout(5.0)
    c = MoosClient()
    try:
        c.connect("127.0.0.1", srv.getsockname()[1], "uPokeDB")
        conn, _ = srv.accept()
        with conn:
            conn.settimeout(5.0)
            parser = MoosStreamParser(expect_handshake=True)
            ours: list[MoosMessage] = []
            ours += [m for p in parser.feed(conn.recv(65536)) for m in p.messages]
            conn.sendall(welcome_bytes)  # the real DB's bytes
            assert c.wait_connected(2.0) and c.community == "trace"
            c.register("NAV_X")
            assert c.notify("NAV_X", 42.25) is True
            deadline = time.monotonic() + 3.0
            while sum(m.msg_type == "N" for m in ours) < 1 and time.monotonic() < deadline:
                ours += [m for p in parser.feed(conn.recv(65536)) for m in p.messages]
        assert parser.handshake == "ELKS CAN'T DANCE 2/8/10"

        def shape(m: MoosMessage) -> tuple:
            return (m.msg_type, m.data_type, m.source, m.source_aux, m.community, m.key,
                    m.dval, m.dval2, m.sval)

        def first(msgs, msg_type, key=None):
            return next(m for m in msgs if m.msg_type == msg_type and key in (None, m.key))

        for msg_type, key in (("i", None), ("T", None), ("R", "NAV_X"), ("N", "NAV_X")):
            assert shape(first(ours, msg_type, key)) == shape(first(real_c2s, msg_type, key))
        assert first(ours, "i").msg_id == first(real_c2s, "i").msg_id == -1
        assert first(ours, "T").msg_id == -1
    finally:
        c.close()
        srv.close()


@pytest.mark.parametrize("coalesce_s", [0.0, 0.005, 0.2])
def test_posts_faster_than_coalesce_arrive_complete_in_order_and_in_time(db, coalesce_s):
    """Posts that follow each other sooner than ``coalesce_s`` share packets, yet every
    one arrives, in posting order, with its own value and stamp; the last of a burst is
    sent by the client's thread without a later post to carry it, and a post after a
    quiet spell is written by the caller's thread before ``notify`` returns. (How soon:
    ``uhrisim bench moos``, ``burst_latency``.)"""
    pub, sub = MoosClient(coalesce_s=coalesce_s), MoosClient()
    try:
        sub.connect("127.0.0.1", db.port, f"co_sub_{int(coalesce_s * 1000)}", strict=True)
        pub.connect("127.0.0.1", db.port, f"co_pub_{int(coalesce_s * 1000)}", strict=True)
        key = f"CO_X_{int(coalesce_s * 1000)}"
        sub.register(key)
        assert wait_until(lambda: (pub.notify(key, -1.0) and False) or any(
            m.key == key for m in sub.drain()), 5.0, 0.05)
        # the handshake's posts may still be on their way (a busy machine: longer than any
        # sleep guessed): a fence posted after them is read last of them, in posting order
        pub.notify(key, -2.0)
        assert wait_until(lambda: any(m.key == key and m.dval == -2.0 for m in sub.drain()),
                          120.0, 0.001)
        time.sleep(max(0.05, 2 * coalesce_s))  # the burst starts after a quiet spell
        got: list[MoosMessage] = []
        for i in range(200):
            pub.notify_many([(key, float(i)), (key + "_S", f"s{i}")], time=1000.0 + i)
        assert wait_until(lambda: got.extend(sub.drain()) or len(got) >= 200, 120.0, 0.001)
        assert [m.dval for m in got] == [float(i) for i in range(200)]
        assert [m.time for m in got] == [1000.0 + i for i in range(200)]
        # a lone post after a quiet spell is written by the caller's thread, at once
        sent = pub.n_sent  # all of it: the burst's last posts have arrived
        time.sleep(coalesce_s + 0.05)  # (at least that long: the spell is quiet)
        pub.notify(key, 1e6)
        assert pub.n_sent == sent + 1  # written before notify returned, not queued
        msgs: list[MoosMessage] = []
        assert wait_until(lambda: msgs.extend(sub.drain()) or bool(msgs), 120.0, 0.0005)
        assert msgs[0].dval == 1e6
        assert pub.dropped_out == 0
    finally:
        pub.close()
        sub.close()
