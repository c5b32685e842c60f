"""The ROS 2 bridge: a read-only publish hook plus an external command input.

``Ros2Bridge`` owns one rclpy ``Context`` (never the global default one), one node
and a background executor thread that only serves the command subscriptions. The
simulation thread calls the ``publish_*`` methods (they serialize and hand the message
to DDS, and return; no call waits for a subscriber) and ``commands()`` (a lock-guarded
read of the latest values). Topics, frames, units, rates and QoS are documented in
docs/bridges-ros2.md; frame conversions happen only in :mod:`.convert`.

Time: every ``header.stamp`` is the simulation time ``t_sim``. With ``publish_clock``
the bridge also publishes ``/clock`` (rosgraph_msgs/Clock) so ROS nodes can run with
``use_sim_time:=true``.
"""

from __future__ import annotations

import array
import logging
import math
import struct
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import rclpy
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Odometry
from numpy.typing import ArrayLike
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, PointCloud2, PointField
from std_msgs.msg import Float64, Float64MultiArray, String
from visualization_msgs.msg import Marker, MarkerArray

from uhrisim.core.errors import BridgeError, ConfigError
from uhrisim.core.frames import enu_from_ned, wrap_360
from uhrisim.record.cdr import (
    CDR_LE_HEADER,
    CdrBuffer,
    OdometryEncoder,
    encode_image,
    encode_pointcloud2,
)

from .convert import (
    CLOUD_FIELDS,
    CLOUD_POINT_STEP,
    RateGate,
    cloud_xyzi_flu,
    odom_fields_from_ned,
    pose_enu_from_ned,
    stamp_from_sim_time,
)
from .spec import (
    THRUSTER_LIMIT,
    AgentBridgeSpec,
    AgentCommands,
    apply_env_defaults,
    check_domain_id,
)

log = logging.getLogger(__name__)

#: World frame of every pose and marker (REP-105 "map", ENU).
WORLD_FRAME = "map"

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

#: A failing topic is logged on its first failed write and then on every this many.
FAILURE_LOG_EVERY = 100

_MARKER_TYPES: dict[str, int] = {
    "box": Marker.CUBE,
    "sphere": Marker.SPHERE,
    "cylinder": Marker.CYLINDER,
    "line_strip": Marker.LINE_STRIP,
    "line_list": Marker.LINE_LIST,
    "points": Marker.POINTS,
    "triangle_list": Marker.TRIANGLE_LIST,
}
#: Marker types whose geometry is a list of world points (``points_ned``).
_POINT_MARKERS = frozenset({"line_strip", "line_list", "points", "triangle_list"})

#: What :meth:`Ros2Bridge.commands` answers before any command arrived.
_NO_COMMANDS = AgentCommands()

_CMD_KEYS_DESIRED = ("desired_heading", "desired_speed", "desired_depth")
#: Longest wait of the command executor for something to do (s).
_IDLE_SPIN_S = 1.0
_CMD_KEY_THRUSTERS = "thrusters"
#: What answers a lockstep round, per accepted command group: every topic of the group.
_ANSWER_GROUPS = {"desired": frozenset(_CMD_KEYS_DESIRED),
                  "thrusters": frozenset({_CMD_KEY_THRUSTERS})}


@dataclass
class _Slot:
    """One received command value with its receipt times (mutable, bridge-private)."""

    value: Any
    t_sim: float
    t_wall: float


def agent_topics(spec: AgentBridgeSpec, sensor_qos: QoSProfile = QOS_SENSOR
                 ) -> list[tuple[str, str, type, QoSProfile]]:
    """``(key, topic, message type, QoS)`` of every topic the bridge publishes for one
    agent (besides ``/clock`` and ``/scene/markers``), as :meth:`Ros2Bridge.start`
    creates them; ``sensor_qos`` is that of the sonar images and hits."""
    ns = f"/{spec.name}"
    topics = [("odom", f"{ns}/odom", Odometry, QOS_STATE),
              ("pose", f"{ns}/pose", PoseStamped, QOS_STATE)]
    if spec.publish_sonar:
        topics += [("polar", f"{ns}/sonar/polar", Image, sensor_qos),
                   ("fan", f"{ns}/sonar/fan", Image, sensor_qos),
                   ("points", f"{ns}/sonar/points", PointCloud2, sensor_qos),
                   ("sonar_pose", f"{ns}/sonar/pose", PoseStamped, QOS_STATE)]
    topics += [(f"helm_{key}", f"{ns}/helm/{key}", Float64, QOS_STATE)
               for key in ("desired_heading", "desired_speed", "desired_depth")]
    topics.append(("helm_mode", f"{ns}/helm/mode", String, QOS_LATCHED))
    return topics


class _AgentIO:
    """Publishers, rate gates and command slots of one agent (bridge-private)."""

    def __init__(self, spec: AgentBridgeSpec) -> None:
        self.spec = spec
        self.nav_gate = RateGate(spec.odom_rate_hz)
        self.sonar_gate = RateGate(spec.sonar_rate_hz)
        # odometry and pose go out pre-serialised (a few us instead of ~30 us a message)
        self.odometry = OdometryEncoder(WORLD_FRAME, f"{spec.name}/base_link")
        self.pose = PoseStampedEncoder(WORLD_FRAME)
        self.pubs: dict[str, Any] = {}
        self.topics = {key: topic for key, topic, _, _ in agent_topics(spec)}
        self.mode_text: str | None = None  # the last helm mode published
        self.subs: dict[str, Any] = {}  # command key -> subscription
        self.slots: dict[str, _Slot] = {}
        self.received = 0  # command messages accepted so far
        self.answered: set[str] = set()  # command keys received since begin_round

    def has_answered(self) -> bool:
        """Since the last :meth:`Ros2Bridge.begin_round`, a whole command group this
        agent accepts has arrived (all three desired values, or the thrusters)."""
        return any(_ANSWER_GROUPS[group] <= self.answered for group in self.spec.accept)


def _poll_until(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Check ``condition`` every 20 ms (wall clock) until it holds, at most ``timeout_s``
    (ROS graph changes, which rclpy only lets us poll); True when it held."""
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.02)
    return True


def _set_stamp(header: Any, t_sim: float, frame_id: str) -> None:
    sec, nanosec = stamp_from_sim_time(t_sim)
    header.stamp.sec = sec
    header.stamp.nanosec = nanosec
    header.frame_id = frame_id


def _mono8(img: np.ndarray, where: str) -> np.ndarray:
    """``img`` as a C-contiguous 2-D uint8 array, or a ConfigError naming ``where``."""
    a = np.asarray(img)
    if a.dtype != np.uint8 or a.ndim != 2:
        raise ConfigError(f"expected a 2-D uint8 image, got {a.dtype} {a.shape}", where)
    return np.ascontiguousarray(a)


def image_msg(img: np.ndarray, t_sim: float, frame_id: str, where: str = "image") -> Image:
    """sensor_msgs/Image ``mono8`` of a 2-D uint8 array (row-major, step = width),
    stamped with simulation time ``t_sim`` (s): the message whose bytes
    :meth:`Ros2Bridge.publish_sonar` sends (tests hold the two together)."""
    a = _mono8(img, where)
    msg = Image()
    _set_stamp(msg.header, t_sim, frame_id)
    msg.height, msg.width = int(a.shape[0]), int(a.shape[1])
    msg.encoding = "mono8"
    msg.is_bigendian = 0
    msg.step = int(a.shape[1])
    data = array.array("B")
    data.frombytes(memoryview(a.reshape(-1)))
    msg.data = data
    return msg


def odometry_msg(
    agent: str,
    t_sim: float,
    position_ned: ArrayLike,
    yaw_rad: float,
    velocity_body_frd: ArrayLike,
    yaw_rate: float,
) -> Odometry:
    """nav_msgs/Odometry (``"map"`` -> ``"<agent>/base_link"``, REP-103) from NED/FRD
    truth; see :func:`~uhrisim.bridges.ros2.convert.odom_fields_from_ned`."""
    f = odom_fields_from_ned(position_ned, yaw_rad, velocity_body_frd, yaw_rate)
    odom = Odometry()
    _set_stamp(odom.header, t_sim, WORLD_FRAME)
    odom.child_frame_id = f"{agent}/base_link"
    pp = odom.pose.pose
    pp.position.x, pp.position.y, pp.position.z = f.position_enu
    o = pp.orientation
    o.x, o.y, o.z, o.w = f.orientation_xyzw
    tw = odom.twist.twist
    tw.linear.x, tw.linear.y, tw.linear.z = f.linear_flu
    tw.angular.x, tw.angular.y, tw.angular.z = f.angular_flu
    return odom


class PoseStampedEncoder:
    """geometry_msgs/PoseStamped in a fixed frame, serialised (CDR, little endian) by one
    precompiled ``struct``: the bytes rclpy makes of the message, without building one.
    ``tests/integration/test_ros2_convert.py`` holds it to rclpy's serialisation."""

    __slots__ = ("_frame", "_struct")

    def __init__(self, frame_id: str) -> None:
        self._frame = frame_id.encode("utf-8") + b"\x00"
        end_of_frame = 8 + 4 + len(self._frame)  # stamp, string length, string (+ NUL)
        pad = -end_of_frame % 8  # the pose's doubles are 8-aligned
        self._struct = struct.Struct(f"<4siII{len(self._frame)}s{pad}x7d")

    def __call__(self, sec: int, nanosec: int, position: Sequence[float],
                 orientation_xyzw: Sequence[float]) -> bytes:
        return self._struct.pack(CDR_LE_HEADER, sec, nanosec, len(self._frame), self._frame,
                                 *position, *orientation_xyzw)


#: rosgraph_msgs/Clock serialised (CDR little endian): header, int32 sec, uint32 nanosec.
_CLOCK_CDR = struct.Struct("<4siI")
#: std_msgs/Float64 serialised: header, then the double (8-aligned at offset 0).
_FLOAT64_CDR = struct.Struct("<4sd")


def clock_bytes(t_sim: float) -> bytes:
    """The serialised rosgraph_msgs/Clock of simulation time ``t_sim`` (s): what rclpy
    makes of the message (tests/integration/test_ros2_inprocess.py holds it to that)."""
    sec, nanosec = stamp_from_sim_time(t_sim)
    return _CLOCK_CDR.pack(CDR_LE_HEADER, sec, nanosec)


def float64_bytes(value: float) -> bytes:
    """The serialised std_msgs/Float64 of ``value``."""
    return _FLOAT64_CDR.pack(CDR_LE_HEADER, value)


def string_bytes(text: str) -> bytes:
    """The serialised std_msgs/String of ``text`` (uint32 length with the NUL, UTF-8
    bytes, NUL)."""
    cdr = CdrBuffer()
    cdr.string(text)
    return cdr.getvalue()


def pointcloud_msg(
    t_sim: float, frame_id: str, points_frd: ArrayLike, intensity: ArrayLike | None = None
) -> PointCloud2:
    """sensor_msgs/PointCloud2 (height 1; x, y, z, intensity float32 LE, 16 bytes a
    point) of ``(N, 3)`` sensor-frame FRD points, written in the sensor's FLU frame: the
    message whose bytes :meth:`Ros2Bridge.publish_sonar` sends (tests hold the two
    together)."""
    xyzi = cloud_xyzi_flu(points_frd, intensity)
    n = xyzi.shape[0]
    cloud = PointCloud2()
    _set_stamp(cloud.header, t_sim, frame_id)
    cloud.height, cloud.width = 1, n
    cloud.fields = [
        PointField(name=name, offset=off, datatype=PointField.FLOAT32, count=1)
        for name, off in CLOUD_FIELDS
    ]
    cloud.is_bigendian = False
    cloud.point_step = CLOUD_POINT_STEP
    cloud.row_step = CLOUD_POINT_STEP * n
    cloud.is_dense = True
    data = array.array("B")
    data.frombytes(xyzi.reshape(-1).view(np.uint8))
    cloud.data = data
    return cloud


class Ros2Bridge:
    """Publishes simulation state to ROS 2 and collects external commands.

    Parameters
    ----------
    agents:
        One :class:`AgentBridgeSpec` per agent (a ROS namespace ``/<name>``).
    node_name:
        Name of the bridge's ROS node.
    domain_id:
        ROS domain id (0-232); ``None`` uses ``ROS_DOMAIN_ID`` (or 0).
    command_timeout_s:
        Commands older than this are dropped from :meth:`commands` (and make ``stale``
        True once all are older).
    timeout_clock:
        ``"sim"`` (default): a command's age is simulation time since its receipt,
        where "receipt" is the newest ``t_sim`` the simulation had passed to the bridge
        when the message arrived; right for paced runs and deterministic in lockstep.
        ``"wall"``: monotonic wall seconds since receipt; right when the simulation
        runs much faster than real time and commands come from a real-time node.
    publish_clock:
        Publish ``/clock`` whenever simulation time changes in a ``publish_*`` call (or
        on :meth:`publish_clock`).
    clock_rate_hz:
        Throttle ``/clock`` to this rate in simulation time (``None``: every change).
        Worth setting when the loop runs free at thousands of ticks per second.
    reliable_sensors:
        Publish sonar images/clouds reliably instead of best effort (see QoS).
    publish_unsubscribed:
        Write every message even to topics nobody subscribes to. By default a volatile
        topic without a matched subscriber is skipped (no subscriber could receive what
        it missed; the conversion and the DDS write are saved); the latched
        ``/helm/mode`` and ``/scene/markers`` are always written.
    reliable_commands:
        Subscribe to the commands reliably (keep the last 10) instead of best effort:
        for lockstep runs, where a lost command would stall a round. Such subscriptions
        match reliable publishers only (rclpy's default).
    """

    def __init__(
        self,
        agents: Sequence[AgentBridgeSpec],
        node_name: str = "uhrisim",
        domain_id: int | None = None,
        command_timeout_s: float = 1.0,
        *,
        timeout_clock: Literal["sim", "wall"] = "sim",
        publish_clock: bool = True,
        clock_rate_hz: float | None = None,
        reliable_sensors: bool = False,
        publish_unsubscribed: bool = False,
        reliable_commands: bool = False,
    ) -> None:
        specs = list(agents)
        if not all(isinstance(s, AgentBridgeSpec) for s in specs):
            raise ConfigError("each agent must be an AgentBridgeSpec", "Ros2Bridge.agents")
        names = [s.name for s in specs]
        if len(set(names)) != len(names):
            raise ConfigError(f"agent names must be unique, got {names}", "Ros2Bridge.agents")
        if not (isinstance(command_timeout_s, int | float) and command_timeout_s > 0.0
                and math.isfinite(command_timeout_s)):
            raise ConfigError(
                f"must be a positive number of seconds, got {command_timeout_s!r}",
                "Ros2Bridge.command_timeout_s",
            )
        if timeout_clock not in ("sim", "wall"):
            raise ConfigError(
                f"must be 'sim' or 'wall', got {timeout_clock!r}", "Ros2Bridge.timeout_clock"
            )
        self._node_name = node_name
        self._domain_id = check_domain_id(domain_id)
        self._timeout = float(command_timeout_s)
        self._timeout_clock = timeout_clock
        self._publish_clock = publish_clock
        self._clock_gate = RateGate(clock_rate_hz)
        self._sensor_qos = QOS_SENSOR_RELIABLE if reliable_sensors else QOS_SENSOR
        self._publish_unsubscribed = publish_unsubscribed
        # reliable commands: the state profile's settings (reliable, keep the last 10)
        self._command_qos = QOS_STATE if reliable_commands else QOS_COMMAND
        self._agents = {s.name: _AgentIO(s) for s in specs}
        self._lock = threading.Lock()
        self._answers = threading.Condition(self._lock)  # lockstep rounds wait on it
        self._t_sim_latest = 0.0
        self._t_clock_published: float | None = None
        self._counts: dict[str, int] = {}
        self._failed: dict[str, int] = {}
        self._rejected = 0
        self._context: Context | None = None
        self._node: Any = None
        self._executor: SingleThreadedExecutor | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._closed = False
        self._pub_clock: Any = None
        self._pub_scene: Any = None

    # ----------------------------------------------------------------- lifecycle
    @property
    def started(self) -> bool:
        """True between :meth:`start` and :meth:`close`."""
        return self._node is not None and not self._closed

    @property
    def agents(self) -> tuple[AgentBridgeSpec, ...]:
        """The agent specs, in the order given."""
        return tuple(io.spec for io in self._agents.values())

    def start(self) -> None:
        """Create the context, node, publishers, subscriptions and the executor thread.

        Applies :data:`~uhrisim.bridges.ros2.spec.ENV_DEFAULTS` to ``os.environ`` first
        (discovery on localhost unless the user chose otherwise). Installs no signal
        handlers.
        """
        if self._closed:
            raise BridgeError("Ros2Bridge: cannot start a closed bridge; make a new one")
        if self._node is not None:
            return
        applied = apply_env_defaults()
        if applied:
            log.info("ROS 2 environment defaults applied: %s", applied)
        ctx = Context()
        try:
            rclpy.init(
                context=ctx,
                domain_id=self._domain_id,
                signal_handler_options=SignalHandlerOptions.NO,
            )
            node = rclpy.create_node(
                self._node_name, context=ctx, start_parameter_services=False
            )
        except Exception as exc:
            ctx.try_shutdown()
            raise BridgeError(f"Ros2Bridge: could not start ROS 2 node: {exc}") from exc
        self._context, self._node = ctx, node
        if self._publish_clock:
            self._pub_clock = node.create_publisher(Clock, "/clock", QOS_CLOCK)
        self._pub_scene = node.create_publisher(MarkerArray, "/scene/markers", QOS_SCENE)
        for name, io in self._agents.items():
            for key, topic, msg_type, qos in agent_topics(io.spec, self._sensor_qos):
                io.pubs[key] = node.create_publisher(msg_type, topic, qos)
            if "desired" in io.spec.accept:
                for key in _CMD_KEYS_DESIRED:
                    io.subs[key] = node.create_subscription(
                        Float64, f"/{name}/cmd/{key}", self._make_float_cb(name, key),
                        self._command_qos,
                    )
            if "thrusters" in io.spec.accept:
                io.subs[_CMD_KEY_THRUSTERS] = node.create_subscription(
                    Float64MultiArray, f"/{name}/cmd/thrusters", self._make_thruster_cb(name),
                    self._command_qos,
                )
        self._executor = SingleThreadedExecutor(context=ctx)
        self._executor.add_node(node)
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._spin, name=f"uhrisim-ros2-{self._node_name}", daemon=True
        )
        self._thread.start()
        log.info(
            "ROS 2 bridge %r started: domain %s, agents %s",
            self._node_name, self._domain_id, list(self._agents),
        )

    def _spin(self) -> None:
        ex = self._executor
        assert ex is not None
        while not self._stop.is_set():
            try:
                # an idle turn costs ~1 ms of CPU; close() wakes the executor at once
                ex.spin_once(timeout_sec=_IDLE_SPIN_S)
            except ExternalShutdownException:
                break
            except Exception:  # a failing callback must not kill the command path
                if self._stop.is_set():
                    break
                log.exception("ROS 2 bridge executor error")

    def close(self) -> None:
        """Stop the executor thread and shut the context down. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        if self._executor is not None:
            self._executor.wake()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            if self._thread.is_alive():
                log.warning("ROS 2 bridge executor thread did not stop within 5 s")
        if self._executor is not None:
            self._executor.shutdown(timeout_sec=1.0)
        if self._node is not None:
            self._node.destroy_node()
        if self._context is not None:
            self._context.try_shutdown()
        log.info("ROS 2 bridge %r closed", self._node_name)

    def __enter__(self) -> Ros2Bridge:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----------------------------------------------------------------- helpers
    def _io(self, agent: str, where: str) -> _AgentIO:
        if not self.started:
            raise BridgeError(f"Ros2Bridge.{where}: bridge is not running (call start())")
        io = self._agents.get(agent)
        if io is None:
            raise ConfigError(
                f"unknown agent {agent!r}; known: {list(self._agents)}", f"Ros2Bridge.{where}"
            )
        return io

    def _advance(self, t_sim: float) -> None:
        t = float(t_sim)
        # one attribute store is atomic: the command callbacks read it under the lock
        self._t_sim_latest = t
        if (
            self._pub_clock is not None
            and t != self._t_clock_published
            and self._clock_gate.due(t)
        ):
            if self._wanted(self._pub_clock):
                # pre-serialised: the bytes of a rosgraph_msgs/Clock, without building one
                self._publish(self._pub_clock, clock_bytes(t), "/clock")
            self._t_clock_published = t

    def _wanted(self, pub: Any) -> bool:
        """Should a message go to ``pub``'s topic: someone subscribed (well under 1 us)?
        A publisher that cannot tell (ROS shut down under the bridge) says yes: the write
        then fails and is counted by :meth:`_publish`."""
        if self._publish_unsubscribed:
            return True
        try:
            return pub.handle.get_subscription_count() > 0
        except Exception:
            return True

    def _publish(self, pub: Any, msg: Any, key: str) -> None:
        """Hand one message to DDS. A write that fails (the context shut down by someone
        else, a full history in asynchronous publication mode) is counted per topic and
        logged, the first of each topic and then every :data:`FAILURE_LOG_EVERY`-th; the
        simulation goes on (nothing in the loop waits for or depends on ROS)."""
        try:
            if type(msg) is bytes:  # serialised: straight to rcl (what publish() calls)
                pub.handle.publish_raw(msg)
            else:
                pub.publish(msg)
        except Exception as exc:
            failed = self._failed[key] = self._failed.get(key, 0) + 1
            if failed == 1 or failed % FAILURE_LOG_EVERY == 0:
                log.warning("ROS 2 bridge: publishing %s failed (%d so far; the simulation "
                            "goes on): %s", key, failed, exc)
            return
        counts = self._counts  # written by this (the simulation's) thread only
        counts[key] = counts.get(key, 0) + 1

    # ----------------------------------------------------------------- publishing
    def note_time(self, t_sim: float) -> None:
        """Tell the bridge the simulation time (s) without publishing anything: the
        receipt time of commands that arrive next (``timeout_clock="sim"``)."""
        self._t_sim_latest = float(t_sim)

    @property
    def wake_time(self) -> float:
        """Before this simulation time (s) neither ``/clock`` nor any agent's odometry is
        due: a loop may call only :meth:`note_time` until then (sonar pings and helm
        decisions are not gated by it)."""
        wake = self._clock_gate.wake_time if self._pub_clock is not None else math.inf
        for io in self._agents.values():
            wake = min(wake, io.nav_gate.wake_time)
        return wake

    def publish_clock(self, t_sim: float) -> None:
        """Publish ``/clock`` at ``t_sim`` (s) if it changed (every ``publish_*`` call
        does this too); for loops that tick without publishing anything else."""
        if not self.started:
            raise BridgeError("Ros2Bridge.publish_clock: bridge is not running (call start())")
        self._advance(t_sim)

    def publish_nav(
        self,
        agent: str,
        t_sim: float,
        position_ned: ArrayLike,
        yaw_rad: float,
        velocity_body_frd: ArrayLike,
        yaw_rate: float,
    ) -> bool:
        """Publish ``/<agent>/odom`` (nav_msgs/Odometry) and ``/<agent>/pose``
        (geometry_msgs/PoseStamped) if the agent's odometry rate gate is due.

        Inputs in uhrisim frames: ``position_ned`` (m), ``yaw_rad`` (compass, rad),
        ``velocity_body_frd`` (m/s), ``yaw_rate`` (rad/s, clockwise positive). Out:
        pose in ``"map"`` (ENU), twist in ``"<agent>/base_link"`` (FLU). Each goes out
        only while someone subscribes to it (see ``publish_unsubscribed``). Returns True
        when messages went out.
        """
        io = self._io(agent, "publish_nav")
        self._advance(t_sim)
        if not io.nav_gate.due(t_sim):
            return False
        f = odom_fields_from_ned(position_ned, yaw_rad, velocity_body_frd, yaw_rate)  # checks
        odom_wanted, pose_wanted = self._wanted(io.pubs["odom"]), self._wanted(io.pubs["pose"])
        if not (odom_wanted or pose_wanted):
            return False
        sec, nanosec = stamp_from_sim_time(t_sim)
        if odom_wanted:
            odom = io.odometry(sec, nanosec, f.position_enu, f.orientation_xyzw, f.linear_flu,
                               f.angular_flu)  # the bytes of odometry_msg(...)
            self._publish(io.pubs["odom"], odom, io.topics["odom"])
        if pose_wanted:
            pose = io.pose(sec, nanosec, f.position_enu, f.orientation_xyzw)
            self._publish(io.pubs["pose"], pose, io.topics["pose"])
        return True

    def odometry_due(self, agent: str, t_sim: float) -> bool:
        """Would :meth:`publish_nav` publish ``agent``'s odometry at ``t_sim`` (s)? Lets a
        caller skip gathering navigation data that would not go out. When the rate gate
        is due but nobody subscribes to the odometry or the pose, the answer is False and
        the gate moves on to its next period, as if the odometry had gone out."""
        io = self._io(agent, "odometry_due")
        if not io.nav_gate.is_due(t_sim):
            return False
        if self._wanted(io.pubs["odom"]) or self._wanted(io.pubs["pose"]):
            return True
        io.nav_gate.due(t_sim)  # nothing to send: pass the slot
        return False

    def sonar_subscribed(self, agent: str) -> tuple[bool, bool, bool]:
        """Whether ``/<agent>/sonar/polar``, ``/fan`` and ``/points`` have a matched
        subscriber now (a fraction of a microsecond each; all True with
        ``publish_unsubscribed``). :meth:`publish_sonar` skips the others; a caller may
        skip forming those products (the simulation hook does; the fan image is the
        costly one)."""
        io = self._io(agent, "sonar_subscribed")
        if not io.spec.publish_sonar:
            return False, False, False
        p = io.pubs
        return self._wanted(p["polar"]), self._wanted(p["fan"]), self._wanted(p["points"])

    def publish_sonar(
        self,
        agent: str,
        t_sim: float,
        polar_u8: np.ndarray | None,
        fan_u8: np.ndarray | None,
        points_sonar_frd: ArrayLike | None = None,
        intensity: ArrayLike | None = None,
        sonar_pose_ned: tuple[ArrayLike, ArrayLike] | None = None,
    ) -> bool:
        """Publish the sonar products if the agent's sonar rate gate is due.

        ``polar_u8``: 2-D uint8, rows = range bins, columns = beams, as the sonar model
        forms it -> ``/<agent>/sonar/polar``; ``fan_u8``: 2-D uint8 scan-converted image
        -> ``/<agent>/sonar/fan`` (both sensor_msgs/Image mono8, frame
        ``"<agent>/sonar"``). ``points_sonar_frd``: ``(N, 3)`` hits in the sonar's FRD
        frame (m), with optional ``(N,)`` ``intensity`` -> ``/<agent>/sonar/points``
        (sensor_msgs/PointCloud2, x y z intensity float32, sonar FLU frame).
        ``sonar_pose_ned``: ``(position_ned (3,), rotation (3x3) sonar FRD -> NED)`` ->
        ``/<agent>/sonar/pose`` (geometry_msgs/PoseStamped in ``"map"``: where the
        ``"<agent>/sonar"`` frame is, since there is no /tf). Any ``None`` product, and
        any whose topic nobody subscribes to, is skipped. Returns True when the gate was
        due.
        """
        io = self._io(agent, "publish_sonar")
        if not io.spec.publish_sonar:
            raise ConfigError(
                f"agent {agent!r} was configured with publish_sonar=False",
                "Ros2Bridge.publish_sonar",
            )
        self._advance(t_sim)
        if not io.sonar_gate.due(t_sim):
            return False
        frame = f"{agent}/sonar"
        # every product given is checked, whether or not someone subscribes to it
        images = [(key, _mono8(image, f"Ros2Bridge.publish_sonar.{key}_u8"))
                  for key, image in (("polar", polar_u8), ("fan", fan_u8)) if image is not None]
        xyzi = None if points_sonar_frd is None else cloud_xyzi_flu(points_sonar_frd, intensity)
        pose = None if sonar_pose_ned is None else pose_enu_from_ned(*sonar_pose_ned)
        sec, nanosec = stamp_from_sim_time(t_sim)
        # pre-serialised, as image_msg / pointcloud_msg / PoseStamped would be: the
        # pixels and points are copied once, into the bytes handed to DDS
        for key, image in images:
            if self._wanted(io.pubs[key]):
                self._publish(io.pubs[key], encode_image(sec, nanosec, frame, image),
                              io.topics[key])
        if xyzi is not None and self._wanted(io.pubs["points"]):
            self._publish(io.pubs["points"], encode_pointcloud2(sec, nanosec, frame, xyzi),
                          io.topics["points"])
        if pose is not None and self._wanted(io.pubs["sonar_pose"]):
            self._publish(io.pubs["sonar_pose"], io.pose(sec, nanosec, *pose),
                          io.topics["sonar_pose"])
        return True

    def publish_helm(
        self,
        agent: str,
        t_sim: float,
        heading_deg: float | None,
        speed: float | None,
        depth: float | None,
        mode: str,
    ) -> None:
        """Publish the helm's decision: ``/<agent>/helm/desired_heading`` (compass deg),
        ``/<agent>/helm/desired_speed`` (m/s), ``/<agent>/helm/desired_depth`` (m, down)
        as std_msgs/Float64 (each skipped when ``None``) and, when it differs from the
        last one, ``/<agent>/helm/mode`` (std_msgs/String, e.g. ``"MODE@ACTIVE:TRAIL"``,
        latched: see :data:`QOS_LATCHED`). Not rate-gated: the helm's own rate applies.
        The desired values go out only while someone subscribes to them; the mode always.
        """
        io = self._io(agent, "publish_helm")
        self._advance(t_sim)
        # pre-serialised std_msgs/Float64 and String (the bytes rclpy would make)
        for key, value in (
            ("desired_heading", heading_deg),
            ("desired_speed", speed),
            ("desired_depth", depth),
        ):
            if value is None:
                continue
            raw = float64_bytes(float(value))  # a bad value fails, subscribed or not
            if self._wanted(io.pubs[f"helm_{key}"]):
                self._publish(io.pubs[f"helm_{key}"], raw, io.topics[f"helm_{key}"])
        mode = str(mode)
        if mode != io.mode_text:
            io.mode_text = mode
            self._publish(io.pubs["helm_mode"], string_bytes(mode), io.topics["helm_mode"])

    def publish_scene(self, t_sim: float, markers: Sequence[Mapping[str, Any]]) -> None:
        """Publish ``/scene/markers`` (visualization_msgs/MarkerArray, frame ``"map"``).

        Each marker is a mapping with ``ns`` (str), ``id`` (int), ``type`` (``"box"``,
        ``"cylinder"``, ``"sphere"``; or, with ``points_ned`` (N, 3) m in the world frame,
        ``"line_strip"``, ``"line_list"``, ``"points"``, ``"triangle_list"`` — what
        :func:`uhrisim.record.hook.scene_markers` makes of the scene's meshes),
        ``position_ned`` (3,) m and optional ``rotation`` (3x3, object frame -> NED) for
        the solids, ``scale`` (3,) (solids: full sizes in m along the object's axes;
        lines: ``scale[0]`` = width; points: ``scale[0:2]`` = size; triangle lists: 1),
        ``color`` (r, g, b, a in 0..1) and an optional ``text`` label.
        """
        if not self.started:
            raise BridgeError("Ros2Bridge.publish_scene: bridge is not running (call start())")
        self._advance(t_sim)
        arr = MarkerArray()
        arr.markers = [self._marker(t_sim, i, m) for i, m in enumerate(markers)]
        self._publish(self._pub_scene, arr, "/scene/markers")

    @staticmethod
    def _marker(t_sim: float, i: int, spec: Mapping[str, Any]) -> Marker:
        where = f"Ros2Bridge.publish_scene.markers[{i}]"
        try:
            kind = spec["type"]
            if kind not in _MARKER_TYPES:
                raise ConfigError(
                    f"type {kind!r} not one of {sorted(_MARKER_TYPES)}", f"{where}.type"
                )
            m = Marker()
            _set_stamp(m.header, t_sim, WORLD_FRAME)
            m.ns = str(spec.get("ns", ""))
            m.id = int(spec["id"])
            m.type = _MARKER_TYPES[kind]
            m.action = Marker.ADD
            if kind in _POINT_MARKERS:
                pts = np.asarray(spec["points_ned"], dtype=float)
                if pts.ndim != 2 or pts.shape[1] != 3:
                    raise ConfigError(f"expected (N, 3), got {pts.shape}", f"{where}.points_ned")
                # points are world coordinates: the marker pose is the ENU identity
                pos, quat = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
                m.points = [Point(x=x, y=y, z=z) for x, y, z in enu_from_ned(pts).tolist()]
            else:
                pos, quat = pose_enu_from_ned(spec["position_ned"], spec.get("rotation"))
            m.pose.position.x, m.pose.position.y, m.pose.position.z = pos
            o = m.pose.orientation
            o.x, o.y, o.z, o.w = quat
            if "text" in spec:
                m.text = str(spec["text"])
            scale = np.broadcast_to(np.asarray(spec.get("scale", 1.0), dtype=float), (3,))
            m.scale.x, m.scale.y, m.scale.z = (float(s) for s in scale)
            rgba = [float(c) for c in spec.get("color", (0.7, 0.7, 0.7, 1.0))]
            if len(rgba) != 4:
                raise ConfigError(f"color needs 4 values (rgba), got {len(rgba)}", where)
            m.color.r, m.color.g, m.color.b, m.color.a = rgba
        except KeyError as exc:
            raise ConfigError(f"missing key {exc.args[0]!r}", where) from exc
        except ConfigError:
            raise
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"bad value: {exc}", where) from exc
        return m

    # ----------------------------------------------------------------- commands
    def _store(self, agent: str, key: str, value: Any) -> None:
        with self._lock:
            io = self._agents[agent]
            io.slots[key] = _Slot(value, self._t_sim_latest, time.monotonic())
            io.received += 1
            io.answered.add(key)
            self._answers.notify_all()

    def _reject(self, agent: str, key: str, why: str) -> None:
        with self._lock:
            self._rejected += 1
            first = self._rejected == 1
        (log.warning if first else log.debug)(
            "ROS 2 bridge rejected /%s/cmd/%s: %s", agent, key, why
        )

    def _make_float_cb(self, agent: str, key: str) -> Any:
        def cb(msg: Float64) -> None:
            v = float(msg.data)
            if not math.isfinite(v):
                self._reject(agent, key, f"not finite ({v})")
                return
            if key == "desired_heading":
                v = float(wrap_360(v))
            elif key == "desired_depth" and v < 0.0:
                v = 0.0  # above the surface is not reachable: hold at the surface
            self._store(agent, key, v)

        return cb

    def _make_thruster_cb(self, agent: str) -> Any:
        def cb(msg: Float64MultiArray) -> None:
            vals = [float(x) for x in msg.data]
            if len(vals) != 3 or not all(math.isfinite(x) for x in vals):
                self._reject(agent, _CMD_KEY_THRUSTERS, f"need 3 finite values, got {vals}")
                return
            lim = THRUSTER_LIMIT
            clipped = tuple(min(lim, max(-lim, x)) for x in vals)
            self._store(agent, _CMD_KEY_THRUSTERS, clipped)

        return cb

    def commands(self, agent: str, t_sim: float) -> AgentCommands:
        """The fresh commands for ``agent`` at simulation time ``t_sim`` (s).

        See :class:`AgentCommands` for the meaning of ``None`` and ``stale``. Also records
        ``t_sim`` as the bridge's current simulation time (the receipt time of commands
        that arrive next, with ``timeout_clock="sim"``).
        """
        io = self._io(agent, "commands")
        t = float(t_sim)
        if not io.slots:  # nothing ever received (slots only grow): no lock, no clock read
            self._t_sim_latest = t
            return _NO_COMMANDS
        now_wall = time.monotonic()
        with self._lock:
            self._t_sim_latest = t
            slots = dict(io.slots)
            received = io.received
        ages = {
            k: (t - s.t_sim) if self._timeout_clock == "sim" else (now_wall - s.t_wall)
            for k, s in slots.items()
        }
        fresh = {k: slots[k].value for k, age in ages.items() if age <= self._timeout}
        newest = min(ages.values()) if ages else None
        return AgentCommands(
            desired_heading_deg=fresh.get("desired_heading"),
            desired_speed=fresh.get("desired_speed"),
            desired_depth=fresh.get("desired_depth"),
            thrusters=fresh.get(_CMD_KEY_THRUSTERS),
            stale=bool(slots) and not fresh,
            age_s=newest,
            received_count=received,
        )

    # ----------------------------------------------------------------- introspection
    def stats(self) -> dict[str, Any]:
        """Messages published and writes failed per topic, and command messages rejected
        (a copy)."""
        with self._lock:
            return {"published": self._counts.copy(), "failed": self._failed.copy(),
                    "rejected_commands": self._rejected}

    # ----------------------------------------------------------------- lockstep
    def begin_round(self, agent: str) -> bool:
        """Lockstep: start a round for ``agent`` (call it before publishing the state the
        round answers): from now on :meth:`wait_answers` waits for commands that arrive
        after this call. Returns whether the agent had answered the previous round."""
        io = self._io(agent, "begin_round")
        with self._lock:
            answered = io.has_answered()
            io.answered.clear()
        return answered

    def wait_answers(self, agents: Sequence[str], timeout_s: float) -> list[str]:
        """Block (wall clock, at most ``timeout_s``) until each of ``agents`` has answered
        since its :meth:`begin_round`: a whole command group it accepts received (desired
        heading, speed and depth; or thrusters). Returns those still silent (none: [])."""
        ios = [self._io(agent, "wait_answers") for agent in agents]
        deadline = time.monotonic() + timeout_s
        with self._answers:
            while True:
                silent = [io.spec.name for io in ios if not io.has_answered()]
                left = deadline - time.monotonic()
                if not silent or left <= 0.0:
                    return silent
                self._answers.wait(left)

    def wait_for_controller(self, agent: str, timeout_s: float) -> bool:
        """Block (wall clock) until ``/<agent>/odom`` has a matched subscriber and one of
        the agent's command topics a matched publisher (its controller, for a lockstep
        start); True when that happened within ``timeout_s``."""
        io = self._io(agent, "wait_for_controller")
        return _poll_until(
            lambda: io.pubs["odom"].get_subscription_count() > 0
            and any(sub.get_publisher_count() > 0 for sub in io.subs.values()),
            timeout_s)

    @property
    def failing_topics(self) -> tuple[str, ...]:
        """The topics on which a write has failed so far, in the order they first failed
        (see :meth:`_publish`)."""
        return tuple(self._failed)

    def subscriber_count(self, topic: str) -> int:
        """How many subscriptions the ROS graph shows on ``topic`` (for tests/tools)."""
        if not self.started:
            raise BridgeError("Ros2Bridge.subscriber_count: bridge is not running")
        return int(self._node.count_subscribers(topic))

    def wait_for_subscribers(self, topics: Sequence[str], timeout_s: float = 10.0) -> bool:
        """Block (wall clock) until every topic in ``topics`` has a subscriber, or the
        timeout passes; True on success. For tests and tools, not for the sim loop.
        DDS discovery of a new node takes from ~0.1 s to a few seconds."""
        return _poll_until(lambda: all(self.subscriber_count(t) > 0 for t in topics),
                           timeout_s)
