"""RIHS01 type hashes computed from the recordings' own schemas (uhrisim.record.typehash)
equal those of two independent sources: rosidl's, written beside every type it built
(``share/<pkg>/msg/<Type>.json`` of the ROS 2 wheels and of the packages built by
``uhrisim ros2-interfaces``), and ``rosbags``' ROS 2 Kilted type store."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from rosbags.typesys import Stores, get_typestore

from uhrisim.record.typehash import rihs01
from uhrisim.ros.msgdefs import known_types, schema_text

KILTED = get_typestore(Stores.ROS2_KILTED)


def _rosidl_hash(typename: str) -> str | None:
    package, _msg, name = typename.split("/")
    path = Path(sys.prefix) / "share" / package / "msg" / f"{name}.json"
    if not path.is_file():
        return None
    doc = json.loads(path.read_text())
    return next(h["hash_string"] for h in doc["type_hashes"] if h["type_name"] == typename)


def test_every_recorded_type_hashes_as_rosidl_and_rosbags_say() -> None:
    compared = 0
    for typename in known_types():
        ours = rihs01(typename, schema_text(typename))
        assert ours.startswith("RIHS01_") and len(ours) == 7 + 64
        theirs = _rosidl_hash(typename)
        if theirs is not None:
            assert ours == theirs, typename
            compared += 1
        if typename in KILTED.fielddefs:
            assert ours == KILTED.hash_rihs01(typename), typename
            compared += 1
    assert compared >= len(known_types())  # each type against one source at least


def test_constants_comments_and_bounds() -> None:
    """Constants and comments are not hashed; bounded strings and sequences are."""
    plain = rihs01("p/msg/A", "uint8 x\n")
    assert rihs01("p/msg/A", "# a comment\nuint8 K=3  # constant\nuint8 x 7\n") == plain
    assert rihs01("p/msg/A", "uint8[<=4] x\n") != rihs01("p/msg/A", "uint8[4] x\n")
    assert rihs01("p/msg/A", "string<=8 x\n") != rihs01("p/msg/A", "string x\n")
    with pytest.raises(ValueError, match="lacks p/msg/B"):
        rihs01("p/msg/A", "B b\n")
