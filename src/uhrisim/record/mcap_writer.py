"""An MCAP writer whose per-message cost is one ``struct`` pack: :class:`PackedMcapWriter`.

It writes the same bytes as ``mcap.writer.Writer`` (mcap 1.6; chunked, every index,
summary CRC, no data-section CRC; a test holds it to the library byte for byte) for the
calls the recorder makes: ``start``, ``add_metadata``, ``register_schema``,
``register_channel``, ``add_message``, ``flush`` and ``finish``. The library builds a
``Message`` record object, a statistics update and a message-index entry through about
fifteen Python calls per message; here a message is one precompiled ``struct`` header
appended with its data to the open chunk's list of parts, and its index entry one tuple.
Every other record (header, schema, channel, metadata, chunk, indexes, statistics,
summary, footer) is written by the library's own record classes.

Writes to the output are those of the library: the header, each metadata record, each
chunk and then its message indexes, the summary, the footer and magic, so a crashed run's
file ends at a chunk boundary in the same places.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Mapping
from typing import IO, Any

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.writer import MCAP0_MAGIC, CompressionType

__all__ = ["PackedMcapWriter"]

#: A message record's head: opcode, record length, channel id, sequence, log and
#: publish time (the data follows).
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
_MESSAGE_HEAD_LENGTH = _MESSAGE_HEAD.size - 9  # what the record length counts of it
#: A message index record's head: opcode, record length, channel id, entries' byte length.
_INDEX_HEAD = struct.Struct("<BQHI")


def _compressor(kind: CompressionType) -> tuple[str, Callable[[bytes], bytes]]:
    """The chunk compression's name in the file and its function (one zstd context kept
    for the whole file: the bytes of ``zstandard.compress``, without a new context for
    each chunk)."""
    if kind is CompressionType.ZSTD:
        import zstandard

        return "zstd", zstandard.ZstdCompressor(level=3).compress
    if kind is CompressionType.LZ4:
        import lz4.frame

        return "lz4", lz4.frame.compress
    return "", bytes


class PackedMcapWriter:
    """Writes a chunked MCAP file to ``output`` (anything with ``write`` and ``tell``),
    byte for byte as ``mcap.writer.Writer(output, chunk_size, compression)`` would.

    ``chunk_size``: a chunk is written once its uncompressed records exceed this many
    bytes (checked after each message, schema or channel)."""

    def __init__(self, output: IO[Any], chunk_size: int,
                 compression: CompressionType = CompressionType.ZSTD) -> None:
        self._out = output
        self._chunk_size = chunk_size
        self._compression, self._compress = _compressor(compression)
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._chunk_indexes: list[ChunkIndex] = []
        # the written chunks' messages: per channel (in order of first message), in all,
        # their first and last log times
        self._message_counts: dict[int, int] = {}
        self._message_count = 0
        self._start_time = 0
        self._end_time = 0
        # the open chunk: its records as parts, their length, its message index per channel
        self._parts: list[bytes] = []
        self._chunk_length = 0
        self._chunk_messages = 0
        self._chunk_start = 0
        self._chunk_end = 0
        self._chunk_index: dict[int, list[int]] = {}  # channel -> [log time, offset, ...]

    def _write_record(self, record: Any) -> None:
        builder = RecordBuilder()
        record.write(builder)
        self._out.write(builder.end())

    def start(self, profile: str, library: str) -> None:
        """The magic and the header record."""
        self._out.write(MCAP0_MAGIC)
        self._write_record(Header(profile, library))

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """A metadata record (written at once) and its index entry for the summary."""
        offset = self._out.tell()
        builder = RecordBuilder()
        Metadata(name=name, metadata=dict(data)).write(builder)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=builder.count,
                                                    name=name))
        self._out.write(builder.end())

    def _add_to_chunk(self, record: Any) -> None:
        builder = RecordBuilder()
        record.write(builder)
        data = builder.end()
        self._parts.append(data)
        self._chunk_length += len(data)
        if self._chunk_length > self._chunk_size:
            self._finish_chunk()

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """A schema record in the open chunk; returns its id (1, 2, ...)."""
        schema = Schema(id=len(self._schemas) + 1, data=data, encoding=encoding, name=name)
        self._schemas.append(schema)
        self._add_to_chunk(schema)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: Mapping[str, str]) -> int:
        """A channel record in the open chunk; returns its id (1, 2, ...)."""
        channel = Channel(id=len(self._channels) + 1, topic=topic,
                          message_encoding=message_encoding, schema_id=schema_id,
                          metadata=dict(metadata))
        self._channels.append(channel)
        self._add_to_chunk(channel)
        return channel.id

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int) -> None:
        """One message record in the open chunk (times in ns)."""
        offset = self._chunk_length
        self._parts.append(_MESSAGE_HEAD.pack(Opcode.MESSAGE, _MESSAGE_HEAD_LENGTH + len(data),
                                              channel_id, sequence, log_time, publish_time))
        self._parts.append(data)
        self._chunk_length = offset + _MESSAGE_HEAD.size + len(data)
        if self._chunk_messages:
            if log_time < self._chunk_start:
                self._chunk_start = log_time
        else:
            self._chunk_start = log_time
        if log_time > self._chunk_end:
            self._chunk_end = log_time
        self._chunk_messages += 1
        entries = self._chunk_index.get(channel_id)
        if entries is None:
            self._chunk_index[channel_id] = [log_time, offset]
        else:
            entries += (log_time, offset)
        if self._chunk_length > self._chunk_size:
            self._finish_chunk()

    def _finish_chunk(self) -> None:
        """Write the open chunk and its message indexes, if it holds a message."""
        if not self._chunk_messages:
            return
        records = b"".join(self._parts)
        compression, compressed = self._compression, self._compress(records)
        chunk = Chunk(compression=compression, data=compressed,
                      message_start_time=self._chunk_start,
                      message_end_time=self._chunk_end,
                      uncompressed_crc=zlib.crc32(records), uncompressed_size=len(records))
        chunk_offset = self._out.tell()
        builder = RecordBuilder()
        chunk.write(builder)
        chunk_length = builder.count
        self._out.write(builder.end())
        index_offset = self._out.tell()
        offsets, indexes, length = {}, [], 0
        for channel_id, entries in self._chunk_index.items():
            offsets[channel_id] = index_offset + length
            body = struct.pack(f"<{len(entries)}Q", *entries)
            indexes += (_INDEX_HEAD.pack(Opcode.MESSAGE_INDEX, 6 + len(body), channel_id,
                                         len(body)), body)
            length += _INDEX_HEAD.size + len(body)
        self._out.write(b"".join(indexes))
        # the file's statistics: its messages are its chunks' (channels counted in order
        # of their first message, as the chunks' indexes list them)
        if self._message_count:
            self._start_time = min(self._start_time, self._chunk_start)
        else:
            self._start_time = self._chunk_start
        self._end_time = max(self._end_time, self._chunk_end)
        self._message_count += self._chunk_messages
        counts = self._message_counts
        for channel_id, entries in self._chunk_index.items():
            counts[channel_id] = counts.get(channel_id, 0) + len(entries) // 2
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=self._chunk_start, message_end_time=self._chunk_end,
            chunk_start_offset=chunk_offset, chunk_length=chunk_length,
            message_index_offsets=offsets, message_index_length=length,
            compression=compression, compressed_size=len(compressed),
            uncompressed_size=len(records)))
        self._parts = []
        self._chunk_length = self._chunk_messages = 0
        self._chunk_start = self._chunk_end = 0
        self._chunk_index = {}

    def flush(self) -> None:
        """Write the open chunk if it holds a message (schemas and channels wait)."""
        self._finish_chunk()

    def finish(self) -> None:
        """The open chunk, the data end, the summary (schemas, channels, statistics, chunk
        and metadata indexes, summary offsets), the footer and the closing magic."""
        self._finish_chunk()
        self._write_record(DataEnd(0))
        summary_start = self._out.tell()
        summary = RecordBuilder()
        offsets = []

        def group(opcode: Opcode, records: list[Any]) -> None:
            start = summary.count
            for record in records:
                record.write(summary)
            offsets.append(SummaryOffset(group_opcode=opcode,
                                         group_start=summary_start + start,
                                         group_length=summary.count - start))

        statistics = Statistics(
            attachment_count=0, channel_count=len(self._channels),
            channel_message_counts=self._message_counts,
            chunk_count=len(self._chunk_indexes), message_count=self._message_count,
            metadata_count=len(self._metadata_indexes),
            message_start_time=self._start_time, message_end_time=self._end_time,
            schema_count=len(self._schemas))
        group(Opcode.SCHEMA, self._schemas)
        group(Opcode.CHANNEL, self._channels)
        group(Opcode.STATISTICS, [statistics])
        group(Opcode.CHUNK_INDEX, self._chunk_indexes)
        group(Opcode.ATTACHMENT_INDEX, [])
        group(Opcode.METADATA_INDEX, self._metadata_indexes)
        offset_start = summary_start + summary.count
        for offset in offsets:
            offset.write(summary)
        data = summary.end()
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, offset_start),
                         zlib.crc32(data))
        self._out.write(data)
        self._write_record(Footer(summary_start=summary_start,
                                  summary_offset_start=offset_start, summary_crc=crc))
        self._out.write(MCAP0_MAGIC)
