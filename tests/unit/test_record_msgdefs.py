"""Embedded ROS 2 message definitions vs the ROS 2 Kilted type store shipped with rosbags.

Provenance: ``rosbags.typesys.Stores.ROS2_KILTED`` is generated from the Kilted
interface packages; ``generate_msgdef(..., ros_version=2)`` produces the concatenated
text in the layout rosbag2 writes (80 '=' separator, ``MSG: pkg/Type``).
"""

from __future__ import annotations

import pytest
from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from uhrisim.bridges.ros2.interfaces import SOURCE_DIR
from uhrisim.core.errors import ConfigError
from uhrisim.ros.msgdefs import SEPARATOR, known_types, schema_text

KILTED = get_typestore(Stores.ROS2_KILTED)
STANDARD = [t for t in known_types() if not t.startswith(("uhrisim_msgs/", "marine_"))]
MARINE = [t for t in known_types() if t.startswith("marine_acoustic_msgs/")]
CUSTOM = [t for t in known_types() if t.startswith("uhrisim_msgs/")]


@pytest.mark.parametrize("typename", MARINE)
def test_marine_acoustic_definition_matches_the_public_msg_files(typename: str) -> None:
    """marine_acoustic_msgs is not in Kilted's core: its types registered from the
    package's own .msg files (uhrisim/bridges/ros2/interfaces, PROVENANCE.md), rosbags'
    rosbag2-layout text of each must be ours."""
    store = get_typestore(Stores.ROS2_KILTED)
    types = {}
    for path in (SOURCE_DIR / "marine_acoustic_msgs" / "msg").glob("*.msg"):
        types.update(get_types_from_msg(path.read_text(), f"marine_acoustic_msgs/msg/{path.stem}"))
    store.register(types)
    assert schema_text(typename) == store.generate_msgdef(typename, ros_version=2)[0]


@pytest.mark.parametrize("typename", STANDARD)
def test_standard_definition_matches_kilted_exactly(typename: str) -> None:
    expected, _md5 = KILTED.generate_msgdef(typename, ros_version=2)
    assert schema_text(typename) == expected


@pytest.mark.parametrize("typename", CUSTOM)
def test_custom_definition_parses_in_both_independent_parsers(typename: str) -> None:
    text = schema_text(typename)
    # rosbags: register every section as its own type, as AnyReader does for a bag.
    sections = text.split(f"{SEPARATOR}\n")
    types = get_types_from_msg(sections[0], typename)
    for section in sections[1:]:
        header, body = section.split("\n", 1)
        pkg, name = header.removeprefix("MSG: ").split("/")
        types.update(get_types_from_msg(body, f"{pkg}/msg/{name}"))
    assert typename in types
    # mcap_ros2 builds both an encoder and a decoder from the text.
    assert typename in serialize_dynamic(typename, text)
    assert typename in generate_dynamic(typename, text)


def test_helm_decision_layout() -> None:
    text = schema_text("uhrisim_msgs/msg/HelmDecision")
    own = text.split(SEPARATOR)[0]
    assert "uhrisim_msgs/BehaviorContribution[] contributions" in own
    assert text.count("MSG: ") == 3  # Header, Time, BehaviorContribution: each once


def test_unknown_type_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="no embedded message definition"):
        schema_text("uhrisim_msgs/msg/NoSuchType")  # (was ProjectedSonarImage, now embedded)
