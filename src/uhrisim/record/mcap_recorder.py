"""Record a simulation run to MCAP with ROS 2 message schemas: :class:`McapRecorder`.

The recorder is one of the two outputs of the ROS translation (:mod:`uhrisim.ros`): it
is a :class:`~uhrisim.ros.writer.RosWriter` whose messages go into an MCAP file that
Foxglove/Lichtblick, ``ros2 bag`` and ``rosbags`` open; the live bridge
(:mod:`uhrisim.bridges.ros2`) is the other, so the topics, types, frames and contents
of a recording are those of the live topics (:mod:`uhrisim.ros.topics`; the table in
docs/bridges-ros2.md). Every topic is recorded under ``/``: ``/<agent>/odom``,
``/<agent>/<sonar>/polar``, ``/tf``, ``/clock``, ... Conversions from uhrisim's NED/FRD
to ROS's ENU/FLU happen in :mod:`uhrisim.ros.convert` only.

The latched topics carry their offered QoS in the channel metadata
(:mod:`uhrisim.record.rosbag2`, which writes the folder's ``metadata.yaml``).

Time: ``header.stamp`` and the MCAP ``log_time``/``publish_time`` are all the
simulation time (nanoseconds since the start of the run); nothing in the file depends
on the wall clock, so the same sequence of calls gives a byte-identical file (for a
given ``mcap``/``zstandard`` version).

Crash safety: messages are grouped in chunks of about ``chunk_size`` bytes; each
finished chunk (with its schemas, channels and message index) is handed to the
operating system at once, without user-space buffering. A run killed with SIGKILL
leaves a file without summary or footer that ``uhrisim.record.reader`` reads up to
its last complete chunk. ``flush_period_s`` bounds how much simulated time a kill can
lose.
"""

from __future__ import annotations

import errno
import logging
import os
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

from mcap.writer import LIBRARY_IDENTIFIER, CompressionType

from uhrisim import __version__ as uhrisim_version
from uhrisim.core.errors import AssetError, ConfigError, UhrisimError
from uhrisim.record.finish import Headroom, size_limit_with_headroom
from uhrisim.record.mcap_writer import PackedMcapWriter
from uhrisim.record.rosbag2 import channel_metadata
from uhrisim.ros.messages import stamp_ns
from uhrisim.ros.msgdefs import schema_text
from uhrisim.ros.topics import QosKind
from uhrisim.ros.writer import RosWriter

logger = logging.getLogger(__name__)

__all__ = ["McapRecorder"]

_COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}


def _library_identifier() -> str:
    return f"uhrisim/{uhrisim_version}; {LIBRARY_IDENTIFIER}"


class RecordingCutError(AssetError):
    """The recording could not be written on (a full disk, a file-size limit): the run
    stops; the file ends at the last whole record, as a killed run's does."""

    def __init__(self, path: Path, why: str, size: int) -> None:
        super().__init__(f"{path}: cannot write the recording on ({why}) after "
                         f"{size / 1e6:.1f} MB: the run stopped there")


class _UnbufferedSink:
    """Append-only file that hands every write straight to the OS (no user-space buffer).

    The MCAP writer writes a chunk only once it is complete, so after a SIGKILL the
    file ends at a chunk boundary or inside the one chunk being written.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._pos = 0
        #: Under a file-size limit (``ulimit -f``) the data stop short of it, leaving the
        #: file room for its summary (:func:`~uhrisim.record.finish.size_limit_with_headroom`).
        self._size_limit = size_limit_with_headroom()
        #: Why the file could not be written (a full disk, a file-size limit): None if it
        #: could. After a failure the file ends where the last whole write ended.
        self.failure: str | None = None

    def write(self, data: bytes | bytearray | memoryview) -> int:
        if self.failure is not None:
            raise RecordingCutError(self.path, self.failure, self._pos)
        view = memoryview(data).cast("B")
        total = len(view)
        try:
            if self._size_limit is not None and self._pos + total > self._size_limit:
                raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))
            while view:
                written = os.write(self._fd, view)
                view = view[written:]
        except OSError as error:  # ENOSPC, EFBIG (ulimit -f, with SIGXFSZ ignored), EDQUOT
            self.failure = error.strerror or str(error)
            os.ftruncate(self._fd, self._pos)  # a cut at a record boundary, as a SIGKILL's
            raise RecordingCutError(self.path, self.failure, self._pos) from None
        self._pos += total
        return total

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered here; the OS holds what was written."""

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class McapRecorder(RosWriter):
    """Write a run to an MCAP file with ROS 2 (``ros2msg``/CDR) schemas: the
    :class:`~uhrisim.ros.writer.RosWriter` API (``write_odometry``, ``write_sonar``, ...).

    Parameters
    ----------
    path:
        Output file (``.mcap``); created or truncated. Its folder must exist.
    chunk_size:
        Target uncompressed chunk size in bytes: a chunk is closed and written as soon
        as it holds more than this. Smaller chunks lose less on a crash and compress less.
    world_frame:
        The ENU world frame id (REP-105 ``map``).
    compression:
        ``"zstd"`` (default), ``"lz4"`` or ``"none"``, per chunk.
    flush_period_s:
        If given, also close the current chunk whenever this much *simulation* time has
        passed since the last one, bounding what a crash loses. ``None``: by size only.
    metadata:
        Optional MCAP metadata records ``{name: {key: value}}`` written after the header
        (e.g. scenario name and seed). Keep wall-clock times out of it for reproducible
        files.

    Use as a context manager, or call :meth:`close` (idempotent).
    """

    def __init__(
        self,
        path: Path | str,
        chunk_size: int = 256 * 1024,
        world_frame: str = "map",
        *,
        compression: str = "zstd",
        flush_period_s: float | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
        namespace: str = "",
    ) -> None:
        where = "McapRecorder"
        if int(chunk_size) < 1:
            raise ConfigError(f"chunk_size must be >= 1 byte, got {chunk_size}", where=where)
        if compression not in _COMPRESSION:
            raise ConfigError(
                f"compression must be one of {sorted(_COMPRESSION)}, got {compression!r}",
                where=where,
            )
        if flush_period_s is not None and not (flush_period_s > 0.0):
            raise ConfigError(
                f"flush_period_s must be > 0 or None, got {flush_period_s}", where=where
            )
        super().__init__(world_frame)
        self.path = Path(path)
        self._flush_period_ns = (
            None if flush_period_s is None else stamp_ns(flush_period_s, where)
        )
        try:
            self._sink = _UnbufferedSink(self.path)
        except OSError as exc:
            raise UhrisimError(f"{self.path}: cannot open for writing ({exc.strerror})") from exc
        self._headroom = Headroom(self.path)
        self._writer = PackedMcapWriter(self._sink, int(chunk_size), _COMPRESSION[compression])
        self._writer.start(profile="ros2", library=_library_identifier())
        for name, data in (metadata or {}).items():
            self._writer.add_metadata(str(name), {str(k): str(v) for k, v in data.items()})
        self._schema_ids: dict[str, int] = {}
        #: Per relative topic: [channel id, messages written so far (the next sequence
        #: number), full topic].
        self._channels: dict[str, list[Any]] = {}
        self._last_flush_ns = 0
        self._closed = False
        self._prefix = namespace.rstrip("/")  # "" or "/sim_a"

    # ------------------------------------------------------------------ plumbing
    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def message_counts(self) -> dict[str, int]:
        """Messages written so far, per topic (a copy)."""
        return {topic: count for _, count, topic in self._channels.values()}

    @property
    def bytes_written(self) -> int:
        """Bytes handed to the OS so far (the open chunk is not counted)."""
        return self._sink.tell()

    def _check_open(self, where: str) -> None:
        if self._closed:
            raise UhrisimError(f"McapRecorder.{where}: recorder for {self.path} is closed")

    def _open_channel(self, topic: str, typename: str) -> list[Any]:
        """Register the channel of the relative ``topic`` (and its schema, once)."""
        schema_id = self._schema_ids.get(typename)
        if schema_id is None:
            schema_id = self._writer.register_schema(
                typename, "ros2msg", schema_text(typename).encode("utf-8")
            )
            self._schema_ids[typename] = schema_id
        full = f"{self._prefix}/{topic}"
        channel = [self._writer.register_channel(full, "cdr", schema_id,
                                                 channel_metadata(full)), 0, full]
        self._channels[topic] = channel
        return channel

    def _emit(self, topic: str, typename: str, qos: QosKind, t_ns: int, data: bytes) -> None:
        """Append one message on ``<namespace>/<topic>`` (``qos``: the rosbag2 metadata
        knows the latched topics by name)."""
        del qos
        channel = self._channels.get(topic) or self._open_channel(topic, typename)
        sequence = channel[1]
        channel[1] = sequence + 1
        self._writer.add_message(channel[0], t_ns, data, t_ns, sequence)
        if self._flush_period_ns is not None and t_ns - self._last_flush_ns >= (
            self._flush_period_ns
        ):
            self._writer.flush()
            self._last_flush_ns = t_ns

    # ------------------------------------------------------------------ lifecycle
    def flush(self) -> None:
        """Close the open chunk (if it holds messages) and hand it to the OS."""
        if self._closed:
            return
        self._writer.flush()

    @property
    def cut(self) -> str | None:
        """Why the file could not be written to its end (None: it could): it then ends
        at its last whole record, and :func:`uhrisim.record.finish.finish_in_place`
        completes it in the room :meth:`close` gave back."""
        return self._sink.failure

    def close(self) -> None:
        """Write the summary and footer and close the file, and give back the disk space
        held for a summary (:class:`~uhrisim.record.finish.Headroom`). Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._sink.failure is None:  # else the file stays cut (see ``cut``)
                self._writer.finish()
        finally:
            self._sink.close()
            self._headroom.release()
        logger.info(
            "recorded %d messages on %d topics to %s (%d bytes)",
            sum(c for _, c, _ in self._channels.values()), len(self._channels), self.path,
            self._sink.tell(),
        )

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
