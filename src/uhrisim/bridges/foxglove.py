"""Foxglove live: the run's ROS 2 messages served to Foxglove over its WebSocket protocol,
with no ROS installed (``uhrisim run --foxglove``; docs/bridges-ros2.md, "Foxglove live").

The channels are the recording's (:class:`~uhrisim.record.hook.McapRecordingHook`): the
same topics, ``ros2msg`` schemas and CDR bytes (:class:`~uhrisim.ros.writer.RosWriter`),
so Foxglove's 3-D, image, plot and raw-message panels read them as they read a bag.
Message times are simulation time (ns since the run's start). The server (the Foxglove
SDK, ``foxglove-sdk``: the ``foxglove`` extra) binds 127.0.0.1 unless told otherwise.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from uhrisim.core.errors import ConfigError, UhrisimError
from uhrisim.record.hook import McapRecordingHook
from uhrisim.ros.msgdefs import schema_text
from uhrisim.ros.tick import TickWriter
from uhrisim.ros.topics import QosKind
from uhrisim.ros.writer import RosWriter

__all__ = ["FoxgloveHook", "FoxgloveWriter"]

log = logging.getLogger(__name__)

#: The layout shipped for Foxglove (the track-and-trail mission's views).
LAYOUT = Path(__file__).with_name("foxglove_layout.json")


#: Simulated seconds after the start at which the server opens: by then the run has
#: created the channels it writes regularly (odometry, /tf, /clock, the sonars, the
#: helms'), so a client does not connect while they are being created. One client of
#: the test suite, connecting during that burst under load, never got some channels'
#: advertisements.
OPEN_AFTER_S = 1.0


class FoxgloveWriter(RosWriter):
    """A :class:`RosWriter` whose messages go to a Foxglove WebSocket server on
    ``host:port`` (``port=0``: any free port; :attr:`port` says which), opened by
    :meth:`open` (messages written before go to channels no client sees yet)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8765) -> None:
        super().__init__()
        try:
            import foxglove
        except ImportError:
            raise ConfigError("--foxglove needs the Foxglove SDK: pip install "
                              "'uhrisim[foxglove]'") from None
        self._fox = foxglove
        self._context = foxglove.Context()
        self._address = (host, port)
        self._server: Any = None
        self._channels: dict[str, Any] = {}
        self.counts: dict[str, int] = {}
        self._closed = False

    def open(self) -> None:
        """Start the server (once)."""
        if self._server is None:
            host, port = self._address
            try:
                self._server = self._fox.start_server(name="uhrisim", host=host, port=port,
                                                      context=self._context)
            except Exception as exc:  # the SDK's own error types: an address in use, ...
                raise UhrisimError(f"Foxglove server on {host}:{port}: {exc}") from None

    @property
    def port(self) -> int:
        """The port the server listens on (once open)."""
        return int(self._server.port)

    def _check_open(self, where: str) -> None:
        if self._closed:
            raise UhrisimError(f"FoxgloveWriter.{where}: the server is stopped")

    def _emit(self, topic: str, typename: str, qos: QosKind, t_ns: int, data: bytes) -> None:
        del qos
        name = f"/{topic}"
        channel = self._channels.get(name)
        if channel is None:
            schema = self._fox.Schema(name=typename, encoding="ros2msg",
                                      data=schema_text(typename).encode("utf-8"))
            channel = self._channels[name] = self._fox.Channel(
                name, schema=schema, message_encoding="cdr", context=self._context)
        channel.log(bytes(data), log_time=t_ns)
        self.counts[name] = self.counts.get(name, 0) + 1

    def close(self) -> None:
        """Stop the server (idempotent)."""
        if not self._closed:
            self._closed = True
            if self._server is not None:
                self._server.stop()


class FoxgloveHook(McapRecordingHook):
    """Serves the run live to Foxglove: the recording hook's choice of messages (odometry
    and ``/tf`` every ``odom_every`` ticks, every ping, camera frame, helm decision,
    posting and event, the scene at start), written to a :class:`FoxgloveWriter`."""

    def __init__(self, port: int = 8765, host: str = "127.0.0.1", odom_every: int = 6) -> None:
        super().__init__(Path("foxglove"), odom_every=odom_every, rosbag2_metadata=False)
        self._host, self._port = host, port
        self.url = ""

    def on_start(self, sim: Any) -> None:
        writer = FoxgloveWriter(self._host, self._port)
        self._rec = writer  # type: ignore[assignment]  (the recording hook's writer)
        self._tick = TickWriter(writer)
        self._tick.start(sim, scene=self.record_scene)

    def on_tick(self, frame: Any) -> None:
        super().on_tick(frame)
        writer = self._rec
        if (not self.url and isinstance(writer, FoxgloveWriter)
                and float(frame.t) >= OPEN_AFTER_S):
            writer.open()
            self.url = f"ws://{self._host}:{writer.port}"
            log.warning("Foxglove: open %s in Foxglove (Open connection -> Foxglove "
                        "WebSocket); layout: %s", self.url, LAYOUT)

    def on_end(self, sim: Any, error: BaseException | None) -> None:
        del sim, error
        if self._rec is not None:
            self._rec.close()

    def summary(self) -> dict[str, Any]:
        writer = self._rec
        counts = writer.counts if isinstance(writer, FoxgloveWriter) else {}
        return {"foxglove": {"url": self.url, "messages": sum(counts.values())}}
