"""Read uhrisim MCAP recordings, including ones cut short by a crash.

A finished recording has a summary and a footer; a run killed half-way (SIGKILL, power
cut of the process) leaves a file that stops somewhere inside a chunk. ``mcap``'s
seeking reader needs the footer; its non-seeking reader yields the complete chunks and
then raises on the cut. This module walks the records itself — MCAP framing is just
``opcode (u8), length (u64), body`` — checks each record is whole before it parses it
(with ``mcap``'s own record parser and CRC check) and stops quietly at the first
incomplete one, so everything up to the last complete chunk comes back. Messages are
decoded with ``mcap_ros2.decoder.DecoderFactory`` from the schemas in the file.

What other readers do with a truncated file (checked with mcap 1.6, rosbags 0.11.9):

* ``mcap.reader.make_reader`` on a seekable file picks the seeking reader, which looks
  for the footer and fails (``RecordLengthLimitExceeded`` or similar);
* ``mcap.reader.NonSeekingReader`` yields every message of the complete chunks, then
  raises ``EndOfFile`` (tests hold our reader to exactly that prefix);
* ``rosbags`` refuses the file ("File end magic is invalid");
* :func:`uhrisim.record.recover` writes a complete copy that all of them open.

The inverse of the recorder's frame conversion (ENU/FLU → NED/FRD) is done here too,
for :func:`read_odometry`.
"""

from __future__ import annotations

import logging
import math
import os
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from mcap.exceptions import EndOfFile
from mcap.records import Channel, Chunk, DataEnd, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory

from uhrisim.core.errors import AssetError
from uhrisim.core.frames import enu_from_ned, enu_rotation_from_ned, flu_from_frd
from uhrisim.ros import cdr

logger = logging.getLogger(__name__)

__all__ = [
    "DecodedMessage",
    "OdometryTrack",
    "RecordingSummary",
    "iter_messages",
    "iter_raw_messages",
    "read_metadata",
    "read_odometry",
    "summarize",
]

MCAP_MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER = 0x02
_OP_CHUNK = 0x06
_OP_DATA_END = 0x0F


@dataclass
class _ScanState:
    """What a raw scan learned about the file's end."""

    truncated: bool = False
    complete: bool = False  # footer reached
    chunks: int = 0
    end_offset: int = 0  # where the last whole record ended


def _scan(path: Path, state: _ScanState) -> Iterator[tuple[Schema | None, Channel, Message]]:
    try:
        stream = path.open("rb")
    except OSError as exc:
        raise AssetError(f"{path}: cannot open recording ({exc.strerror})") from exc
    with stream:
        size = os.fstat(stream.fileno()).st_size
        if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise AssetError(f"{path}: not an MCAP file (bad magic)")
        yield from _scan_records(path, stream, size, state)
    if state.truncated:
        logger.info(
            "%s: recording is truncated (no footer); read %d complete chunks up to byte %d",
            path, state.chunks, state.end_offset,
        )


def _scan_records(
    path: Path, stream: BinaryIO, size: int, state: _ScanState
) -> Iterator[tuple[Schema | None, Channel, Message]]:
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    pos = len(MCAP_MAGIC)
    state.end_offset = pos
    while True:
        if pos + 9 > size:
            state.truncated = True
            return
        frame = stream.read(9)
        opcode = frame[0]
        (length,) = struct.unpack_from("<Q", frame, 1)
        end = pos + 9 + length
        if end > size:
            state.truncated = True
            return
        try:
            records = _records_of(frame + stream.read(length))
        except Exception as exc:  # a corrupt record: CRC, decompression, parse errors
            logger.warning("%s: corrupt record at byte %d (%s); stopping there", path, pos, exc)
            state.truncated = True
            return
        state.end_offset = pos = end
        if opcode == _OP_CHUNK:
            state.chunks += 1
        for rec in records:
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                channels[rec.id] = rec
            elif isinstance(rec, Message):
                channel = channels.get(rec.channel_id)
                if channel is None:
                    logger.warning("%s: message on unknown channel %d", path, rec.channel_id)
                    continue
                yield schemas.get(channel.schema_id), channel, rec
        if opcode in (_OP_DATA_END, _OP_FOOTER):
            # What follows DataEnd is the summary section: nothing new for a stream read.
            state.complete = True
            return


def _records_of(blob: bytes) -> list[Any]:
    """The records in one whole MCAP record (a chunk expands to its contents)."""
    out: list[Any] = []
    reader = StreamReader(BytesIO(blob), skip_magic=True, validate_crcs=True)
    try:
        for rec in reader.records:
            out.append(rec)
    except EndOfFile:  # the reader looks for a next record after ours
        pass
    return out


def is_complete(path: Path | str) -> bool:
    """Whether the MCAP file ends with its closing magic (a finished recording)."""
    path = Path(path)
    with path.open("rb") as f:
        f.seek(0, 2)
        if f.tell() < 2 * len(MCAP_MAGIC):
            return False
        f.seek(-len(MCAP_MAGIC), 2)
        return f.read() == MCAP_MAGIC


def iter_raw_messages(
    path: Path | str, topics: Iterable[str] | None = None
) -> Iterator[tuple[Schema | None, Channel, Message]]:
    """``(schema, channel, message)`` in file order, up to the last complete record."""
    wanted = None if topics is None else set(topics)
    for schema, channel, message in _scan(Path(path), _ScanState()):
        if wanted is None or channel.topic in wanted:
            yield schema, channel, message


@dataclass(frozen=True)
class DecodedMessage:
    """One decoded message: topic, ROS type, MCAP log time (ns) and the decoded object."""

    topic: str
    typename: str
    log_time_ns: int
    message: Any


def iter_messages(
    path: Path | str, topics: Iterable[str] | None = None
) -> Iterator[DecodedMessage]:
    """Decoded messages (``mcap_ros2``) in file order; tolerant of a truncated file."""
    factory = DecoderFactory()
    for schema, channel, message in iter_raw_messages(path, topics):
        decoder = factory.decoder_for(channel.message_encoding, schema)
        if decoder is None:
            raise AssetError(
                f"{path}: topic {channel.topic} has no ROS 2 schema "
                f"(encoding {channel.message_encoding!r})"
            )
        yield DecodedMessage(
            channel.topic, schema.name if schema else "", message.log_time, decoder(message.data)
        )


@dataclass(frozen=True)
class RecordingSummary:
    """Topics with their type and message count, and whether the file was cut short."""

    topics: dict[str, tuple[str, int]] = field(default_factory=dict)
    truncated: bool = False
    complete_chunks: int = 0
    first_ns: int | None = None
    last_ns: int | None = None


def read_metadata(path: Path | str) -> dict[str, dict[str, str]]:
    """The file's MCAP metadata records by name (the recorder writes them before the
    first chunk, so a truncated file has them too)."""
    path = Path(path)
    out: dict[str, dict[str, str]] = {}
    try:
        with path.open("rb") as stream:
            for rec in StreamReader(stream, skip_magic=False).records:
                if isinstance(rec, Metadata):
                    out[rec.name] = dict(rec.metadata)
                elif isinstance(rec, Chunk | Message | DataEnd):
                    break
    except OSError as exc:
        raise AssetError(f"{path}: cannot open recording ({exc.strerror})") from exc
    except EndOfFile:
        pass  # cut before its first chunk: what was read is all there is
    return out


def summarize(path: Path | str) -> RecordingSummary:
    """Scan the whole file (without decoding payloads) and count messages per topic."""
    state = _ScanState()
    counts: dict[str, list[Any]] = {}
    first = last = None
    for schema, channel, message in _scan(Path(path), state):
        entry = counts.setdefault(channel.topic, [schema.name if schema else "", 0])
        entry[1] += 1
        first = message.log_time if first is None else min(first, message.log_time)
        last = message.log_time if last is None else max(last, message.log_time)
    return RecordingSummary(
        {k: (v[0], v[1]) for k, v in counts.items()}, state.truncated, state.chunks, first, last
    )


@dataclass(frozen=True)
class OdometryTrack:
    """One agent's recorded trajectory, back in uhrisim conventions (NED / FRD).

    Arrays of equal length, sorted by ``t``: ``t`` (s, simulation time from
    ``header.stamp``), ``x_north``, ``y_east``, ``depth`` (m, world NED), ``yaw`` (rad,
    compass yaw in [-pi, pi)), ``u``, ``v``, ``w`` (m/s, body FRD), ``r`` (rad/s,
    clockwise from above). ``track["t"]`` works as well as ``track.t``.
    """

    t: np.ndarray
    x_north: np.ndarray
    y_east: np.ndarray
    depth: np.ndarray
    yaw: np.ndarray
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    r: np.ndarray

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self.__dataclass_fields__:
            raise KeyError(key)
        return getattr(self, key)

    def __len__(self) -> int:
        return int(self.t.shape[0])


def _quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(N, 3, 3)`` from unit quaternions ``(N, 4)`` as (x, y, z, w)."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def read_odometry(path: Path | str) -> dict[str, OdometryTrack]:
    """Every ``/<agent>/odom`` topic of a recording as an :class:`OdometryTrack`.

    Reads up to the last complete chunk of a truncated file. ENU/FLU → NED/FRD with the
    same ``uhrisim.core.frames`` maps the recorder used (each is its own inverse).
    """
    rows: dict[str, list[tuple[float, ...]]] = {}
    slow = DecoderFactory()
    for schema, channel, message in iter_raw_messages(path):
        if schema is None or schema.name != "nav_msgs/msg/Odometry":
            continue
        parts = channel.topic.split("/")
        if len(parts) != 3 or parts[0] != "" or parts[2] != "odom":
            continue
        try:
            sec, nanosec, _frame, _child, values = cdr.decode_odometry(message.data)
        except ValueError:  # not CDR little endian: let mcap_ros2 do it
            m = slow.decoder_for(channel.message_encoding, schema)(message.data)
            p, o = m.pose.pose.position, m.pose.pose.orientation
            lin, ang = m.twist.twist.linear, m.twist.twist.angular
            sec, nanosec = m.header.stamp.sec, m.header.stamp.nanosec
            values = (p.x, p.y, p.z, o.x, o.y, o.z, o.w, lin.x, lin.y, lin.z, ang.x, ang.y,
                      ang.z)
        rows.setdefault(parts[1], []).append((sec + nanosec * 1e-9, *values))
    out: dict[str, OdometryTrack] = {}
    for agent, data in rows.items():
        a = np.asarray(data, dtype=float)
        a = a[np.argsort(a[:, 0], kind="stable")]
        pos_ned = enu_from_ned(a[:, 1:4])  # the swap is an involution: ENU → NED
        r_ned_frd = enu_rotation_from_ned(_quat_to_matrix(a[:, 4:8]))
        yaw = np.arctan2(r_ned_frd[:, 1, 0], r_ned_frd[:, 0, 0])
        yaw = (yaw + math.pi) % (2 * math.pi) - math.pi
        vel_frd = flu_from_frd(a[:, 8:11])
        rate_frd = flu_from_frd(a[:, 11:14])
        out[agent] = OdometryTrack(
            t=a[:, 0],
            x_north=pos_ned[:, 0],
            y_east=pos_ned[:, 1],
            depth=pos_ned[:, 2],
            yaw=yaw,
            u=vel_frd[:, 0],
            v=vel_frd[:, 1],
            w=vel_frd[:, 2],
            r=rate_frd[:, 2],
        )
    return out
