"""A small MOOSDB in pure Python, for tests, benchmarks and trying the bridge without MOOS.

It speaks the real MOOS v10 protocol (see :mod:`uhrisim.bridges.moos.wire`), with the
behaviour seen in ``tests/data/moos/moos-trace.jsonl``:

* handshake: 32-byte protocol string, then a packet with one ``i`` message whose key is
  ``asynchronous`` (a v10 asynchronous client) or empty (an old synchronous client) and
  whose string value is the client's name. The DB answers ``W`` (welcome: sval
  ``asynchronous`` for async clients, dval = clock skew estimate = DB time - the time in
  the client's message, src_aux ``hostname=...``, community) or ``K`` (poison, with the
  real DB's text ``A client of this name ("NAME") already exists``) when the name is
  already connected. The name is taken when the DB reads it (MOOSCommServer.cpp:956-980),
  before the welcome goes out: with ``welcome_delay_s`` the welcome follows that many
  seconds later, as from a busy DB, while the DB serves everyone else;
* ``R``/``U`` register/unregister a variable; on registration the current value (if any)
  is sent at once; ``*``/``/`` wildcard register/unregister with a string
  ``AppPattern=..,VarPattern=..,Interval=..`` (comma- or space-separated; ``*``/``?`` glob);
* ``N`` notifications are stored and forwarded to every client registered for the
  variable (exact or wildcard), with the DB's community filled in (msg id, source and
  time are kept, as the real DB does);
* ``T`` ``_async_timing``: echoed with dval = DB time, dval2 = 0;
* asynchronous clients are sent notifications as soon as they arrive; synchronous
  clients (e.g. pymoos2) get their queued mail as the reply to each packet they send
  (a single ``.`` null message when there is none);
* ``DB_TIME`` and ``DB_UPTIME`` are posted once per second by ``MOOSDB_<community>``.

Not implemented: registration intervals (every change is forwarded), ``Q`` server
requests, ``C`` commands, compression. Malformed input from a client drops that client.

Run it::

    python -m uhrisim.bridges.moos.testdb --port 9000 --community shoreside

It binds 127.0.0.1 only. :func:`spawn` starts one in a subprocess (tests, benchmarks).
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import logging
import os
import selectors
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field

from uhrisim.bridges.moos.wire import (
    MoosMessage,
    MoosProtocolError,
    MoosStreamParser,
    encode_packet,
)
from uhrisim.core.errors import BridgeError

__all__ = ["MoosTestDB", "TestDBProcess", "main", "spawn"]

log = logging.getLogger(__name__)

_READY_PREFIX = "MOOSDB_LISTENING "


@dataclass
class _Wildcard:
    var_pattern: str
    app_pattern: str
    interval: float


@dataclass
class _Client:
    sock: socket.socket
    addr: str
    parser: MoosStreamParser = field(
        default_factory=lambda: MoosStreamParser(expect_handshake=True))
    name: str | None = None
    asynchronous: bool = True
    registered: dict[str, float] = field(default_factory=dict)
    wildcards: list[_Wildcard] = field(default_factory=list)
    outbuf: bytearray = field(default_factory=bytearray)
    mail: list[MoosMessage] = field(default_factory=list)  # for synchronous clients
    welcome: MoosMessage | None = None  # a welcome still to send (welcome_delay_s)
    welcome_at: float = 0.0  # time.time() at which it goes out

    def wants(self, key: str, source: str) -> bool:
        if key in self.registered:
            return True
        return any(fnmatch.fnmatchcase(key, w.var_pattern)
                   and fnmatch.fnmatchcase(source, w.app_pattern) for w in self.wildcards)


def _parse_wildcard(spec: str) -> _Wildcard:
    fields: dict[str, str] = {}
    for part in spec.replace(",", " ").split():
        k, _, v = part.partition("=")
        fields[k.strip().lower()] = v.strip()
    try:
        interval = float(fields.get("interval", "0") or 0.0)
    except ValueError:
        interval = 0.0
    return _Wildcard(fields.get("varpattern", "*") or "*",
                     fields.get("apppattern", "*") or "*", interval)


class MoosTestDB:
    """A single-threaded MOOSDB serving ``127.0.0.1:port`` (``port=0``: ephemeral);
    ``welcome_delay_s``: seconds between reading a client's name and welcoming it."""

    def __init__(self, port: int = 0, community: str = "uhrisim", host: str = "127.0.0.1",
                 welcome_delay_s: float = 0.0):
        if host not in ("127.0.0.1", "localhost"):
            raise BridgeError(f"MoosTestDB: refusing to bind {host!r}; loopback only")
        if not 0.0 <= welcome_delay_s < 3600.0:
            raise BridgeError(f"MoosTestDB: welcome_delay_s {welcome_delay_s!r} not in [0, 3600)")
        self.community = community
        self.welcome_delay_s = welcome_delay_s
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listener.bind(("127.0.0.1", port))
        self._listener.listen(64)
        self._listener.setblocking(False)
        self.port: int = self._listener.getsockname()[1]
        self._sel = selectors.DefaultSelector()
        self._sel.register(self._listener, selectors.EVENT_READ, None)
        self._clients: dict[socket.socket, _Client] = {}
        self._vars: dict[str, MoosMessage] = {}
        self._start = time.time()
        self._next_db_time = self._start
        self._hostname = socket.gethostname()
        self._running = True
        self.n_forwarded = 0

    # -- public ---------------------------------------------------------------------
    def serve_forever(self) -> None:
        try:
            while self._running:
                self.serve_once(0.1)
        finally:
            self.close()

    def stop(self) -> None:
        self._running = False

    def close(self) -> None:
        for c in list(self._clients.values()):
            self._drop(c, "DB shutting down")
        with contextlib.suppress(Exception):
            self._sel.unregister(self._listener)
        self._listener.close()
        self._sel.close()

    def serve_once(self, timeout: float) -> None:
        now = time.time()
        if now >= self._next_db_time:
            self._post_db_vars(now)
            self._next_db_time = now + 1.0
        due = self._next_db_time
        for client in list(self._clients.values()):
            if client.welcome is not None:
                if now >= client.welcome_at:
                    self._welcome(client)
                else:
                    due = min(due, client.welcome_at)
        for key, mask in self._sel.select(min(timeout, max(0.0, due - now))):
            if key.data is None:
                self._accept()
                continue
            client: _Client = key.data
            if mask & selectors.EVENT_READ:
                self._on_readable(client)
            if mask & selectors.EVENT_WRITE and client.sock in self._clients:
                self._flush(client)

    # -- connection handling ----------------------------------------------------------
    def _accept(self) -> None:
        try:
            sock, addr = self._listener.accept()
        except BlockingIOError:
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        client = _Client(sock, f"{addr[0]}:{addr[1]}")
        self._clients[sock] = client
        self._sel.register(sock, selectors.EVENT_READ, client)

    def _drop(self, client: _Client, why: str) -> None:
        if client.sock not in self._clients:
            return
        log.info("MOOSDB: dropping %s (%s): %s", client.name, client.addr, why)
        del self._clients[client.sock]
        with contextlib.suppress(Exception):
            self._sel.unregister(client.sock)
        client.sock.close()

    def _on_readable(self, client: _Client) -> None:
        try:
            data = client.sock.recv(1 << 16)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._drop(client, f"recv failed: {exc}")
            return
        if not data:
            self._drop(client, "closed by peer")
            return
        try:
            packets = client.parser.feed(data)
            for pkt in packets:
                self._on_packet(client, pkt.messages)
        except MoosProtocolError as exc:
            self._drop(client, str(exc))

    def _send(self, client: _Client, msgs: list[MoosMessage]) -> None:
        client.outbuf += encode_packet(msgs)
        self._flush(client)

    def _flush(self, client: _Client) -> None:
        if client.outbuf:
            try:
                n = client.sock.send(client.outbuf)
                del client.outbuf[:n]
            except (BlockingIOError, InterruptedError):
                pass
            except OSError as exc:
                self._drop(client, f"send failed: {exc}")
                return
        events = selectors.EVENT_READ | (selectors.EVENT_WRITE if client.outbuf else 0)
        self._sel.modify(client.sock, events, client)

    def _deliver(self, client: _Client, msgs: list[MoosMessage]) -> None:
        if not msgs:
            return
        if client.asynchronous:
            self._send(client, msgs)
        else:
            client.mail.extend(msgs)

    # -- protocol -------------------------------------------------------------------------
    def _on_packet(self, client: _Client, msgs: tuple[MoosMessage, ...]) -> None:
        if client.name is None:
            self._on_handshake(client, msgs)
            return
        replies: list[MoosMessage] = []
        for m in msgs:
            t = m.msg_type
            if t == "N":
                self._on_notify(m)
            elif t == "R":
                client.registered[m.key] = m.dval
                cur = self._vars.get(m.key)
                if cur is not None:
                    replies.append(cur)
            elif t == "U":
                client.registered.pop(m.key, None)
            elif t == "*":
                w = _parse_wildcard(m.string)
                client.wildcards.append(w)
                replies.extend(v for k, v in self._vars.items()
                               if fnmatch.fnmatchcase(k, w.var_pattern)
                               and fnmatch.fnmatchcase(v.source, w.app_pattern))
            elif t == "/":
                w = _parse_wildcard(m.string)
                client.wildcards = [x for x in client.wildcards
                                    if (x.var_pattern, x.app_pattern)
                                    != (w.var_pattern, w.app_pattern)]
            elif t == "T":
                replies.append(MoosMessage(-1, "T", "D", "", "", "", m.key or "_async_timing",
                                           m.time, time.time(), 0.0, b""))
            elif t == "^":
                self._drop(client, "terminate requested")
                return
            # '.', 'Q', 'C', ... : nothing to do
        if client.asynchronous:
            self._deliver(client, replies)
        else:
            out = client.mail + replies
            client.mail = []
            self._send(client, out or [MoosMessage(-1, ".", "D", "", "", "", "", time.time())])

    def _on_handshake(self, client: _Client, msgs: tuple[MoosMessage, ...]) -> None:
        if len(msgs) != 1 or msgs[0].msg_type != "i":
            self._send(client, [MoosMessage(-1, "K", "S", "", "", self.community, "",
                                            time.time(), -1.0, -1.0, b"expected a handshake")])
            self._drop(client, "bad handshake")
            return
        hello = msgs[0]
        name = hello.string
        if any(c.name == name for c in self._clients.values()):
            self._send(client, [MoosMessage(
                -1, "K", "S", "", "", self.community, "", time.time(), -1.0, -1.0,
                f'A client of this name ("{name}") already exists'.encode())])
            self._drop(client, f"duplicate name {name!r}")
            return
        client.name = name
        client.asynchronous = hello.key == "asynchronous"
        now = time.time()
        skew = now - hello.time if hello.time > 0 else 0.0
        client.welcome = MoosMessage(
            -1, "W", "D", "", f"hostname={self._hostname}", self.community, "", now, skew, -1.0,
            b"asynchronous" if client.asynchronous else b"")
        client.welcome_at = now + self.welcome_delay_s
        if not self.welcome_delay_s:
            self._welcome(client)

    def _welcome(self, client: _Client) -> None:
        assert client.welcome is not None
        self._send(client, [client.welcome])
        client.welcome = None
        log.info("MOOSDB: %s connected (%s, %s)", client.name, client.addr,
                 "asynchronous" if client.asynchronous else "synchronous")

    def _on_notify(self, m: MoosMessage) -> None:
        fwd = MoosMessage(m.msg_id, "N", m.data_type, m.source, m.source_aux, self.community,
                          m.key, m.time, m.dval, m.dval2, m.sval)
        self._vars[m.key] = fwd
        for c in list(self._clients.values()):
            if c.name is not None and c.wants(m.key, m.source):
                self._deliver(c, [fwd])
                self.n_forwarded += 1

    def _post_db_vars(self, now: float) -> None:
        src = f"MOOSDB_{self.community}"
        self._on_notify(MoosMessage.notify("DB_TIME", now, now, src))
        self._on_notify(MoosMessage.notify("DB_UPTIME", now - self._start, now, src))
        names = ",".join(sorted(c.name for c in self._clients.values() if c.name))
        self._on_notify(MoosMessage.notify("DB_CLIENTS", names, now, src))


@dataclass
class TestDBProcess:
    """A test MOOSDB running in a child process (see :func:`spawn`)."""

    __test__ = False  # not a pytest test class
    proc: subprocess.Popen
    port: int

    def kill(self) -> None:
        """SIGKILL: the DB vanishes without closing its sockets politely."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(5.0)

    def terminate(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5.0)

    def __enter__(self) -> TestDBProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.terminate()


def spawn(port: int = 0, community: str = "uhrisim", timeout_s: float = 60.0,
          welcome_delay_s: float = 0.0) -> TestDBProcess:
    """Start ``python -m uhrisim.bridges.moos.testdb`` in a child process on 127.0.0.1.

    ``port=0`` picks a free port; the child reports it on its first stdout line. Raises
    :class:`BridgeError` if the DB is not listening within ``timeout_s`` (a bound for a
    busy machine: the child reports as soon as it listens).
    """
    env = dict(os.environ)
    src_root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src_root, env.get("PYTHONPATH")) if p)
    proc = subprocess.Popen(
        [sys.executable, "-m", "uhrisim.bridges.moos.testdb", "--port", str(port),
         "--community", community, "--welcome-delay", repr(welcome_delay_s)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    sel = selectors.DefaultSelector()
    assert proc.stdout is not None
    sel.register(proc.stdout, selectors.EVENT_READ)
    ok = sel.select(timeout_s)
    sel.close()
    line = proc.stdout.readline() if ok else ""
    if not line.startswith(_READY_PREFIX):
        proc.kill()
        proc.wait(5.0)
        raise BridgeError(f"test MOOSDB on port {port} did not start (got {line.strip()!r})")
    return TestDBProcess(proc, int(line[len(_READY_PREFIX):]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m uhrisim.bridges.moos.testdb",
                                 description="A small pure-Python MOOSDB on 127.0.0.1.")
    ap.add_argument("--port", type=int, default=9000, help="TCP port (0: any free port)")
    ap.add_argument("--community", default="uhrisim", help="community name")
    ap.add_argument("--welcome-delay", type=float, default=0.0, metavar="S",
                    help="welcome each client S seconds after reading its name (a busy DB)")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(asctime)s %(name)s %(message)s")
    db = MoosTestDB(args.port, args.community, welcome_delay_s=args.welcome_delay)
    signal.signal(signal.SIGTERM, lambda *_: db.stop())
    sys.stdout.write(f"{_READY_PREFIX}{db.port}\n")
    sys.stdout.flush()
    with contextlib.suppress(KeyboardInterrupt):
        db.serve_forever()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
