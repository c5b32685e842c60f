"""Turn a recording cut short by a crash into a complete, indexed MCAP file.

A killed run leaves an MCAP file without summary and footer (see
:mod:`uhrisim.record.reader`). Foxglove can stream such a file, but ``rosbags``
("File end magic is invalid"), ``ros2 bag`` and ``mcap``'s seeking reader refuse it.
:func:`recover` copies every message of every complete chunk — bytes untouched, same
schemas, channels, times and sequence numbers — into a new, finished file.
"""

from __future__ import annotations

import logging
from pathlib import Path

from mcap.records import Channel, Schema
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from uhrisim.core.errors import UhrisimError
from uhrisim.record.finish import headroom_path
from uhrisim.record.reader import MCAP_MAGIC, _scan, _ScanState, is_complete
from uhrisim.record.rosbag2 import write_metadata

logger = logging.getLogger(__name__)

__all__ = ["is_complete", "recover", "recover_in_place", "starts_as_mcap"]

PARTIAL_SUFFIX = ".partial"


def recover(src: Path | str, dst: Path | str, chunk_size: int = 1024 * 1024) -> int:
    """Copy the readable messages of ``src`` into a complete MCAP file ``dst``.

    Returns the number of messages copied. ``src`` and ``dst`` must differ. The header
    profile is ``ros2``; schema and channel ids may be renumbered (in order of first use).
    """
    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise UhrisimError(f"recover: {src}: source and destination are the same file")
    state = _ScanState()
    count = 0
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    with dst.open("wb") as out:
        writer = McapWriter(out, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="uhrisim recover")
        for schema, channel, message in _scan(src, state):
            cid = channel_ids.get(channel.id)
            if cid is None:
                sid = 0
                if isinstance(schema, Schema):
                    sid = schema_ids.get(schema.id, 0)
                    if not sid:
                        sid = writer.register_schema(schema.name, schema.encoding, schema.data)
                        schema_ids[schema.id] = sid
                assert isinstance(channel, Channel)
                cid = writer.register_channel(
                    channel.topic, channel.message_encoding, sid, dict(channel.metadata)
                )
                channel_ids[channel.id] = cid
            writer.add_message(cid, message.log_time, message.data, message.publish_time,
                               message.sequence)
            count += 1
        writer.finish()
    logger.info("recovered %d messages from %s (%s) into %s", count, src,
                "truncated" if state.truncated else "complete", dst)
    return count


def recover_in_place(path: Path | str) -> int | None:
    """Make the recording at ``path`` complete if a killed run cut it short: the cut file
    is kept as ``<path>.partial`` and a complete one, with every message of its complete
    chunks, takes its place, with the folder's rosbag2 ``metadata.yaml``
    (:mod:`uhrisim.record.rosbag2`); the headroom file a killed run left is deleted.
    Returns the messages copied, or None if it was complete."""
    path = Path(path)
    if not path.is_file():
        raise UhrisimError(f"{path}: no such recording")
    if not starts_as_mcap(path):
        raise UhrisimError(f"{path}: not an MCAP recording (no MCAP magic and header at its "
                           "start): left as it is")
    headroom = headroom_path(path)
    if headroom.exists():  # a killed run's: its space is needed now
        headroom.unlink()
    if is_complete(path):
        return None
    partial = path.with_name(path.name + PARTIAL_SUFFIX)
    if partial.exists():
        raise UhrisimError(f"{partial} already exists: move it away to recover {path} again")
    try:
        path.rename(partial)
    except OSError as error:
        raise UhrisimError(f"{path}: cannot recover it here ({error.strerror}): copy the "
                           "folder somewhere writable and recover the copy") from None
    try:
        count = recover(partial, path)
        write_metadata(path)
    except OSError as error:  # a full disk, say: the cut file goes back where it was
        path.unlink(missing_ok=True)
        partial.rename(path)
        raise UhrisimError(f"{path}: recovery failed ({error.strerror}); the recording is "
                           "left as it was") from None
    return count


def starts_as_mcap(path: Path | str) -> bool:
    """Whether the file starts as an MCAP file does: the magic, then a Header record
    (opcode 0x01, a length that fits in the file). Nothing else is ever renamed."""
    path = Path(path)
    with path.open("rb") as f:
        head = f.read(len(MCAP_MAGIC) + 9)
    if len(head) < len(MCAP_MAGIC) + 9 or head[: len(MCAP_MAGIC)] != MCAP_MAGIC:
        return False
    opcode, length = head[len(MCAP_MAGIC)], int.from_bytes(head[len(MCAP_MAGIC) + 1:], "little")
    return opcode == 0x01 and length <= path.stat().st_size
