"""Complete a recording cut by a full disk where it lies: its summary and footer appended
after its last whole record, so only the summary needs room (not a copy of the file, as
:func:`uhrisim.record.recover.recover` makes).

The file is scanned record by record (a chunk is read whole, its messages counted); the
summary repeats its schemas and channels and holds its statistics, one chunk index per
chunk (with the offsets of the message indexes that follow it on disk) and the metadata
indexes, as ``mcap``'s own writer lays them out (MCAP specification, "Summary section").
The recorder keeps room for it: a file of :data:`HEADROOM_BYTES` beside the recording that
it deletes when it closes (:class:`Headroom`), and under a file-size limit data that stop
short of the limit (:func:`size_limit_with_headroom`).
"""

from __future__ import annotations

import contextlib
import os
import resource
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import BinaryIO

from mcap.data_stream import RecordBuilder
from mcap.exceptions import EndOfFile
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    McapRecord,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Opcode,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import StreamReader, breakup_chunk

from uhrisim.core.errors import UhrisimError
from uhrisim.record.reader import MCAP_MAGIC, is_complete

HEADROOM_BYTES = 4 * 1024 * 1024  # the summary of a day's run at 15 Hz pings fits


def headroom_path(recording: Path) -> Path:
    """The headroom file of a recording: ``<name>.headroom`` beside it."""
    return recording.with_name(recording.name + ".headroom")


def size_limit_with_headroom() -> int | None:
    """Under a file-size limit (``ulimit -f``: the headroom file cannot help, the limit
    is per file), the size a recording's data stop at, leaving it room for its summary
    (a quarter of the limit, at most :data:`HEADROOM_BYTES`); None without a limit."""
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if limit == resource.RLIM_INFINITY:
        return None
    return limit - min(HEADROOM_BYTES, limit // 4)


class Headroom:
    """Disk space held back in a file beside the recording (:func:`headroom_path`), given
    back when the recording closes, so that a recording the disk cut short still has
    room for its summary, its ``metadata.yaml`` and the run's ``metrics.json``."""

    def __init__(self, recording: Path, size: int = HEADROOM_BYTES) -> None:
        self.path = path = headroom_path(recording)
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            try:
                os.posix_fallocate(fd, 0, size)
            finally:
                os.close(fd)
        except OSError:  # no room even for that: the run will be cut without a summary
            self.release()

    def release(self) -> None:
        """Give the space back (idempotent)."""
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()


@dataclass
class _Summary:
    """What a scan of the data section learned, to be written as its summary."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    metadata_indexes: list[MetadataIndex] = field(default_factory=list)
    channel_counts: dict[int, int] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int = 0

    def add_contents(self, records: list[McapRecord]) -> None:
        for record in records:
            if isinstance(record, Schema):
                self.schemas[record.id] = record
            elif isinstance(record, Channel):
                self.channels[record.id] = record
            elif isinstance(record, Message):
                counts = self.channel_counts
                counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
                start = self.start_ns
                self.start_ns = record.log_time if start is None else min(start, record.log_time)
                self.end_ns = max(self.end_ns, record.log_time)


def _whole_records(stream: BinaryIO, size: int) -> Iterator[tuple[int, int, McapRecord]]:
    """``(offset, length with its 9-byte opcode and length, record)`` of every whole
    record after the magic, in file order, up to the first that the file cuts short."""
    pos = len(MCAP_MAGIC)
    while pos + 9 <= size:
        stream.seek(pos)
        frame = stream.read(9)
        (length,) = struct.unpack_from("<Q", frame, 1)
        if pos + 9 + length > size:
            return
        reader = StreamReader(BytesIO(frame + stream.read(length)), skip_magic=True,
                              emit_chunks=True, validate_crcs=True)
        try:
            record = next(iter(reader.records))
        except (EndOfFile, StopIteration):
            return
        yield pos, 9 + length, record
        pos += 9 + length


def _scan(stream: BinaryIO, size: int) -> tuple[int, _Summary]:
    """Where the data section's whole records end, and their summary."""
    summary, end = _Summary(), len(MCAP_MAGIC)
    last_chunk: ChunkIndex | None = None
    for offset, length, record in _whole_records(stream, size):
        if isinstance(record, (DataEnd, Footer)):  # cut inside its summary: written anew
            break
        end = offset + length
        if isinstance(record, Chunk):
            summary.add_contents(breakup_chunk(record, validate_crc=True))
            last_chunk = ChunkIndex(
                message_start_time=record.message_start_time,
                message_end_time=record.message_end_time, chunk_start_offset=offset,
                chunk_length=length, message_index_offsets={}, message_index_length=0,
                compression=record.compression, compressed_size=len(record.data),
                uncompressed_size=record.uncompressed_size)
            summary.chunk_indexes.append(last_chunk)
        elif isinstance(record, MessageIndex):
            if last_chunk is not None:  # the indexes of the chunk just before
                last_chunk.message_index_offsets[record.channel_id] = offset
                last_chunk.message_index_length += length
        else:
            last_chunk = None
            if isinstance(record, Metadata):
                summary.metadata_indexes.append(MetadataIndex(offset=offset, length=length,
                                                              name=record.name))
            summary.add_contents([record])
    return end, summary


def _summary_bytes(summary: _Summary, data_end: int) -> bytes:
    """DataEnd, the summary's groups, their offsets, the footer and the closing magic,
    for a data section that ends at byte ``data_end``."""
    builder = RecordBuilder()
    DataEnd(data_section_crc=0).write(builder)
    summary_start = data_end + builder.count
    groups: list[tuple[int, int, int]] = []  # opcode, start, length

    def group(opcode: int, records: list[McapRecord]) -> None:
        if records:
            start = builder.count
            for record in records:
                record.write(builder)
            groups.append((opcode, data_end + start, builder.count - start))

    group(Opcode.SCHEMA, list(summary.schemas.values()))
    group(Opcode.CHANNEL, list(summary.channels.values()))
    group(Opcode.STATISTICS, [Statistics(
        message_count=sum(summary.channel_counts.values()),
        schema_count=len(summary.schemas), channel_count=len(summary.channels),
        attachment_count=0, metadata_count=len(summary.metadata_indexes),
        chunk_count=len(summary.chunk_indexes), message_start_time=summary.start_ns or 0,
        message_end_time=summary.end_ns, channel_message_counts=summary.channel_counts)])
    group(Opcode.CHUNK_INDEX, list(summary.chunk_indexes))
    group(Opcode.METADATA_INDEX, list(summary.metadata_indexes))
    offsets_start = data_end + builder.count
    for opcode, start, length in groups:
        SummaryOffset(group_opcode=opcode, group_start=start, group_length=length).write(builder)
    Footer(summary_start=summary_start, summary_offset_start=offsets_start,
           summary_crc=0).write(builder)
    builder.write(MCAP_MAGIC)
    return builder.end()


def finish_in_place(path: Path | str) -> int:
    """Append the summary and footer to the cut MCAP file at ``path`` (after its last
    whole record, dropping any part record after it). Returns the messages it holds. On
    a write that fails the file is put back as it was and a one-line error raised."""
    path = Path(path)
    with path.open("r+b") as stream:
        size = os.fstat(stream.fileno()).st_size
        if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise UhrisimError(f"{path}: not an MCAP recording: left as it is")
        if is_complete(path):
            raise UhrisimError(f"{path}: complete already (it has its summary)")
        data_end, summary = _scan(stream, size)
        tail = _summary_bytes(summary, data_end)
        try:
            stream.truncate(data_end)
            stream.seek(data_end)
            stream.write(tail)
            stream.flush()
            os.fsync(stream.fileno())
        except OSError as error:
            stream.truncate(data_end)
            raise UhrisimError(f"{path}: no room to complete the recording "
                               f"({error.strerror}): free some and run uhrisim recover") from None
    return sum(summary.channel_counts.values())
