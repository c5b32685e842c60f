"""PackedMcapWriter writes the bytes mcap's own Writer writes for the same calls.

The recorder's writer (uhrisim.record.mcap_writer) packs message records itself; the
reference is the library's ``mcap.writer.Writer`` with the same chunk size and
compression. Random call sequences cover chunks closed by size and by flush, schemas and
channels registered inside an open chunk, out-of-order log times, metadata records and
empty messages; the file is then read back by mcap's own reader.
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from uhrisim.record.mcap_writer import PackedMcapWriter


def calls(seed: int) -> list[tuple]:
    """A random sequence of writer calls (method name, arguments)."""
    rng = np.random.default_rng(seed)
    out: list[tuple] = [("start", "ros2", "test/1"),
                        ("add_metadata", "run", {"seed": str(seed), "dt": "0.0166"})]
    channels = 0
    t = 0
    for _ in range(600):
        roll = rng.random()
        if channels == 0 or roll < 0.02:
            schema = len([c for c in out if c[0] == "register_schema"]) + 1
            out.append(("register_schema", f"pkg/msg/T{schema}", "ros2msg",
                        b"float64 x\n" * int(rng.integers(1, 5))))
            channels += 1
            out.append(("register_channel", f"/agent/topic{channels}", "cdr", schema,
                        {"offered_qos_profiles": "" if channels % 2 else "- depth: 1"}))
        elif roll < 0.05:
            out.append(("flush",))
        elif roll < 0.06:
            out.append(("add_metadata", f"note{len(out)}", {"k": "v"}))
        else:
            t += int(rng.integers(-5_000_000, 20_000_000))  # log times may go back
            size = int(rng.choice([0, 4, 60, 900, 5000]))
            out.append(("add_message", int(rng.integers(1, channels + 1)), max(t, 0),
                        rng.integers(0, 256, size, dtype=np.uint8).tobytes(), max(t, 0),
                        int(rng.integers(0, 1000))))
    out.append(("finish",))
    return out


def written(writer_class, sequence: list[tuple], chunk_size: int,
            compression: CompressionType) -> bytes:
    sink = io.BytesIO()
    writer = writer_class(sink, chunk_size, compression)
    for name, *args in sequence:
        getattr(writer, name)(*args)
    return sink.getvalue()


@pytest.mark.parametrize("compression", list(CompressionType))
@pytest.mark.parametrize("seed,chunk_size", [(1, 4096), (2, 64 * 1024), (3, 1)])
def test_same_bytes_as_mcap_writer(seed: int, chunk_size: int,
                                   compression: CompressionType) -> None:
    sequence = calls(seed)
    ours = written(PackedMcapWriter, sequence, chunk_size, compression)
    assert ours == written(McapWriter, sequence, chunk_size, compression)
    messages = [c for c in sequence if c[0] == "add_message"]
    read = make_reader(io.BytesIO(ours)).iter_messages(log_time_order=False)
    assert [(channel.id, m.log_time, m.data, m.sequence) for _, channel, m in read] == [
        (c[1], c[2], c[3], c[5]) for c in messages]
