"""Make a recording's folder a rosbag2 bag: ``metadata.yaml`` beside the ``.mcap`` file.

``ros2 bag info|play``, ``rosbags.rosbag2.Reader`` and other rosbag2 tools open a
*folder* whose ``metadata.yaml`` lists the storage files, topics, types, message counts
and times (rosbag2 metadata version 9, what ROS 2 Jazzy and Kilted write). The run's
output folder is that folder: ``metadata.yaml`` names ``recording.mcap``; the other files
there (``metrics.json``, figures) are ignored by rosbag2. The metadata is made from the
finished MCAP file's own summary, so it is right for a recording that
:func:`~uhrisim.record.recover.recover` has completed too.

Offered QoS: the latched topics (``/tf_static``, ``/scene/markers``, ``*/helm/mode``) are
recorded as the live bridge offers them (reliable, transient local, keep last 1), so
``ros2 bag play`` latches them again; the others get rosbag2's default (none listed).
rosbag2 keeps them twice, in each MCAP channel's metadata (``offered_qos_profiles``, a
YAML text: :func:`channel_metadata`, which the recorder uses) and in ``metadata.yaml``,
made here from the former; readers match the two. Each topic's
``type_description_hash`` is the RIHS01 hash of its type, computed from the schema the
recording holds (:func:`uhrisim.record.typehash.rihs01`), as ``ros2 bag record`` writes
it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from mcap.reader import make_reader

from uhrisim.core.errors import UhrisimError
from uhrisim.core.files import write_text_whole
from uhrisim.record.typehash import rihs01

__all__ = ["METADATA_NAME", "channel_metadata", "write_metadata"]

#: The file rosbag2 looks for in a bag folder.
METADATA_NAME = "metadata.yaml"
#: rosbag2 metadata version (Jazzy, Kilted).
VERSION = 9

_DURATION_ZERO = {"sec": 0, "nsec": 0}
_LATCHED_QOS = {
    "history": "keep_last", "depth": 1, "reliability": "reliable",
    "durability": "transient_local", "deadline": _DURATION_ZERO, "lifespan": _DURATION_ZERO,
    "liveliness": "system_default", "liveliness_lease_duration": _DURATION_ZERO,
    "avoid_ros_namespace_conventions": False,
}


class _NoAliases(yaml.SafeDumper):
    """Writes repeated values in full (no ``&id``/``*id`` anchors)."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def _dump(data: Any) -> str:
    return yaml.dump(data, Dumper=_NoAliases, sort_keys=False)


def channel_metadata(topic: str) -> dict[str, str]:
    """The MCAP channel metadata of ``topic`` as rosbag2 writes it: the offered QoS of
    the latched topics (``/tf_static``, ``/scene/markers``, ``*/helm/mode``)."""
    latched = topic.endswith(("/tf_static", "/scene/markers", "/helm/mode"))
    return {"offered_qos_profiles": _dump([_LATCHED_QOS])} if latched else {}


def write_metadata(mcap_path: Path | str) -> Path:
    """Write ``metadata.yaml`` for the finished recording ``mcap_path`` into its folder
    (replacing one there); return its path. UhrisimError if the file has no summary
    (a cut recording: ``uhrisim recover`` it first)."""
    mcap_path = Path(mcap_path)
    with mcap_path.open("rb") as f:
        summary = make_reader(f).get_summary()
    if summary is None or summary.statistics is None:
        raise UhrisimError(f"{mcap_path}: no summary (a cut recording: run uhrisim recover)")
    stats = summary.statistics
    counts = stats.channel_message_counts
    start = stats.message_start_time if stats.message_count else 0
    duration = stats.message_end_time - start if stats.message_count else 0
    topics = []
    for channel_id, channel in sorted(summary.channels.items()):
        schema = summary.schemas.get(channel.schema_id)
        type_hash = (rihs01(schema.name, schema.data.decode()) if schema is not None
                     and schema.encoding == "ros2msg" else "")
        qos = yaml.safe_load(channel.metadata.get("offered_qos_profiles", "")) or []
        topics.append({
            "topic_metadata": {
                "name": channel.topic,
                "type": schema.name if schema is not None else "",
                "serialization_format": channel.message_encoding,
                "offered_qos_profiles": qos,
                "type_description_hash": type_hash,
            },
            "message_count": int(counts.get(channel_id, 0)),
        })
    info: dict[str, Any] = {
        "version": VERSION,
        "storage_identifier": "mcap",
        "relative_file_paths": [mcap_path.name],
        "duration": {"nanoseconds": int(duration)},
        "starting_time": {"nanoseconds_since_epoch": int(start)},
        "message_count": int(stats.message_count),
        "topics_with_message_count": topics,
        "compression_format": "",
        "compression_mode": "",
        "files": [{
            "path": mcap_path.name,
            "starting_time": {"nanoseconds_since_epoch": int(start)},
            "duration": {"nanoseconds": int(duration)},
            "message_count": int(stats.message_count),
        }],
        "custom_data": None,
        "ros_distro": "kilted",
    }
    return write_text_whole(mcap_path.parent / METADATA_NAME,
                            _dump({"rosbag2_bagfile_information": info}))
