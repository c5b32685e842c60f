"""The interface packages built at install time (uhrisim.bridges.ros2.interfaces) are the
real types: their type hashes (RIHS01, computed by rosidl when building) equal those
``rosbags`` computes independently, tf2_msgs/TFMessage from its own ROS 2 Kilted type
store, the marine_acoustic_msgs types from the same public .msg files (issue 16)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

pytest.importorskip("tf2_msgs", reason="python -m uhrisim.bridges.ros2.interfaces")
pytest.importorskip("marine_acoustic_msgs")
typesys = pytest.importorskip("rosbags.typesys")

from uhrisim.bridges.ros2.interfaces import PACKAGES, SOURCE_DIR  # noqa: E402


def _built_hash(package: str, name: str) -> str:
    """The hash rosidl wrote beside the type it built (share/<pkg>/msg/<Type>.json)."""
    doc = json.loads((Path(sys.prefix) / "share" / package / "msg" / f"{name}.json")
                     .read_text())
    return next(h["hash_string"] for h in doc["type_hashes"]
                if h["type_name"] == f"{package}/msg/{name}")


def test_built_types_have_the_real_type_hashes() -> None:
    store = typesys.get_typestore(typesys.Stores.ROS2_KILTED)
    assert _built_hash("tf2_msgs", "TFMessage") == store.hash_rihs01("tf2_msgs/msg/TFMessage")
    msgs, _deps = PACKAGES["marine_acoustic_msgs"]
    types = {}
    for name in msgs:
        text = (SOURCE_DIR / "marine_acoustic_msgs" / "msg" / f"{name}.msg").read_text()
        types.update(typesys.get_types_from_msg(text, f"marine_acoustic_msgs/msg/{name}"))
    store.register(types)
    for name in msgs:
        assert _built_hash("marine_acoustic_msgs", name) == store.hash_rihs01(
            f"marine_acoustic_msgs/msg/{name}"), name
