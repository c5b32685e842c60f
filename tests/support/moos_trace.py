"""The real MOOSDB trace in tests/data/moos/ (provenance in its README), as byte streams."""

from __future__ import annotations

import json
from pathlib import Path

TRACE = Path(__file__).resolve().parents[1] / "data" / "moos" / "moos-trace.jsonl"

Stream = tuple[int, str]  # (connection number, "c2s" | "s2c")


def trace_chunks() -> dict[Stream, list[bytes]]:
    """Per connection and direction, the chunks as each ``recv`` returned them, in order."""
    chunks: dict[Stream, list[bytes]] = {}
    for line in TRACE.read_text().splitlines():
        if line.strip():
            rec = json.loads(line)
            chunks.setdefault((rec["conn"], rec["dir"]), []).append(bytes.fromhex(rec["hex"]))
    return chunks


def trace_streams() -> dict[Stream, bytes]:
    """Per connection and direction, the whole byte stream."""
    return {k: b"".join(v) for k, v in trace_chunks().items()}
