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


def test_uhrisim_msgs_are_the_recordings_definitions() -> None:
    """uhrisim_msgs is built from the definitions every recording embeds: the hash rosidl
    computed equals the one rosbags computes from that text."""
    pytest.importorskip("uhrisim_msgs")
    from uhrisim.ros.msgdefs import own_definition

    store = typesys.get_typestore(typesys.Stores.ROS2_KILTED)
    msgs, _deps = PACKAGES["uhrisim_msgs"]
    types = {}
    for name in msgs:
        typename = f"uhrisim_msgs/msg/{name}"
        types.update(typesys.get_types_from_msg(own_definition(typename), typename))
    store.register(types)
    for name in msgs:
        assert _built_hash("uhrisim_msgs", name) == store.hash_rihs01(
            f"uhrisim_msgs/msg/{name}"), name


def test_pre_serialised_sonar_image_is_what_rclpy_makes() -> None:
    """The bytes the bridge (and the recording) write for /<agent>/<sonar>/image are rclpy's
    serialisation of the ProjectedSonarImage built field by field (Fast CDR leaves its
    padding bytes unset: equal lengths, and rclpy reads ours back as the message)."""
    import numpy as np
    from marine_acoustic_msgs.msg import ProjectedSonarImage
    from rclpy.serialization import deserialize_message, serialize_message

    from tests.support.ros2_reference import projected_sonar_image_msg
    from uhrisim.ros.convert import stamp_from_sim_time
    from uhrisim.ros.messages import sonar_image

    polar = np.arange(6 * 4, dtype=np.uint8).reshape(6, 4)
    angles, ranges = np.linspace(-0.3, 0.3, 4), np.linspace(0.5, 3.0, 6)
    args = (12.345, "rov/sonar", polar, angles, ranges, 900e3, 1498.7)
    ours = sonar_image(*stamp_from_sim_time(12.345), *args[1:], "test")
    theirs = serialize_message(projected_sonar_image_msg(*args))
    assert len(ours) == len(theirs)
    assert deserialize_message(ours, ProjectedSonarImage) == deserialize_message(
        theirs, ProjectedSonarImage)
