"""The ROS names of what uhrisim writes: topics, their message types and QoS kinds, frames.

Both outputs of the ROS translation — the recording (:mod:`uhrisim.record`, an MCAP
file) and the live bridge (:mod:`uhrisim.bridges.ros2`, DDS) — take every name from
here, so a live topic and a recorded one are equal by construction. Topic names are
relative (``"videoray/odom"``): the recording puts them under ``/``, the bridge resolves
them in its node's namespace. Per agent: ``odom``, ``pose``, each sonar's
``<sonar>/{polar,fan,points,pose,image}``, each camera's
``<camera>/{image_raw,camera_info,depth,labels,pose}``, the helm's
``helm/desired_{heading,speed,depth}``, ``helm/mode``, ``helm/decision``, the community's
``vars``, the sonar perception's ``perception/{detections,tracks}``; bridge-wide
``clock``, ``tf``, ``tf_static``, ``scene/markers``, ``events``. Frames: ``map`` (ENU),
``<agent>/odom``, ``<agent>/base_link``, ``<agent>/<sonar>``, ``<agent>/<camera>_optical``
(docs/bridges-ros2.md).
"""

from __future__ import annotations

import re
from typing import Literal

#: World frame of every pose and marker (REP-105 ``map``, ENU).
WORLD_FRAME = "map"
#: A ROS 2 name token (one namespace level): a letter, then letters, digits, underscores.
ROS_NAME_TOKEN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: A frame id: name tokens joined by ``/``.
FRAME_ID = re.compile(r"^[A-Za-z][A-Za-z0-9_/]*$")
_NOT_NAME = re.compile(r"[^A-Za-z0-9_]")

#: How a topic is offered: the bridge's QoS profile of each kind is in
#: :mod:`uhrisim.bridges.ros2.topics`; a recording notes the latched ones (rosbag2).
QosKind = Literal["state", "sensor", "latched", "tf", "tf_static", "clock", "scene",
                  "markers"]

ODOMETRY = "nav_msgs/msg/Odometry"
POSE = "geometry_msgs/msg/PoseStamped"
IMAGE = "sensor_msgs/msg/Image"
CLOUD = "sensor_msgs/msg/PointCloud2"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
PROJECTED_SONAR_IMAGE = "marine_acoustic_msgs/msg/ProjectedSonarImage"
FLOAT64 = "std_msgs/msg/Float64"
STRING = "std_msgs/msg/String"
TF = "tf2_msgs/msg/TFMessage"
JOINT_STATE = "sensor_msgs/msg/JointState"
CLOCK = "rosgraph_msgs/msg/Clock"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
HELM_DECISION = "uhrisim_msgs/msg/HelmDecision"
VARIABLE = "uhrisim_msgs/msg/Variable"
EVENT = "uhrisim_msgs/msg/Event"

#: Each sonar's products: topic under ``<agent>/<sonar>/`` -> (type, QoS kind).
SONAR_TOPICS: dict[str, tuple[str, QosKind]] = {
    "polar": (IMAGE, "sensor"), "fan": (IMAGE, "sensor"), "points": (CLOUD, "sensor"),
    "pose": (POSE, "state"), "image": (PROJECTED_SONAR_IMAGE, "sensor")}
#: Each camera's products: topic under ``<agent>/<camera>/`` -> (type, QoS kind).
CAMERA_TOPICS: dict[str, tuple[str, QosKind]] = {
    "image_raw": (IMAGE, "sensor"), "camera_info": (CAMERA_INFO, "sensor"),
    "depth": (IMAGE, "sensor"), "labels": (IMAGE, "sensor"), "pose": (POSE, "state")}
#: Keys of the helm's desired values: ``<agent>/helm/<key>`` out, ``<agent>/cmd/<key>`` in.
DESIRED_KEYS = ("desired_heading", "desired_speed", "desired_depth")
#: The perception's marker topics under ``<agent>/perception/``.
PERCEPTION_TOPICS = ("detections", "tracks")
#: Bridge-wide topics -> (type, QoS kind).
GLOBAL_TOPICS: dict[str, tuple[str, QosKind]] = {
    "clock": (CLOCK, "clock"), "tf": (TF, "tf"), "tf_static": (TF, "tf_static"),
    "scene/markers": (MARKER_ARRAY, "scene"), "events": (EVENT, "state")}


def ros_name(name: str) -> str:
    """A ROS-name-safe version of an agent name: other characters become ``_``.

    Names already valid (letter first, then letters, digits, ``_``) are unchanged.
    """
    out = _NOT_NAME.sub("_", str(name))
    return out if out[:1].isalpha() else f"a_{out}"


def camera_frame(camera: str) -> str:
    """A camera's frame under its agent: its REP-103 optical frame ``<camera>_optical``
    (x right, y down, z forward)."""
    return f"{camera}_optical"


def agent_topics(sonars: tuple[str, ...] = (), cameras: tuple[str, ...] = (),
                 helm: bool = True, joints: bool = False) -> list[tuple[str, str, QosKind]]:
    """``(topic relative to the agent, message type, QoS kind)`` of every topic written
    for an agent with these sonars and cameras (by name), with the helm's topics when it
    has a helm and ``joint_states`` when it is articulated (``joints``)."""
    topics: list[tuple[str, str, QosKind]] = [("odom", ODOMETRY, "state"),
                                              ("pose", POSE, "state")]
    topics += [(f"{s}/{key}", kind, qos) for s in sonars for key, (kind, qos)
               in SONAR_TOPICS.items()]
    topics += [(f"{c}/{key}", kind, qos) for c in cameras for key, (kind, qos)
               in CAMERA_TOPICS.items()]
    if helm:
        topics += [(f"helm/{key}", FLOAT64, "state") for key in DESIRED_KEYS]
        topics += [("helm/mode", STRING, "latched"),
                   ("helm/decision", HELM_DECISION, "state")]
    if joints:
        topics.append(("joint_states", JOINT_STATE, "state"))
    topics.append(("vars", VARIABLE, "state"))
    return topics
