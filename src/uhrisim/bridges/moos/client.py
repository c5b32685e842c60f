"""A pure-Python asynchronous MOOS v10 client on a background thread.

What it does, in MOOS terms (MOOSAsyncCommClient): it connects to a MOOSDB over TCP, sends
the 32-byte handshake and an ``i`` message with key ``asynchronous`` and its name, waits
for ``W`` (welcome) or ``K`` (poison), then both sides write whenever they like. Every
``timing_period_s`` it sends an ``_async_timing`` ``T`` message as v10 clients do; the
DB's ``T`` replies are read and ignored. Notifications (``N``) the DB pushes land in a
thread-safe inbox that the caller empties with :meth:`MoosClient.drain`.

Never blocking the caller: :meth:`notify`, :meth:`register` and :meth:`drain` only take a
short lock. While connected with nothing queued, a notification's packet is written at
once by the caller's thread with one non-blocking ``send`` (a loopback TCP write of a
few microseconds); otherwise (a queue still being flushed, a full socket buffer, a
send error) it joins the queue and a wake-up socket pokes the client's thread, which
does all other network I/O (connecting, reading, timing, the rest of a partial write).
Either way the order of the posts is kept and no call waits on the network; waking the
client's thread for every post would cost far more (a thread switch and a wait for
the GIL). When the DB goes away the thread reconnects with exponential backoff
(``reconnect_min_s`` doubling up to ``reconnect_max_s``), performs the handshake again and
re-registers every variable.

A busy MOOSDB may take seconds to welcome a client, and MOOS's own clients wait for the
welcome without a time limit (CMOOSCommClient::HandShake reads it with no timeout); this
client waits ``welcome_timeout_s`` (30 s by default) before it gives a connection up. A
connection given up too soon is still held by the DB under the client's name until the
DB notices it closed, and the DB refuses the next one ("A client of this name already
exists", a ``K`` reply): the client says so once, counts it in :attr:`n_refusals` and
keeps retrying with backoff until the name is free. :attr:`n_attempts` counts every TCP
connection tried, :attr:`n_connects` every welcomed one.

Notifications while disconnected: the **latest value per variable** is kept (older ones
are replaced) and sent, after the re-registrations, once the client is connected again.
While connected, the outgoing queue is bounded (``max_outbox`` messages; the oldest are
dropped and counted in :attr:`dropped_out`); a DB that stops reading for more than
``max_send_buffer`` bytes is treated as dead (the connection is dropped and re-made).

MOOS time (``MOOSLocalTime`` in MOOS v10 ``MOOSUtilityFunctions.cpp``) is
``wall-clock seconds since the epoch x MOOSTimeWarp`` (+ the DB's skew estimate when
``apply_skew`` is set). Every process of a warped MOOS community uses this definition,
so notification times, NODE_REPORT TIME and the helm's clock agree.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import selectors
import socket
import threading
import time
from collections.abc import Callable, Iterable
from time import monotonic as time_now

from uhrisim.bridges.moos.wire import (
    HANDSHAKE,
    MoosMessage,
    MoosProtocolError,
    MoosStreamParser,
    NotifyEncoder,
    encode_message,
    encode_packet,
    encode_packet_raw,
)
from uhrisim.core.errors import BridgeError

__all__ = ["MoosClient"]

log = logging.getLogger(__name__)

#: Largest accepted MOOSTimeWarp (a sanity bound; MOOS itself only requires warp > 0).
_MAX_WARP = 1000.0
#: How often a wait for the DB's welcome looks whether the client was closed (s).
_STOP_POLL_S = 0.25


class _NameRefusedError(BridgeError):
    """The DB answered the handshake with poison (``K``): it refused the client's name."""


class MoosClient:
    """Asynchronous MOOS client. Create, :meth:`connect`, then notify/register/drain.

    Parameters
    ----------
    time_warp:
        MOOSTimeWarp of the community (> 0). MOOS time = wall clock x warp.
    apply_skew:
        Add the DB's clock-skew estimate (welcome message dval) to MOOS time, as C++ MOOS
        clients do with local time correction on. Off by default: on one machine the
        "skew" is only the handshake latency.
    reconnect_min_s, reconnect_max_s:
        Reconnection backoff (wall-clock seconds), doubling from min to max.
    connect_timeout_s:
        TCP connect wait per attempt (wall-clock seconds).
    welcome_timeout_s:
        How long an accepted connection waits for the DB's welcome (wall-clock seconds).
    timing_period_s:
        Period of ``_async_timing`` messages (wall-clock seconds).
    coalesce_s:
        Shortest wall-clock time between two packets of notifications (default 0: every
        post is written at once, as MOOS v10 clients do). With ``coalesce_s > 0`` a post
        that comes sooner after the last packet waits, with those that follow it, until
        that time has passed, then they go out together in one packet (sent by the next
        post or by the client's thread, whichever comes first); a post that comes later
        goes out at once. For a slow DB fed by a simulation running far faster than real
        time (fewer packets, each write also wakes the DB). Not a saving for the
        simulation itself: on the free-running mission benchmark a 20 ms window saved
        a few percent at best and a 5 ms one cost more than it saved (every flush by the
        client's thread takes the GIL from the simulation's thread).
    max_outbox, max_inbox:
        Bounds of the outgoing and incoming queues (messages); the oldest are dropped.
    max_send_buffer:
        Bytes written but not taken by the DB before the connection is declared dead.
    wall_clock:
        Seconds since the Unix epoch (injectable for tests).
    """

    def __init__(
        self,
        *,
        time_warp: float = 1.0,
        apply_skew: bool = False,
        reconnect_min_s: float = 0.05,
        reconnect_max_s: float = 1.0,
        connect_timeout_s: float = 1.0,
        welcome_timeout_s: float = 30.0,
        timing_period_s: float = 1.0,
        coalesce_s: float = 0.0,
        max_outbox: int = 100_000,
        max_inbox: int = 100_000,
        max_send_buffer: int = 16 * 1024 * 1024,
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        if not (0.0 < time_warp <= _MAX_WARP):
            raise BridgeError(f"MOOS client: time_warp {time_warp} not in (0, {_MAX_WARP}]")
        self.time_warp = float(time_warp)
        self.apply_skew = apply_skew
        self._rmin = reconnect_min_s
        self._rmax = reconnect_max_s
        self._ctimeout = connect_timeout_s
        self._welcome_timeout = welcome_timeout_s
        self._timing_period = timing_period_s
        if not coalesce_s >= 0.0:
            raise BridgeError(f"MOOS client: coalesce_s {coalesce_s!r} must be >= 0")
        self._coalesce = float(coalesce_s)
        self._last_send = -float("inf")  # monotonic time of the last packet written
        self._flush_armed = False  # the client thread will flush the queue by itself
        self._max_send_buffer = max_send_buffer
        self._wall = wall_clock

        self.host = "127.0.0.1"
        self.port = 9000
        self.name = "uhrisim"
        self._encode_notify = NotifyEncoder(self.name)

        self._lock = threading.Lock()
        # outgoing messages, already serialised: (variable for notifications else None, bytes)
        self._outbox: collections.deque[tuple[str | None, bytes]] = collections.deque(
            maxlen=max_outbox)
        self._latest_down: dict[str, bytes] = {}
        self._inbox: collections.deque[MoosMessage] = collections.deque(maxlen=max_inbox)
        self._registrations: dict[str, float] = {}
        self._next_id = 0
        self._wake_pending = False
        # the connected socket and the bytes not yet written to it, shared by the caller's
        # direct sends and the client thread; both only under self._lock
        self._sock: socket.socket | None = None
        self._sendbuf = bytearray()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)

        self._stop = threading.Event()
        self._connected_evt = threading.Event()
        self._attempted_evt = threading.Event()
        self._thread: threading.Thread | None = None
        self._parser = MoosStreamParser()

        self._connected = False
        self.community: str | None = None
        self.skew = 0.0
        self.last_error: str | None = None
        self._status = "not started"
        self.n_attempts = 0
        self.n_connects = 0
        self.n_refusals = 0
        self.dropped_out = 0
        self.dropped_in = 0
        self.n_sent = 0
        self.n_received = 0

    # -- state ------------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        """True while a welcomed connection to the DB is up."""
        return self._connected

    @property
    def status(self) -> str:
        """One line: connection state, and the last error if there is one."""
        s = self._status
        return f"{s} (last error: {self.last_error})" if self.last_error else s

    def moos_time(self) -> float:
        """MOOS time now: wall-clock epoch seconds x time warp (+ skew if applied)."""
        return self._wall() * self.time_warp + (self.skew if self.apply_skew else 0.0)

    # -- lifecycle --------------------------------------------------------------------
    def connect(
        self,
        host: str = "127.0.0.1",
        port: int = 9000,
        name: str = "uhrisim",
        *,
        strict: bool = False,
        timeout_s: float = 3.0,
    ) -> None:
        """Start the client thread, connecting to ``host:port`` as ``name``.

        Non-strict (default): returns at once; the thread keeps trying (with backoff) and
        logs. Strict: waits until connected, or until the first attempt fails, or
        ``timeout_s``; raises :class:`BridgeError` (and stops the thread) if not connected.
        """
        if self._thread is not None:
            raise BridgeError(f"MOOS client {self.name!r}: connect() called twice")
        if not name or any(ch.isspace() for ch in name):
            raise BridgeError(f"MOOS client: invalid name {name!r} (non-empty, no spaces)")
        self.host, self.port, self.name = host, int(port), name
        self._encode_notify = NotifyEncoder(name)
        self._status = f"connecting to {host}:{port}"
        self._thread = threading.Thread(target=self._run, name=f"moos-{name}", daemon=True)
        self._thread.start()
        if strict:
            deadline = time.monotonic() + timeout_s
            while time.monotonic() < deadline and not self._connected_evt.is_set():
                if self._attempted_evt.wait(0.01) and not self._connected_evt.is_set():
                    break
            if not self._connected_evt.is_set():
                err = self.last_error or f"no welcome within {timeout_s:.1f} s"
                self.close()
                raise BridgeError(
                    f"MOOS: cannot connect to MOOSDB at {host}:{port} as {name!r}: {err}")

    def wait_connected(self, timeout_s: float) -> bool:
        """Block up to ``timeout_s`` for a connection (for scripts and tests)."""
        return self._connected_evt.wait(timeout_s)

    def close(self) -> None:
        """Stop the thread and close the connection (idempotent)."""
        self._stop.set()
        self._wake()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(5.0)
        self._connected = False
        self._status = "closed"
        for s in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                s.close()

    def __enter__(self) -> MoosClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- caller API (never blocks on I/O) -----------------------------------------------
    def register(self, var: str, interval: float = 0.0) -> None:
        """Subscribe to ``var`` (minimum interval ``interval`` s; 0 = every change).

        Remembered: re-sent after every reconnection.
        """
        with self._lock:
            self._registrations[var] = float(interval)
            if self._connected:
                self._outbox.append((None, self._make_register(var, float(interval))))
        self._wake()

    def unregister(self, var: str) -> None:
        with self._lock:
            self._registrations.pop(var, None)
            if self._connected:
                self._outbox.append((None, encode_message(MoosMessage(
                    self._new_id(), "U", "D", self.name, "", "", var, self.moos_time(), 0.0,
                    -1.0))))
        self._wake()

    def notify(self, var: str, value: float | str | bytes, time: float | None = None) -> bool:
        """Post ``var = value`` stamped with MOOS ``time`` (default: :meth:`moos_time`).

        Returns True if queued for sending now, False if the client is disconnected (the
        value then replaces any older one of ``var`` and is sent after reconnection).
        """
        return self.notify_many([(var, value)], time)

    def notify_many(
        self, items: Iterable[tuple[str, float | str | bytes]], time: float | None = None
    ) -> bool:
        """Post several variables with one time stamp in one packet (one lock, at most
        one ``send`` or one wake-up)."""
        t = self.moos_time() if time is None else float(time)
        wake = False
        with self._lock:
            enc, i0 = self._encode_notify, self._next_id  # ids as _new_id() gives them
            msgs = [(k, enc(k, v, t, (i0 + j) & 0x7FFFFFFF)) for j, (k, v) in enumerate(items)]
            self._next_id = (i0 + len(msgs)) & 0x7FFFFFFF
            up = self._connected
            if not up:
                self._latest_down.update(msgs)
            elif self._sock is None or self._sendbuf or len(self._outbox) + len(msgs) > (
                    self._outbox.maxlen or 0) // 2:
                # not serving yet, a partial write pending, or a large backlog: the thread
                free = self._outbox.maxlen - len(self._outbox)  # type: ignore[operator]
                if len(msgs) > free:
                    self.dropped_out += len(msgs) - free
                self._outbox.extend(msgs)
                wake = True
            elif time_now() - self._last_send >= self._coalesce:
                if self._outbox:  # what waited for this packet goes first
                    msgs[:0] = self._outbox
                    self._outbox.clear()
                wake = self._send_direct(msgs)
            else:  # too soon after the last packet: wait for the next one
                self._outbox.extend(msgs)
                wake = not self._flush_armed  # the thread must know, to flush in time
                self._flush_armed = True
        if wake:
            self._wake()
        return up

    def _send_direct(self, msgs: list[tuple[str | None, bytes]]) -> bool:
        """Write ``msgs`` as one packet now, from the caller's thread (lock held, nothing
        queued before them). Returns True when the client thread must be woken: the
        socket took only part (the rest waits in the send buffer for the thread) or
        failed (the messages go back to the queue, so the thread keeps the latest value
        of each variable for the reconnection when it finds the connection dead)."""
        assert self._sock is not None
        self._last_send = time_now()
        packet = encode_packet_raw([data for _, data in msgs])
        try:
            n = self._sock.send(packet)
        except (BlockingIOError, InterruptedError):
            n = 0
        except OSError:
            self._outbox.extend(msgs)
            return True
        self.n_sent += len(msgs)
        if n == len(packet):
            return False
        self._sendbuf += memoryview(packet)[n:]
        return True

    @property
    def has_mail(self) -> bool:
        """True when :meth:`drain` would return something (a lock-free look)."""
        return bool(self._inbox)

    def drain(self) -> list[MoosMessage]:
        """Return and clear every notification received since the last call (oldest first)."""
        if not self._inbox:  # the common case, without the lock (a deque's length is atomic)
            return []
        with self._lock:
            out = list(self._inbox)
            self._inbox.clear()
        return out

    # -- internals ------------------------------------------------------------------------
    def _new_id(self) -> int:
        i = self._next_id
        self._next_id = (i + 1) & 0x7FFFFFFF
        return i

    def _make_register(self, var: str, interval: float) -> bytes:
        return encode_message(MoosMessage.register(var, interval, self.moos_time(), self.name,
                                                   msg_id=self._new_id()))

    def _wake(self) -> None:
        if self._wake_pending:
            return
        self._wake_pending = True
        with contextlib.suppress(OSError):
            self._wake_w.send(b"\x00")

    def _run(self) -> None:
        backoff = self._rmin
        told: set[str] = set()  # kinds of failure already logged since the last welcome
        while not self._stop.is_set():
            sock: socket.socket | None = None
            try:
                sock = self._handshake()
                backoff = self._rmin
                if told:
                    log.warning("MOOS client %r: connected to %s:%d (attempt %d)",
                                self.name, self.host, self.port, self.n_attempts)
                told.clear()
                self._serve(sock)
            except _NameRefusedError as exc:
                self.last_error = f"refused: {exc}"
                if "refused" not in told:
                    told.add("refused")
                    log.warning("MOOS client %r: MOOSDB at %s:%d refused the name: %s - it "
                                "still holds a connection of that name (an earlier one of "
                                "ours it has not yet seen closed, or another process); "
                                "retrying with backoff", self.name, self.host, self.port, exc)
            except (OSError, BridgeError) as exc:
                self.last_error = f"{type(exc).__name__}: {exc}"
                if self._connected:
                    log.warning("MOOS client %r: connection to %s:%d lost: %s",
                                self.name, self.host, self.port, exc)
                elif "failed" not in told:
                    told.add("failed")
                    log.warning("MOOS client %r: cannot connect to MOOSDB at %s:%d (%s); "
                                "retrying", self.name, self.host, self.port, exc)
                else:
                    log.debug("MOOS client %r: retry failed: %s", self.name, exc)
            finally:
                with self._lock:  # the state and its line change together
                    self._connected = False
                    self._status = f"disconnected from {self.host}:{self.port}"
                    # unsent notifications: keep the latest per variable for the reconnect
                    for key, data in self._outbox:
                        if key is not None:
                            self._latest_down[key] = data
                    self._outbox.clear()
                self._connected_evt.clear()
                self._attempted_evt.set()
                if sock is not None:
                    with contextlib.suppress(OSError):
                        sock.close()
            if self._stop.is_set():
                break
            self._status = f"disconnected; retrying {self.host}:{self.port} in {backoff:.2f} s"
            self._stop.wait(backoff)
            backoff = min(self._rmax, backoff * 2.0)

    def _handshake(self) -> socket.socket:
        self.n_attempts += 1
        sock = socket.create_connection((self.host, self.port), timeout=self._ctimeout)
        try:
            return self._welcomed(sock)
        except BaseException:
            sock.close()
            raise

    def _welcomed(self, sock: socket.socket) -> socket.socket:
        """Say hello on ``sock`` and wait (up to ``welcome_timeout_s``, while not closed)
        for the DB's welcome; the connection made ready to serve."""
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        hello = MoosMessage(-1, "i", "S", "", "", "", "asynchronous", self.moos_time(),
                            -1.0, -1.0, self.name.encode())
        sock.sendall(HANDSHAKE + encode_packet([hello]))
        self._status = f"waiting for the welcome of {self.host}:{self.port}"
        parser = MoosStreamParser()
        deadline = time.monotonic() + self._welcome_timeout
        packets = []
        while not packets:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise BridgeError(f"MOOSDB sent no welcome within {self._welcome_timeout:g} s")
            if self._stop.is_set():
                raise BridgeError("closed while waiting for the welcome")
            sock.settimeout(min(remaining, _STOP_POLL_S))
            try:
                data = sock.recv(65536)
            except TimeoutError:
                continue
            if not data:
                raise BridgeError("MOOSDB closed the connection during the handshake")
            packets = parser.feed(data)
        first = packets[0].messages[0] if packets[0].messages else None
        if first is None or first.msg_type == "K":
            self.n_refusals += 1
            raise _NameRefusedError(first.string if first is not None else "empty reply")
        if first.msg_type != "W":
            raise MoosProtocolError(f"MOOS handshake: expected W or K, got {first.msg_type!r}")
        if first.string != "asynchronous":
            raise BridgeError("MOOSDB does not support asynchronous clients (MOOS < v10)")
        self.community = first.community
        self.skew = first.dval
        sock.setblocking(False)
        with self._lock:  # the state and its line change together
            self._connected = True
            self._status = (f"connected to {self.host}:{self.port} as {self.name!r} "
                            f"(community {self.community!r})")
            self.n_connects += 1
            # registrations first, then the latest values posted while we were away
            pending: list[tuple[str | None, bytes]] = [
                (None, self._make_register(v, i)) for v, i in self._registrations.items()]
            pending.extend(self._latest_down.items())
            self._latest_down.clear()
            self._outbox.extendleft(reversed(pending))
        self.last_error = None
        self._connected_evt.set()
        self._attempted_evt.set()
        log.info("MOOS client %r: %s", self.name, self._status)
        # packets that arrived together with the welcome
        for p in packets[1:]:
            self._on_messages(p.messages)
        self._parser = parser
        return sock

    def _on_messages(self, msgs: tuple[MoosMessage, ...]) -> None:
        notes = [m for m in msgs if m.msg_type == "N"]
        for m in msgs:
            if m.msg_type == "K":
                raise BridgeError(f"MOOSDB sent poison: {m.string}")
            if m.msg_type == "^":
                raise BridgeError("MOOSDB asked us to terminate")
        if notes:
            with self._lock:
                free = self._inbox.maxlen - len(self._inbox)  # type: ignore[operator]
                if len(notes) > free:
                    self.dropped_in += len(notes) - free
                self._inbox.extend(notes)
                self.n_received += len(notes)

    def _serve(self, sock: socket.socket) -> None:
        sel = selectors.DefaultSelector()
        parser = self._parser
        next_timing = time.monotonic()
        sendbuf = self._sendbuf
        try:
            sel.register(sock, selectors.EVENT_READ)
            sel.register(self._wake_r, selectors.EVENT_READ)
            with self._lock:
                sendbuf.clear()
                self._flush_armed = False  # what the handshake queued goes out at once
                self._sock = sock  # callers may now write their posts directly
            want_write = False
            while not self._stop.is_set():
                now = time.monotonic()
                with self._lock:
                    if now >= next_timing:
                        sendbuf += encode_packet([MoosMessage(
                            -1, "T", "D", "", "", "", "_async_timing", self.moos_time(), 0.0,
                            -1.0)])
                        next_timing = now + self._timing_period
                    # collect outgoing mail, no sooner than coalesce_s after the last packet
                    self._wake_pending = False
                    flush_at = self._last_send + self._coalesce
                    if self._outbox and (now >= flush_at or not self._flush_armed):
                        out = [data for _, data in self._outbox]
                        self._outbox.clear()
                        sendbuf += encode_packet_raw(out)
                        self.n_sent += len(out)
                        self._last_send = now
                    self._flush_armed = bool(self._outbox)
                    wait_until = flush_at if self._outbox else next_timing
                    if sendbuf:
                        try:
                            n = sock.send(sendbuf)
                            del sendbuf[:n]
                        except (BlockingIOError, InterruptedError):
                            pass
                    backlog = len(sendbuf)
                if backlog > self._max_send_buffer:
                    raise BridgeError(f"MOOSDB is not reading ({backlog} bytes backed up)")
                if bool(backlog) != want_write:
                    want_write = bool(backlog)
                    sel.modify(sock, selectors.EVENT_READ
                               | (selectors.EVENT_WRITE if want_write else 0))
                timeout = max(0.0, min(next_timing, wait_until) - time.monotonic())
                for key, _mask in sel.select(timeout):
                    if key.fileobj is self._wake_r:
                        with contextlib.suppress(BlockingIOError, InterruptedError):
                            self._wake_r.recv(4096)
                    elif _mask & selectors.EVENT_READ:
                        try:
                            data = sock.recv(1 << 16)
                        except (BlockingIOError, InterruptedError):
                            continue
                        if not data:
                            raise BridgeError("MOOSDB closed the connection")
                        for p in parser.feed(data):
                            self._on_messages(p.messages)
        finally:
            with self._lock:
                self._sock = None
                sendbuf.clear()
            sel.close()
