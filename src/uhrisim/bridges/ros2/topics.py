"""The ROS 2 bridge's topics and their QoS: what goes out per agent, what comes in.

Per agent (namespace ``/<agent>``): ``odom``, ``pose``, each sonar's ``<sonar>/polar``,
``<sonar>/fan``, ``<sonar>/points``, ``<sonar>/pose`` and ``<sonar>/image``
(marine_acoustic_msgs/ProjectedSonarImage), each camera's ``<camera>/image_raw``,
``<camera>/camera_info``, ``<camera>/depth``, ``<camera>/labels`` and ``<camera>/pose``
(a sensor's name: ``sonar`` and ``camera`` unless the scenario names them), the
helm's ``helm/desired_*``, ``helm/mode`` and ``helm/decision``, the community's ``vars``;
commands in on ``cmd/desired_*`` and ``cmd/thrusters``. Bridge-wide: ``/clock``,
``/scene/markers``, ``/tf``, ``/tf_static`` (the sonar and camera mounts) and ``/events``.
The topics whose message packages have no wheels exist when :mod:`.interfaces` has built
them. docs/bridges-ros2.md has the table
with frames, units and rates; the QoS profiles below say why each is what it is.
"""

from __future__ import annotations

import importlib.util

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
from std_msgs.msg import Float64, String

from .spec import AgentBridgeSpec

#: Odometry, pose, helm and scene: reliable, keep the last 10, volatile. A reliable
#: publisher matches reliable and best-effort subscribers alike; keep-last means a slow
#: or dead subscriber only loses old samples, the publisher never waits.
QOS_STATE = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
#: Sonar images and point clouds: the ROS "sensor data" convention, best effort, keep
#: the last 2. Subscribers must ask for best effort (``qos_profile_sensor_data``);
#: ``Ros2Bridge(reliable_sensors=True)`` switches to reliable keep-last-2 for tools that
#: only subscribe reliably.
QOS_SENSOR = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
QOS_SENSOR_RELIABLE = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
#: Scene markers: reliable, transient-local, keep the last 1, so a viewer that starts
#: late still receives the static scene.
QOS_SCENE = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
#: Helm mode: published when it changes, reliable and transient-local (keep the last 1),
#: so a node that subscribes later with transient-local durability still gets the mode
#: in force; a volatile subscriber matches too and gets every change from then on.
QOS_LATCHED = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
#: /clock: best effort, keep the last 1 (what rclpy's TimeSource subscribes with).
QOS_CLOCK = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
#: Command subscriptions: best effort, keep the last 10. A best-effort subscriber
#: matches both reliable and best-effort publishers; commands are latest-value and must
#: be re-sent faster than the timeout anyway, so a lost sample costs nothing.
QOS_COMMAND = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)

#: /tf: what tf2_ros's TransformBroadcaster uses (reliable, keep the last 100, volatile).
QOS_TF = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
#: /tf_static: what tf2_ros's StaticTransformBroadcaster uses (reliable, transient local,
#: keep the last 1): one message holding every static transform, sent once at start.
QOS_TF_STATIC = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)

#: The reliable variants of the sensor and clock profiles (``-p sensor_qos:=reliable``,
#: ``-p clock_qos:=reliable``), for tools that subscribe with rclpy's default reliable QoS
#: (RViz2's image and point-cloud displays by default, a plain ``create_subscription``).
QOS_CLOCK_RELIABLE = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Keys of the desired values (std_msgs/Float64): the helm's ``/<agent>/helm/<key>`` out,
#: the commands ``/<agent>/cmd/<key>`` in.
DESIRED_KEYS = ("desired_heading", "desired_speed", "desired_depth")
#: Command key of the thruster inputs (``/<agent>/cmd/thrusters``, Float64MultiArray).
THRUSTERS_KEY = "thrusters"


def sonar_topic_keys(sonar: str) -> tuple[str, ...]:
    """The keys (topics relative to the agent) of one sonar's products."""
    return tuple(f"{sonar}/{product}" for product in ("polar", "fan", "points", "pose"))


def agent_topics(spec: AgentBridgeSpec, sensor_qos: QoSProfile = QOS_SENSOR
                 ) -> list[tuple[str, str, type, QoSProfile]]:
    """``(key, topic, message type, QoS)`` of every topic the bridge publishes for one
    agent (besides the bridge-wide ones), as
    :meth:`~uhrisim.bridges.ros2.bridge.Ros2Bridge.start` creates them; ``sensor_qos`` is
    that of the sonar and camera images and hits. A key is the topic relative to the
    agent (``"odom"``, ``"sonar/polar"``, ``"camera/image_raw"``): each sonar and camera
    has its topics under its own name. Names are relative: they resolve in the node's
    namespace (``/<agent>/odom`` without one)."""
    ns = spec.name
    keys = [("odom", Odometry, QOS_STATE), ("pose", PoseStamped, QOS_STATE)]
    projected = importlib.util.find_spec("marine_acoustic_msgs") is not None
    for sonar in spec.sonars:
        if projected:
            from marine_acoustic_msgs.msg import ProjectedSonarImage

            keys.append((f"{sonar}/image", ProjectedSonarImage, sensor_qos))
        keys += [(f"{sonar}/polar", Image, sensor_qos), (f"{sonar}/fan", Image, sensor_qos),
                 (f"{sonar}/points", PointCloud2, sensor_qos),
                 (f"{sonar}/pose", PoseStamped, QOS_STATE)]
    for camera in spec.cameras:
        keys += [(f"{camera}/image_raw", Image, sensor_qos),
                 (f"{camera}/camera_info", CameraInfo, sensor_qos),
                 (f"{camera}/depth", Image, sensor_qos),
                 (f"{camera}/labels", Image, sensor_qos),
                 (f"{camera}/pose", PoseStamped, QOS_STATE)]
    keys += [(f"helm/{key}", Float64, QOS_STATE) for key in DESIRED_KEYS]
    keys.append(("helm/mode", String, QOS_LATCHED))
    if importlib.util.find_spec("uhrisim_msgs") is not None:
        from uhrisim_msgs.msg import HelmDecision, Variable

        keys += [("helm/decision", HelmDecision, QOS_STATE), ("vars", Variable, QOS_STATE)]
    return [(key, f"{ns}/{key}", msg_type, qos) for key, msg_type, qos in keys]
