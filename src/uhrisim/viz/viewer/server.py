"""The live web viewer's server: one background thread, an asyncio loop, a websocket.

The simulation thread only calls :meth:`ViewerServer.publish` (stores a reference, well
under a microsecond) and :meth:`ViewerServer.drain_commands`. Everything costly — JSON
encoding of frames, PNG encoding of sonar fans, the sockets — happens in the server
thread, at most ``max_fps`` times per second, and only for the latest frame: frames
published in between are skipped ("latest frame wins"). Each browser has its own send
task, so a slow browser gets fewer frames and never delays the simulation or the others.

Static page files (HTML/JS/CSS and the vendored three.js) are served from the package by
the same socket (plain HTTP GET answered in ``process_request``); the page opens the
websocket at ``/ws``. Nothing is fetched from the network. The server binds loopback
only (house rule: 127.0.0.1).
"""

from __future__ import annotations

import asyncio
import contextlib
import gzip
import importlib.util
import json
import logging
import math
import re
import threading
from collections import deque
from collections.abc import Callable
from http import HTTPStatus
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

from uhrisim.core.errors import ConfigError, MissingExtraError, UhrisimError
from uhrisim.viz.viewer.protocol import (
    Command,
    encode_json,
    encode_png_b64,
    parse_command,
    validate_buttons,
)

if TYPE_CHECKING:
    from websockets.asyncio.server import ServerConnection
    from websockets.http11 import Request, Response

log = logging.getLogger(__name__)

_B64 = re.compile(r"[A-Za-z0-9+/=]*")

LOOPBACK_HOSTS = frozenset({"127.0.0.1", "localhost", "::1"})

_CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".png": "image/png",
    ".LICENSE": "text/plain; charset=utf-8",
}


def _host_of(authority: str) -> str:
    """Host name of ``host[:port]`` / ``[v6]:port`` (lower case, brackets removed)."""
    a = authority.strip().lower()
    if a.startswith("["):
        return a[1 : a.find("]")] if "]" in a else a
    return a.rsplit(":", 1)[0] if a.count(":") == 1 else a


def _is_loopback_authority(authority: str) -> bool:
    return _host_of(authority) in LOOPBACK_HOSTS


def _is_loopback_origin(origin: str) -> bool:
    scheme, _, rest = origin.partition("://")
    return scheme in ("http", "https") and _is_loopback_authority(rest.split("/", 1)[0])


def _load_static() -> dict[str, tuple[bytes, str]]:
    """Read the page assets shipped in ``uhrisim/viz/viewer/static`` (name → bytes, type)."""
    out: dict[str, tuple[bytes, str]] = {}
    root = resources.files("uhrisim.viz.viewer") / "static"
    for entry in root.iterdir():
        name = entry.name
        ext = "." + name.rsplit(".", 1)[-1] if "." in name else ""
        ctype = _CONTENT_TYPES.get(ext)
        if ctype is None or not entry.is_file():
            continue
        out[name] = (entry.read_bytes(), ctype)
    if "index.html" not in out:
        raise UhrisimError("viewer page assets missing: uhrisim/viz/viewer/static/index.html")
    return out


class ViewerServer:
    """Serve the viewer page on ``http://host:port/`` and stream frames to it.

    Parameters
    ----------
    scene:
        Static scene, sent once to each page on connect (schema in docs/viewer.md;
        positions NED metres).
    buttons:
        Scenario buttons ``[{"label", "agent", "var", "value"}]``; a click posts
        ``Command(kind="post", agent, name=var, value)``.
    host:
        Loopback address to bind (127.0.0.1, localhost or ::1; anything else is refused).
    port:
        TCP port; 0 picks a free one (read the URL returned by :meth:`start`).
    max_fps:
        Upper bound on frames per second sent to each page.
    max_sonar_fps:
        Upper bound on sonar fans PNG-encoded and sent per second, per agent (the
        newest ping wins; a real imaging sonar pings at 5–15 Hz).
    sonar_max_px:
        Fans larger than this (pixels, larger side) are shrunk for display before
        encoding (the sonar panel is about 380 px wide); None sends them full size.
    history_period, history_len:
        Trail history kept by the server (one point per ``history_period`` seconds of
        simulation time, at most ``history_len`` per agent) so a page that connects late
        still draws trails.
    """

    def __init__(
        self,
        scene: dict[str, Any],
        buttons: list[dict[str, Any]],
        host: str = "127.0.0.1",
        port: int = 8765,
        max_fps: float = 20.0,
        *,
        max_sonar_fps: float = 10.0,
        sonar_max_px: int | None = 400,
        history_period: float = 0.5,
        history_len: int = 4000,
    ) -> None:
        if host not in LOOPBACK_HOSTS:
            raise ConfigError(f"viewer binds loopback only, got host {host!r}", "viewer host")
        if not (isinstance(port, int) and 0 <= port <= 65535):
            raise ConfigError(f"port must be an integer in 0..65535, got {port!r}", "viewer port")
        if not (math.isfinite(max_fps) and max_fps > 0):
            raise ConfigError(f"max_fps must be > 0, got {max_fps!r}", "viewer max_fps")
        if not max_sonar_fps > 0:
            raise ConfigError(f"max_sonar_fps must be > 0, got {max_sonar_fps!r}",
                              "viewer max_sonar_fps")
        self._sonar_period = 1.0 / float(max_sonar_fps)
        self._sonar_max_px = sonar_max_px
        self._sonar_time: dict[str, float] = {}
        self.host = host
        self.port = port
        self.max_fps = float(max_fps)
        self.mode = "live"
        self._scene = scene
        self._buttons = validate_buttons(buttons)
        self._static = _load_static()
        self._gzipped: dict[str, bytes] = {}
        self._history_period = float(history_period)
        self._history: dict[str, deque[list[float]]] = {}
        self._history_len = int(history_len)
        # --- shared with the simulation thread (single stores only; see publish) ---
        self._latest: tuple[int, dict[str, Any]] | None = None
        self._seq = 0
        self._sonar_lock = threading.Lock()
        self._sonar: dict[str, tuple[int, dict[str, Any]]] = {}
        self._commands: deque[Command] = deque(maxlen=10_000)
        # --- server thread state ---
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._started = threading.Event()
        self._start_error: BaseException | None = None
        self._url: str | None = None
        self._clients: set[ServerConnection] = set()
        self._cond: asyncio.Condition | None = None
        self._generation = 0
        self._frame_seq = -1
        self._frame_text: str | None = None
        self._sonar_text: dict[str, tuple[int, str]] = {}
        self._hello_extra: dict[str, Any] = {}
        # hooks for replay: called in the server thread once per producer cycle
        self._tick_hook: Callable[[float], None] | None = None
        self._command_hook: Callable[[Command | dict[str, Any]], bool] | None = None
        #: the ReplayPlayer driving this server in replay mode (None when live)
        self.player: Any = None
        # counters (read by the benchmark and tests)
        #: number of the latest published frame the server thread has taken in (publish()
        #: numbers frames 1, 2, …); frames published in between were skipped
        self.processed_seq = 0
        self.frames_encoded = 0
        self.frames_sent = 0
        self.sonars_encoded = 0
        self.cameras_encoded = 0

    # ------------------------------------------------------------------ sim-side API
    @property
    def url(self) -> str | None:
        """``http://host:port/`` once started, else None."""
        return self._url

    def start(self, timeout: float = 10.0) -> str:
        """Start the background thread and return the page URL (idempotent)."""
        if self._url is not None:
            return self._url
        if self._started.is_set():
            raise UhrisimError("viewer server was closed or failed to start; make a new one")
        if importlib.util.find_spec("websockets") is None:
            raise MissingExtraError(
                "the viewer needs the 'websockets' package: pip install \"uhrisim[viewer]\""
            )
        self._thread = threading.Thread(target=self._run, name="uhrisim-viewer", daemon=True)
        self._thread.start()
        if not self._started.wait(timeout):
            raise UhrisimError(f"viewer did not start within {timeout} s on {self.host}")
        if self._start_error is not None:
            err = self._start_error
            self._thread.join(timeout)
            self._thread = None
            raise ConfigError(
                f"cannot listen on {self.host}:{self.port}: {err}", "viewer port"
            ) from err
        assert self._url is not None
        log.info("viewer at %s", self._url)
        return self._url

    def publish(self, frame: dict[str, Any]) -> None:
        """Hand the latest frame to the viewer. Non-blocking, O(1); call it from one thread.

        The viewer keeps a reference to ``frame`` (the caller must not mutate it
        afterwards; build a fresh dict each tick). A ``frame["sonar"]`` entry may carry
        the fan image as ``"fan"`` (uint8 array, H×W or H×W×3) instead of
        ``"fan_png_b64"``: it is copied here (cheap) and PNG-encoded in the server thread,
        once per ping, only while a page is connected. ``frame["sonar"]`` may also be a
        list of such dicts (several sonars pinged in the same tick); each names its
        ``agent`` and ``sensor`` and carries its ``fov_deg`` and ``max_range`` (m).
        ``frame["camera"]``, a list of ``{"agent", "sensor", "t", "image"}`` (uint8 H×W×3
        RGB), goes the same way: copied, PNG-encoded in the server thread at most
        ``max_sonar_fps`` times a second per sensor, sent as ``camera`` messages.
        """
        sonar = frame.get("sonar")
        self._seq += 1
        seq = self._seq
        if sonar is not None:
            for ping in sonar if isinstance(sonar, list) else (sonar,):
                fan = ping.get("fan")
                if fan is not None:
                    ping = {**ping, "fan": np.array(fan, copy=True)}
                with self._sonar_lock:
                    self._sonar[_image_key(ping)] = (seq, ping)
        for shot in frame.get("camera") or ():
            shot = {**shot, "kind": "camera", "image": np.array(shot["image"], copy=True)}
            with self._sonar_lock:  # one queue for both kinds of image, keyed apart
                self._sonar[f"camera:{_image_key(shot)}"] = (seq, shot)
        self._latest = (seq, frame)

    def drain_commands(self) -> list[Command]:
        """All commands received from pages since the last call, oldest first."""
        out: list[Command] = []
        pop = self._commands.popleft
        while True:
            try:
                out.append(pop())
            except IndexError:
                return out

    def close(self, timeout: float = 5.0) -> None:
        """Stop serving, close connections and join the thread (idempotent)."""
        loop, stop, thread = self._loop, self._stop, self._thread
        if loop is not None and stop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(stop.set)
        if thread is not None:
            thread.join(timeout)
            if thread.is_alive():
                log.warning("viewer thread did not stop within %.1f s", timeout)
        self._thread = None
        self._url = None

    def __enter__(self) -> ViewerServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def n_clients(self) -> int:
        """Number of pages connected right now."""
        return len(self._clients)

    # ------------------------------------------------------------------ server thread
    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as e:  # report start errors to start()
            if not self._started.is_set():
                self._start_error = e
                self._started.set()
            else:
                log.exception("viewer server stopped on an error")
        finally:
            with contextlib.suppress(Exception):
                loop.run_until_complete(loop.shutdown_asyncgens())
            loop.close()

    async def _main(self) -> None:
        from websockets.asyncio.server import serve

        self._stop = asyncio.Event()
        self._cond = asyncio.Condition()
        async with serve(
            self._handler,
            self.host,
            self.port,
            process_request=self._http,
            compression=None,
            max_size=1 << 16,
            close_timeout=1.0,
            logger=logging.getLogger(__name__ + ".ws"),
        ) as server:
            port = next(iter(server.sockets)).getsockname()[1]
            host = f"[{self.host}]" if ":" in self.host else self.host
            self.port = port
            self._url = f"http://{host}:{port}/"
            self._started.set()
            producer = asyncio.create_task(self._producer())
            await self._stop.wait()
            producer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await producer
            closing = [ws.close(1001, "viewer closing") for ws in list(self._clients)]
            if closing:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(
                        asyncio.gather(*closing, return_exceptions=True), timeout=2.0
                    )

    def _http(self, connection: ServerConnection, request: Request) -> Response | None:
        from websockets.datastructures import Headers
        from websockets.http11 import Response

        path = request.path.split("?", 1)[0]
        # Only pages served from loopback may talk to us: a Host header naming another
        # machine means DNS rebinding; a foreign Origin on /ws means another web site
        # trying to steer the simulation from the user's browser.
        if not _is_loopback_authority(request.headers.get("Host", "")):
            return connection.respond(HTTPStatus.FORBIDDEN, "host not allowed\n")
        if path == "/ws":
            origin = request.headers.get("Origin")
            if origin is not None and not _is_loopback_origin(origin):
                log.warning("viewer: refused a websocket from origin %r", origin)
                return connection.respond(HTTPStatus.FORBIDDEN, "origin not allowed\n")
            return None  # go on with the websocket handshake
        name = "index.html" if path in ("/", "/index.html") else path.removeprefix("/static/")
        if name == "/favicon.ico":
            return Response(204, "No Content", Headers([("Content-Length", "0")]))
        item = self._static.get(name)
        if item is None:
            return connection.respond(HTTPStatus.NOT_FOUND, "not found\n")
        body, ctype = item
        headers = [("Content-Type", ctype), ("Cache-Control", "no-cache")]
        if len(body) > 4096 and "gzip" in request.headers.get("Accept-Encoding", ""):
            if name not in self._gzipped:
                self._gzipped[name] = gzip.compress(body, compresslevel=6)
            body = self._gzipped[name]
            headers.append(("Content-Encoding", "gzip"))
        headers.append(("Content-Length", str(len(body))))
        return Response(200, "OK", Headers(headers), body)

    def _hello(self) -> str:
        msg = {
            "type": "hello",
            "mode": self.mode,
            "scene": self._scene,
            "buttons": self._buttons,
            "max_fps": self.max_fps,
            "history": {a: list(h) for a, h in self._history.items()},
            "replay": None,
            **self._hello_extra,
        }
        return encode_json(msg)

    async def _handler(self, ws: ServerConnection) -> None:
        path = ws.request.path.split("?", 1)[0] if ws.request is not None else ""
        if path != "/ws":
            await ws.close(1008, "unknown path")
            return
        await ws.send(self._hello())
        self._clients.add(ws)
        sender = asyncio.create_task(self._sender(ws))
        try:
            async for raw in ws:
                self._on_message(raw)
        except Exception as e:  # connection dropped: nothing to do but forget it
            log.debug("viewer client ended: %s", e)
        finally:
            self._clients.discard(ws)
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await sender

    def _on_message(self, raw: str | bytes) -> None:
        try:
            msg = json.loads(raw)
        except (ValueError, UnicodeDecodeError):
            log.warning("viewer: dropped a message that is not JSON")
            return
        if not isinstance(msg, dict):
            log.warning("viewer: dropped a message that is not a JSON object")
            return
        mtype = msg.get("type")
        if mtype == "command":
            try:
                cmd = parse_command(msg)
            except ConfigError as e:
                log.warning("%s (dropped)", e)
                return
            if self._command_hook is not None and self._command_hook(cmd):
                return
            self._commands.append(cmd)
        elif self._command_hook is not None and self._command_hook(msg):
            return
        else:
            log.warning("viewer: dropped a message of unknown type %r", mtype)

    async def _producer(self) -> None:
        """Encode the latest frame and new sonar pings, at most ``max_fps`` times a second."""
        assert self._cond is not None
        loop = asyncio.get_running_loop()
        period = 1.0 / self.max_fps
        next_t = loop.time()
        while True:
            now = loop.time()
            if self._tick_hook is not None:
                self._tick_hook(now)
            changed = False
            latest = self._latest
            if latest is not None and latest[0] != self._frame_seq:
                seq, frame = latest
                self._record_history(frame)
                self.processed_seq = seq
                if self._clients:
                    msg = {"type": "frame", "seq": seq}
                    msg.update((k, v) for k, v in frame.items()
                               if k not in ("sonar", "camera"))
                    try:
                        self._frame_text = encode_json(msg)
                        self.frames_encoded += 1
                    except (TypeError, ValueError) as e:
                        log.warning("viewer: frame %d not encodable: %s", seq, e)
                    self._frame_seq = seq
                    changed = True
            if self._clients:
                with self._sonar_lock:
                    pings = list(self._sonar.items())
                for agent, (seq, sonar) in pings:
                    if self._sonar_text.get(agent, (-1, ""))[0] == seq:
                        continue
                    # (half a producer period of slack, so 10 Hz stays 10 Hz with jitter)
                    slack = 0.5 * period
                    if now - self._sonar_time.get(agent, -math.inf) < self._sonar_period - slack:
                        continue  # newest ping goes out on a later cycle
                    self._sonar_time[agent] = now
                    text = self._encode_sonar(seq, agent, sonar)
                    self._sonar_text[agent] = (seq, text if text is not None else "")
                    changed = changed or text is not None
            if changed:
                async with self._cond:
                    self._generation += 1
                    self._cond.notify_all()
            next_t += period
            delay = next_t - loop.time()
            if delay < -period:  # fell behind (e.g. a long encode): don't try to catch up
                next_t = loop.time()
                delay = 0.0
            await asyncio.sleep(max(delay, 0.0))

    def _encode_sonar(self, seq: int, agent: str, sonar: dict[str, Any]) -> str | None:
        """The ``sonar`` message of a ping, or the ``camera`` message of a camera frame
        (entries of kind "camera", keyed ``camera:<agent>/<sensor>``); None if not
        encodable (a ping without its field of view and range, too: the viewer never
        guesses them)."""
        try:
            if sonar.get("kind") == "camera":
                b64 = encode_png_b64(sonar["image"], self._sonar_max_px)
                self.cameras_encoded += 1
                head = {"type": "camera", "seq": seq, "agent": str(sonar.get("agent", "")),
                        "sensor": str(sonar.get("sensor", "camera")),
                        "t": float(sonar.get("t", math.nan))}
                key = "png_b64"
            else:
                b64 = sonar.get("fan_png_b64")
                if b64 is None:
                    b64 = encode_png_b64(sonar["fan"], self._sonar_max_px)
                self.sonars_encoded += 1
                head = {
                    "type": "sonar",
                    "seq": seq,
                    "agent": str(sonar.get("agent", "")),
                    "sensor": str(sonar.get("sensor", "sonar")),
                    "t": float(sonar.get("t", math.nan)),
                    "fov_deg": float(sonar["fov_deg"]),
                    "max_range": float(sonar["max_range"]),
                    "marks": list(sonar.get("marks", [])),
                }
                key = "fan_png_b64"
            if not isinstance(b64, str) or not _B64.fullmatch(b64[:64]):
                raise ValueError(f"{key} is not base64 text")
            # base64 needs no JSON escaping: splice it in rather than re-scan 100 kB
            return encode_json(head)[:-1] + f',"{key}":"' + b64 + '"}'
        except (KeyError, TypeError, ValueError, ConfigError) as e:
            log.warning("viewer: image %r not encodable: %s", agent, e)
            return None

    def _record_history(self, frame: dict[str, Any]) -> None:
        try:
            t = float(frame.get("t", 0.0))
            for a in frame.get("agents", ()):
                name = str(a["name"])
                h = self._history.get(name)
                if h is None:
                    h = self._history[name] = deque(maxlen=self._history_len)
                if h and t < h[-1][0]:
                    h.clear()  # time went backwards: a new run or a replay seek
                if not h or t - h[-1][0] >= self._history_period:
                    h.append([t, float(a["north"]), float(a["east"]), float(a["depth"])])
        except (KeyError, TypeError, ValueError) as e:
            log.debug("viewer: frame without usable agents: %s", e)

    async def _sender(self, ws: ServerConnection) -> None:
        assert self._cond is not None
        sent_frame = -1
        sent_sonar: dict[str, int] = {}
        seen_gen = -1
        while True:
            async with self._cond:
                while self._generation == seen_gen:
                    await self._cond.wait()
                seen_gen = self._generation
            if self._frame_seq != sent_frame and self._frame_text is not None:
                sent_frame = self._frame_seq
                await ws.send(self._frame_text)
                self.frames_sent += 1
            for agent, (seq, text) in list(self._sonar_text.items()):
                if sent_sonar.get(agent) != seq and text:
                    sent_sonar[agent] = seq
                    await ws.send(text)


def _image_key(entry: dict[str, Any]) -> str:
    """``"<agent>/<sensor>"`` of a sonar or camera entry (its sensor named by its kind
    when the entry does not say)."""
    default = "camera" if entry.get("kind") == "camera" else "sonar"
    return f"{entry.get('agent', '')}/{entry.get('sensor', default)}"
