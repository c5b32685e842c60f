"""The QoS the ROS 2 bridge offers each kind of topic, and what commands come in.

The topics themselves — names, message types and QoS kinds — are the ROS translation's
(:mod:`uhrisim.ros.topics`), the same the recording has; here each kind gets its
profile, with why it is what it is. Commands come in on ``<agent>/cmd/desired_*`` and
``<agent>/cmd/thrusters``. docs/bridges-ros2.md has the table with frames, units and
rates.
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from uhrisim.ros.topics import DESIRED_KEYS

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

#: Per-ping marker arrays (sonar perception): reliable, so RViz2's default subscriber
#: gets them.
QOS_MARKERS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE)

#: The profile of each kind of topic (:data:`uhrisim.ros.topics.QosKind`) and of the
#: commands; the sensor and clock kinds have a reliable variant the node's parameters
#: choose (:mod:`.params`).
QOS_BY_KIND: dict[str, QoSProfile] = {
    "state": QOS_STATE, "sensor": QOS_SENSOR, "latched": QOS_LATCHED, "tf": QOS_TF,
    "tf_static": QOS_TF_STATIC, "clock": QOS_CLOCK, "scene": QOS_SCENE,
    "markers": QOS_MARKERS, "command": QOS_COMMAND}


def qos_for(kind: str) -> QoSProfile:
    """The QoS profile of a kind of topic."""
    return QOS_BY_KIND[kind]


#: Command key of the thruster inputs (``/<agent>/cmd/thrusters``, Float64MultiArray).
THRUSTERS_KEY = "thrusters"
__all__ = ["DESIRED_KEYS", "QOS_BY_KIND", "THRUSTERS_KEY", "qos_for"]
