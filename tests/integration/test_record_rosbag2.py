"""A run's output folder is a rosbag2 bag with the live bridge's topics (issue 16).

``uhrisim``'s runner records the track-and-trail mission for 3 s with the ROS 2 bridge
attached, the same mission with the VideoRay's camera (camera_trail), and with two sonars
(a P900-45 and a P900-130) and a camera (videoray_two_sonars). The folder must
open with ``rosbags.rosbag2.Reader`` (its metadata.yaml: the files, topics, types and
counts of the MCAP file; each topic's type hash the one rosidl gives the live publisher)
and every message must decode with rosbags and with mcap-ros2.
The recorded topics must be the topics the bridge's node publishes (asked of the ROS graph
during the run), uhrisim_msgs' helm decisions, community variables and events included,
each sensor's topics under its name; every sensor's mount is on /tf_static, and no sensor
frame on /tf. A recording cut short and recovered is a bag again.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
import yaml

pytest.importorskip("rclpy")
for _package in ("tf2_msgs", "marine_acoustic_msgs", "uhrisim_msgs"):  # the live topics
    pytest.importorskip(_package, reason="python -m uhrisim.bridges.ros2.interfaces")
rosbag2 = pytest.importorskip("rosbags.rosbag2")

from mcap.reader import make_reader  # noqa: E402
from mcap_ros2.reader import read_ros2_messages  # noqa: E402
from rosbags.highlevel import AnyReader  # noqa: E402

from uhrisim.app.runner import run_scenario  # noqa: E402
from uhrisim.bridges.ros2.hook import Ros2BridgeHook  # noqa: E402
from uhrisim.dynamics.diver_body import DiverSkeleton  # noqa: E402
from uhrisim.record.recover import recover_in_place  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = [ROOT / "scenarios" / name for name in ("track_and_trail.yaml",
                                                     "camera_trail.yaml",
                                                     "videoray_two_sonars.yaml")]
#: the VideoRay's sensors in each scenario: (sonar names, camera names)
SENSORS = {"track_and_trail": (["sonar"], []), "camera_trail": (["sonar"], ["camera"]),
           "videoray_two_sonars": (["narrow", "wide"], ["camera"])}
SONAR_PRODUCTS = ("polar", "fan", "points", "pose", "image")
CAMERA_PRODUCTS = ("image_raw", "camera_info", "depth", "labels", "pose")
NODE = "uhrisim_rosbag2_test"


class LiveTopics:
    """Asks the ROS graph, late in the run, which topics the bridge's node publishes."""

    def __init__(self, bridge_hook: Ros2BridgeHook) -> None:
        self.hook, self.topics, self.type_hashes = bridge_hook, None, {}

    def on_start(self, sim) -> None: ...
    def on_end(self, sim, error) -> None: ...

    def on_tick(self, frame) -> None:
        if self.topics is None and frame.t >= 2.5:
            node = self.hook.bridge._node
            self.topics = {name for name, _types in
                           node.get_publisher_names_and_types_by_node(NODE, "/")}
            for topic in self.topics:  # the type hash rosidl gave each live type
                for info in node.get_publishers_info_by_topic(topic):
                    self.type_hashes[topic] = str(info.topic_type_hash)


@pytest.mark.parametrize("scenario", SCENARIOS, ids=lambda path: path.stem)
def test_run_folder_is_a_rosbag2_bag_with_the_live_topics(ros_env: int, tmp_path: Path,
                                                          scenario: Path):
    out = tmp_path / "run"
    bridge = Ros2BridgeHook(domain_id=ros_env, node_name=NODE)
    live = LiveTopics(bridge)
    run_scenario(scenario, out, duration=3.0, figures=False, extra_hooks=[live, bridge],
                 configure=lambda sim: sim.record_event("note", "an event for /events"))

    meta = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["relative_file_paths"] == ["recording.mcap"]
    assert meta["storage_identifier"] == "mcap" and meta["version"] == 9
    declared = {t["topic_metadata"]["name"]: t["message_count"]
                for t in meta["topics_with_message_count"]}

    # rosbags: the folder as a rosbag2 bag, every message decoded
    with rosbag2.Reader(out) as reader:
        assert reader.message_count == meta["message_count"]
        assert {c.topic: c.msgcount for c in reader.connections} == declared
    static, tf_children = [], set()
    with AnyReader([out]) as reader:
        counted = Counter()
        for connection, _t, raw in reader.messages():
            msg = reader.deserialize(raw, connection.msgtype)
            counted[connection.topic] += 1
            if connection.topic == "/tf_static":
                static += [(t.header.frame_id, t.child_frame_id) for t in msg.transforms]
            elif connection.topic == "/tf":
                tf_children |= {t.child_frame_id for t in msg.transforms}
    assert counted == declared
    # mcap-ros2: the same messages from the .mcap file
    decoded = Counter(m.channel.topic for m in read_ros2_messages(out / "recording.mcap"))
    assert decoded == declared

    # the same topics as live (ROS's own node topics aside)
    assert live.topics is not None
    published = live.topics - {"/rosout", "/parameter_events"}
    recorded = set(declared)
    assert recorded == published
    assert {"/clock", "/tf", "/tf_static"} <= recorded
    if scenario.stem == "camera_trail":  # its articulated diver's joints, live and recorded
        assert "/diver/joint_states" in recorded
    # metadata.yaml's type hashes (computed from the recorded schemas) are rosidl's
    recorded_hashes = {t["topic_metadata"]["name"]: t["topic_metadata"]["type_description_hash"]
                       for t in meta["topics_with_message_count"]}
    assert recorded_hashes == {t: live.type_hashes[t] for t in recorded}
    # each sensor's topics under its own name, nothing under any other sensor name
    sonars, cameras = SENSORS[scenario.stem]
    sensor_topics = {f"/videoray/{s}/{p}" for s in sonars for p in SONAR_PRODUCTS}
    sensor_topics |= {f"/videoray/{c}/{p}" for c in cameras for p in CAMERA_PRODUCTS}
    assert sensor_topics <= recorded
    others = {t for t in recorded if t.startswith("/videoray/") and t.split("/")[2] not in
              ("odom", "pose", "helm", "vars")}
    assert others == sensor_topics
    # the sensor mounts on /tf_static (once), not on /tf (REP 105: map -> odom -> base_link)
    mounts = [("videoray/base_link", f"videoray/{s}") for s in sonars]
    mounts += [("videoray/base_link", f"videoray/{c}_optical") for c in cameras]
    assert static == mounts
    links = ({f"diver/{link}" for link in DiverSkeleton().links}  # its articulated diver's
             if scenario.stem == "camera_trail" else set())        # links, docs/teamwork.md
    assert tf_children == {"videoray/odom", "videoray/base_link", "diver/odom",
                           "diver/base_link"} | links

    # a run killed mid-way has no metadata.yaml; uhrisim recover makes the folder a bag
    data = (out / "recording.mcap").read_bytes()
    with (out / "recording.mcap").open("rb") as f:
        last_chunk = max(c.chunk_start_offset for c in make_reader(f).get_summary().chunk_indexes)
    (out / "metadata.yaml").unlink()
    (out / "recording.mcap").write_bytes(data[: last_chunk + 10])  # inside the last chunk
    count = recover_in_place(out / "recording.mcap")
    assert count is not None and 0 < count < meta["message_count"]
    with rosbag2.Reader(out) as reader:
        assert reader.message_count == count == sum(1 for _ in reader.messages())
