"""The ROS 2 bridge: a read-only publish hook plus an external command input.

``Ros2Bridge`` owns one rclpy ``Context`` (never the global default one), one node
and a background executor thread that only serves the command subscriptions. The
simulation thread calls the ``publish_*`` methods (they serialize and hand the message
to DDS, and return; no call waits for a subscriber) and ``commands()`` (a lock-guarded
read of the latest values). Topics, frames, units, rates and QoS are documented in
docs/bridges-ros2.md; frame conversions happen only in :mod:`.convert`.

This module is the bridge's node and its lifecycle; the rest is in rooms of its own:
:mod:`.topics` (topics and QoS), :mod:`.publishers` (each agent's products going out),
:mod:`.messages` (message builders and serialised messages), :mod:`.commands` (commands
coming in, their freshness, lockstep answers), :mod:`.writer` (writes and statistics).

Time: every ``header.stamp`` is the simulation time ``t_sim``. With ``publish_clock``
the bridge also publishes ``/clock`` (rosgraph_msgs/Clock) so ROS nodes can run with
``use_sim_time:=true``.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any, Literal

import numpy as np
import rclpy
from numpy.typing import ArrayLike
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from visualization_msgs.msg import MarkerArray

from uhrisim.core.errors import BridgeError, ConfigError
from uhrisim.record import uhrisim_msgs
from uhrisim.record.cdr import PoseStampedEncoder

from .commands import CommandInbox
from .convert import RateGate, stamp_from_sim_time
from .interfaces import build_hint
from .messages import (
    WORLD_FRAME,
    clock_bytes,
    float64_bytes,
    image_msg,
    marker_msg,
    mono8,
    odometry_msg,
    pointcloud_msg,
    static_tf_msg,
    string_bytes,
)
from .params import BridgeParameters
from .params import declare as declare_parameters
from .publishers import AgentPublishers
from .spec import AgentBridgeSpec, AgentCommands, apply_env_defaults, check_domain_id
from .topics import (
    QOS_CLOCK,
    QOS_CLOCK_RELIABLE,
    QOS_COMMAND,
    QOS_SCENE,
    QOS_SENSOR,
    QOS_SENSOR_RELIABLE,
    QOS_STATE,
    QOS_TF,
    QOS_TF_STATIC,
)
from .writer import TopicWriter

#: Per-ping marker arrays (sonar perception): reliable, so RViz2's default subscriber gets them.
QOS_MARKERS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE)

#: The bridge, and what tests import from here of :mod:`.messages` and :mod:`.topics`.
__all__ = [
    "QOS_SCENE",
    "WORLD_FRAME",
    "PoseStampedEncoder",
    "Ros2Bridge",
    "clock_bytes",
    "float64_bytes",
    "image_msg",
    "odometry_msg",
    "pointcloud_msg",
    "string_bytes",
]

log = logging.getLogger(__name__)

#: Longest wait of the command executor for something to do (s).
_IDLE_SPIN_S = 1.0


def _ns(t_sim: float) -> int:
    """Simulation time (s) as integer nanoseconds (the stamps' rounding)."""
    sec, nanosec = stamp_from_sim_time(t_sim)
    return sec * 1_000_000_000 + nanosec


def _poll_until(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Check ``condition`` every 20 ms (wall clock) until it holds, at most ``timeout_s``
    (ROS graph changes, which rclpy only lets us poll); True when it held."""
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.02)
    return True


class Ros2Bridge:
    """Publishes simulation state to ROS 2 and collects external commands.

    Parameters
    ----------
    agents:
        One :class:`AgentBridgeSpec` per agent (topics ``<name>/...`` in the node's
        namespace: ``/<name>/odom`` without one).
    node_name:
        Name of the bridge's ROS node.
    namespace:
        The node's namespace (``"/sim_a"``: every topic under ``/sim_a/``, ``/clock`` and
        ``/tf`` included; ``""``: the root).
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
    ros_args:
        ROS command-line arguments for the node, as after ``--ros-args``: remappings
        (``-r __node:=sim``, ``-r __ns:=/sim_a``, ``-r videoray/odom:=odometry``),
        parameters (``-p sensor_qos:=reliable``, :mod:`.params`), ``--params-file``.
    world_frame, frame_prefix:
        Defaults of the parameters of the same names (:mod:`.params`).
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
        namespace: str = "",
        ros_args: Sequence[str] = (),
        world_frame: str = WORLD_FRAME,
        frame_prefix: str = "",
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
        if isinstance(ros_args, str) or not all(isinstance(a, str) for a in ros_args):
            raise ConfigError("must be a list of strings, e.g. ['-r', '__ns:=/sim_a']",
                              "Ros2Bridge.ros_args")
        self._node_name = node_name
        self._namespace = namespace
        self._ros_args = list(ros_args)
        self._defaults = BridgeParameters(
            clock_rate_hz=float(clock_rate_hz or 0.0), world_frame=world_frame,
            frame_prefix=frame_prefix,
            sensor_qos="reliable" if reliable_sensors else "best_effort")
        self._domain_id = check_domain_id(domain_id)
        self._publish_clock = publish_clock
        self._clock_gate = RateGate(clock_rate_hz)
        self._sensor_qos = QOS_SENSOR_RELIABLE if reliable_sensors else QOS_SENSOR
        self._clock_qos = QOS_CLOCK
        self._world_frame = world_frame
        #: the node's parameters as read at start (the defaults until then)
        self.parameters = self._defaults
        # reliable commands: the state profile's settings (reliable, keep the last 10)
        self._command_qos = QOS_STATE if reliable_commands else QOS_COMMAND
        self._writer = TopicWriter(publish_unsubscribed)
        self._agents = {s.name: AgentPublishers(s, self._writer, world_frame, frame_prefix)
                        for s in specs}
        self._inbox = CommandInbox(specs, float(command_timeout_s), timeout_clock)
        self._t_clock_published: float | None = None
        self._context: Context | None = None
        self._node: Any = None
        self._executor: SingleThreadedExecutor | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._closed = False
        self._pub_clock: Any = None
        self._pub_scene: Any = None
        self._pub_tf: Any = None
        self._pub_tf_static: Any = None
        self._pub_events: Any = None
        self._topic: dict[str, str] = {}  # bridge-wide topic -> its resolved name
        self._pub_markers: dict[str, Any] = {}  # topic -> MarkerArray publisher

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
                args=["uhrisim", "--ros-args", *self._ros_args],
                context=ctx,
                domain_id=self._domain_id,
                signal_handler_options=SignalHandlerOptions.NO,
            )
            node = rclpy.create_node(
                self._node_name, namespace=self._namespace, context=ctx,
                start_parameter_services=False,
            )
        except Exception as exc:
            ctx.try_shutdown()
            raise BridgeError(f"Ros2Bridge: could not start ROS 2 node: {exc}") from exc
        try:
            self._apply(declare_parameters(node, self._defaults))
        except ConfigError:
            node.destroy_node()
            ctx.try_shutdown()
            raise
        self._context, self._node = ctx, node
        # command rejections go to /rosout (and the console) through the node's logger
        self._inbox.validator.log = node.get_logger().warning
        if self._publish_clock:
            self._pub_clock = self._writer.create(node, Clock, "clock", self._clock_qos)
        self._pub_scene = self._writer.create(node, MarkerArray, "scene/markers", QOS_SCENE)
        try:
            from tf2_msgs.msg import TFMessage
        except ImportError:
            log.warning("ROS 2 bridge: no /tf, /tf_static: tf2_msgs is not built (run %s)",
                        build_hint())
        else:
            self._pub_tf = self._writer.create(node, TFMessage, "tf", QOS_TF)
            self._pub_tf_static = self._writer.create(node, TFMessage, "tf_static",
                                                      QOS_TF_STATIC)
        try:
            from uhrisim_msgs.msg import Event
        except ImportError:
            log.warning("ROS 2 bridge: no helm/decision, vars, /events: uhrisim_msgs is not "
                        "built (run %s)", build_hint())
        else:
            self._pub_events = self._writer.create(node, Event, "events", QOS_STATE)
        # resolved names (the node's namespace applied), the keys of the statistics
        self._topic = {key: pub.topic_name for key, pub in (
            ("clock", self._pub_clock), ("scene", self._pub_scene), ("tf", self._pub_tf),
            ("tf_static", self._pub_tf_static), ("events", self._pub_events))
            if pub is not None}
        for name, io in self._agents.items():
            io.create(node, self._sensor_qos, self._pub_tf)
            self._inbox.subscribe(node, name, self._command_qos)
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

    def _apply(self, params: BridgeParameters) -> None:
        """Rates, frames and QoS from the node's parameters (before any publisher)."""
        self._clock_gate = RateGate(params.clock_rate_hz or None)
        self._sensor_qos = QOS_SENSOR_RELIABLE if params.sensor_qos == "reliable" \
            else QOS_SENSOR
        self._clock_qos = QOS_CLOCK_RELIABLE if params.clock_qos == "reliable" else QOS_CLOCK
        self._world_frame = params.world_frame
        specs = [replace(io.spec,
                         odom_rate_hz=params.odom_rate_hz or io.spec.odom_rate_hz,
                         sonar_rate_hz=params.sonar_rate_hz or io.spec.sonar_rate_hz)
                 for io in self._agents.values()]
        self._agents = {s.name: AgentPublishers(s, self._writer, params.world_frame,
                                                params.frame_prefix) for s in specs}
        self.parameters = params

    def frame(self, agent: str, name: str) -> str:
        """The full name of one of ``agent``'s frames (``"base_link"``, ``"odom"``,
        a sonar's ``"sonar"``, a camera's ``"camera_optical"``), with the ``frame_prefix``
        parameter applied."""
        return f"{self._io(agent, 'frame').frame_base}/{name}"

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
    def _io(self, agent: str, where: str) -> AgentPublishers:
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
        self._inbox.note_time(t)
        if (
            self._pub_clock is not None
            and t != self._t_clock_published
            and self._clock_gate.due(t)
        ):
            if self._writer.wanted(self._pub_clock):
                # pre-serialised: the bytes of a rosgraph_msgs/Clock, without building one
                self._writer.write(self._pub_clock, clock_bytes(t), self._topic["clock"])
            self._t_clock_published = t

    # ----------------------------------------------------------------- publishing
    def note_time(self, t_sim: float) -> None:
        """Tell the bridge the simulation time (s) without publishing anything: the
        receipt time of commands that arrive next (``timeout_clock="sim"``)."""
        self._inbox.note_time(float(t_sim))

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
        return io.nav(t_sim, position_ned, yaw_rad, velocity_body_frd, yaw_rate)

    def odometry_due(self, agent: str, t_sim: float) -> bool:
        """Would :meth:`publish_nav` publish ``agent``'s odometry at ``t_sim`` (s)? Lets a
        caller skip gathering navigation data that would not go out. When the rate gate
        is due but nobody subscribes to the odometry or the pose, the answer is False and
        the gate moves on to its next period, as if the odometry had gone out."""
        return self._io(agent, "odometry_due").odometry_due(t_sim)

    def sonar_subscribed(self, agent: str, sonar: str = "sonar") -> tuple[bool, bool, bool]:
        """Whether ``/<agent>/<sonar>/polar``, ``/fan`` and ``/points`` have a matched
        subscriber now (a fraction of a microsecond each; all True with
        ``publish_unsubscribed``). :meth:`publish_sonar` skips the others; a caller may
        skip forming those products (the simulation hook does; the fan image is the
        costly one)."""
        return self._io(agent, "sonar_subscribed").sonar_subscribed(sonar)

    def publish_sonar(
        self,
        agent: str,
        t_sim: float,
        polar_u8: np.ndarray | None,
        fan_u8: np.ndarray | None,
        points_sonar_frd: ArrayLike | None = None,
        intensity: ArrayLike | None = None,
        sonar_pose_ned: tuple[ArrayLike, ArrayLike] | None = None,
        sonar: str = "sonar",
    ) -> bool:
        """Publish the products of the agent's sonar named ``sonar`` (topics
        ``/<agent>/<sonar>/...``, frame ``"<agent>/<sonar>"``; below for the default
        name) if that sonar's rate gate is due.

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
        if sonar not in io.spec.sonars:
            raise ConfigError(
                f"agent {agent!r} was configured without a sonar {sonar!r} (its sonars: "
                f"{list(io.spec.sonars)})", "Ros2Bridge.publish_sonar")
        self._advance(t_sim)
        return io.sonar(sonar, t_sim, polar_u8, fan_u8, points_sonar_frd, intensity,
                        sonar_pose_ned)

    def publish_camera(
        self,
        agent: str,
        t_sim: float,
        rgb_u8: np.ndarray,
        depth_m: np.ndarray | None,
        K: ArrayLike,
        camera_pose_ned: tuple[ArrayLike, ArrayLike],
        labels_u8: np.ndarray | None = None,
        camera: str = "camera",
    ) -> None:
        """Publish a frame of the agent's camera named ``camera`` (topics
        ``/<agent>/<camera>/...``, frame ``"<agent>/<camera>_optical"``; below for the
        default name): ``rgb_u8`` (H, W, 3) uint8 -> ``/<agent>/camera/image_raw``
        (sensor_msgs/Image rgb8), ``K`` -> ``/<agent>/camera/camera_info``, ``depth_m``
        (H, W) metres along the optical axis, NaN where nothing was hit ->
        ``/<agent>/camera/depth`` (32FC1, REP-118), ``labels_u8`` (H, W) uint8, label id
        + 1, 0 for open water (:func:`~.convert.label_image_mono8`) ->
        ``/<agent>/camera/labels`` (mono8), ``camera_pose_ned`` (position (3,), rotation
        camera (x forward, y right, z down) -> NED) -> ``/<agent>/camera/pose`` (the
        optical frame ``"<agent>/camera_optical"``: x right, y down, z forward; the same
        as ``/tf`` with the mount on ``/tf_static``). ``None`` products are skipped; only
        to topics with a subscriber (see ``publish_unsubscribed``)."""
        io = self._io(agent, "publish_camera")
        where = "Ros2Bridge.publish_camera"
        if camera not in io.spec.cameras:
            raise ConfigError(f"agent {agent!r} was configured without a camera {camera!r} "
                              f"(its cameras: {list(io.spec.cameras)})", where)
        rgb = np.asarray(rgb_u8)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.size == 0:
            raise ConfigError(f"rgb_u8 must be a non-empty (H, W, 3) uint8 array, got "
                              f"{rgb.dtype} {rgb.shape}", where)
        labels = None
        if labels_u8 is not None:
            labels = mono8(labels_u8, f"{where}.labels_u8")
            if labels.shape != rgb.shape[:2]:
                raise ConfigError(f"labels_u8 must have shape {rgb.shape[:2]}, got "
                                  f"{labels.shape}", where)
        self._advance(t_sim)
        io.camera(camera, t_sim, rgb, depth_m, labels, np.asarray(K, dtype=float),
                  camera_pose_ned)

    def publish_sonar_image(self, agent: str, t_sim: float, polar_u8: np.ndarray,
                            beam_angles_rad: ArrayLike, ranges_m: ArrayLike,
                            frequency_hz: float, sound_speed_m_s: float,
                            sonar: str = "sonar") -> None:
        """Publish ``/<agent>/<sonar>/image`` (marine_acoustic_msgs/ProjectedSonarImage in
        ``"<agent>/<sonar>"``): the polar image ``(n_bins, n_beams)`` uint8 with the beam
        azimuths (rad, > 0 starboard), range-bin centres (m), centre frequency (Hz) and
        sound speed (m/s); see :func:`~.messages.projected_sonar_image_msg`. Only while
        someone subscribes, and only when marine_acoustic_msgs is built. Not rate-gated:
        call it on the calls where :meth:`publish_sonar` published."""
        io = self._io(agent, "publish_sonar_image")
        io.sonar_image(sonar, t_sim, polar_u8, beam_angles_rad, ranges_m, frequency_hz,
                       sound_speed_m_s)

    def sonar_image_subscribed(self, agent: str, sonar: str = "sonar") -> bool:
        """Does ``/<agent>/<sonar>/image`` have a subscriber (form it only then)?"""
        return self._io(agent, "sonar_image_subscribed").sonar_image_wanted(sonar)

    def publish_static_transforms(
        self, t_sim: float, transforms: Sequence[tuple[str, str, ArrayLike, ArrayLike]]
    ) -> None:
        """Publish ``/tf_static`` (latched, one message with every static transform): each
        ``(parent, child, position_frd (3,) m, rotation_frd (3x3) child -> parent)`` in
        body FRD terms, written in FLU (e.g. ``("rov/base_link", "rov/sonar", mount
        position, mount rotation)``). Nothing when tf2_msgs is not built."""
        if not self.started:
            raise BridgeError("Ros2Bridge.publish_static_transforms: bridge is not running")
        if self._pub_tf_static is not None:
            self._writer.write(self._pub_tf_static, static_tf_msg(t_sim, transforms),
                               self._topic["tf_static"])

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
        latched: see :data:`~uhrisim.bridges.ros2.topics.QOS_LATCHED`). Not rate-gated: the
        helm's own rate applies. The desired values go out only while someone subscribes to
        them; the mode always.
        """
        io = self._io(agent, "publish_helm")
        self._advance(t_sim)
        io.helm(heading_deg, speed, depth, mode)

    def publish_helm_decision(self, agent: str, t_sim: float, heading_deg: float | None,
                              speed: float | None, depth: float | None,
                              contributions: Mapping[str, float], mode: str,
                              active: Sequence[str], total: float | None,
                              all_stop_reason: str) -> None:
        """Publish ``/<agent>/helm/decision`` (uhrisim_msgs/HelmDecision: the decision with
        every behavior's share; the recording's message), only while someone subscribes;
        fields as :meth:`uhrisim.record.McapRecorder.write_helm_decision`."""
        io = self._io(agent, "publish_helm_decision")
        if io.extra_wanted("helm/decision"):
            io.write_extra("helm/decision", uhrisim_msgs.helm_decision_bytes(
                _ns(t_sim), heading_deg, speed, depth, contributions, mode, active, total,
                all_stop_reason, "Ros2Bridge.publish_helm_decision"))

    def publish_variable(self, agent: str, t_sim: float, name: str, value: float | str,
                         source: str) -> None:
        """Publish a community posting on ``/<agent>/vars`` (uhrisim_msgs/Variable), only
        while someone subscribes."""
        io = self._io(agent, "publish_variable")
        if io.extra_wanted("vars"):
            io.write_extra("vars", uhrisim_msgs.variable_bytes(
                _ns(t_sim), name, value, source, "Ros2Bridge.publish_variable"))

    def publish_event(self, t_sim: float, kind: str, detail: str) -> None:
        """Publish ``/events`` (uhrisim_msgs/Event, frame the world frame), only while
        someone subscribes."""
        if not self.started:
            raise BridgeError("Ros2Bridge.publish_event: bridge is not running (call start())")
        if self._pub_events is not None and self._writer.wanted(self._pub_events):
            self._writer.write(self._pub_events, uhrisim_msgs.event_bytes(
                _ns(t_sim), self._world_frame, kind, detail), self._topic["events"])

    def extras_subscribed(self) -> bool:
        """Does anyone subscribe to a ``vars`` topic or to ``/events`` (so that the
        simulation's postings and events are worth handing over)?"""
        if self._pub_events is not None and self._writer.wanted(self._pub_events):
            return True
        return any(io.extra_wanted("vars") for io in self._agents.values())

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
        arr.markers = [marker_msg(t_sim, i, m, self._world_frame)
                       for i, m in enumerate(markers)]
        self._writer.write(self._pub_scene, arr, self._topic["scene"])

    def publish_markers(self, topic: str, t_sim: float,
                        markers: Sequence[Mapping[str, Any]]) -> None:
        """Publish ``markers`` (mappings as for :meth:`publish_scene`; ``action:
        "deleteall"`` too) as one visualization_msgs/MarkerArray on ``topic``, frame
        ``"map"``, if someone subscribes; the publisher (reliable, depth 10) is made on
        first use. The sonar perception's detections and tracks go out this way."""
        if not self.started:
            raise BridgeError("Ros2Bridge.publish_markers: bridge is not running (call start())")
        pub = self._pub_markers.get(topic)
        if pub is None:
            pub = self._pub_markers[topic] = self._node.create_publisher(
                MarkerArray, topic, QOS_MARKERS)
        self._advance(t_sim)
        if not self._writer.wanted(pub):
            return
        arr = MarkerArray()
        arr.markers = [marker_msg(t_sim, i, m, self._world_frame)
                       for i, m in enumerate(markers)]
        self._writer.write(pub, arr, topic)

    # ----------------------------------------------------------------- commands
    def commands(self, agent: str, t_sim: float) -> AgentCommands:
        """The fresh commands for ``agent`` at simulation time ``t_sim`` (s).

        See :class:`AgentCommands` for the meaning of ``None`` and ``stale``. Also records
        ``t_sim`` as the bridge's current simulation time (the receipt time of commands
        that arrive next, with ``timeout_clock="sim"``).
        """
        self._io(agent, "commands")
        return self._inbox.commands(agent, t_sim)

    # ----------------------------------------------------------------- introspection
    def stats(self) -> dict[str, Any]:
        """Messages published and writes failed per topic; command messages refused and
        clamped, and the rejections per topic and reason (:mod:`.limits`); a copy."""
        validator = self._inbox.validator
        return {**self._writer.stats(), "rejected_commands": validator.refused,
                "clamped_commands": validator.clamped,
                "command_rejections": validator.counts()}

    def depth_above_floor(self, agent: str, depth: float, deepest: float) -> float:
        """A commanded depth (m, down) of ``agent`` as it may take effect where the
        vehicle is: clamped to ``deepest`` (the floor below it less the clearance; NaN:
        no limit), the clamp counted and reported like every command rejection."""
        self._io(agent, "depth_above_floor")
        return self._inbox.validator.depth_above_floor(agent, depth, deepest)

    # ----------------------------------------------------------------- lockstep
    def begin_round(self, agent: str) -> bool:
        """Lockstep: start a round for ``agent`` (call it before publishing the state the
        round answers): from now on :meth:`wait_answers` waits for commands that arrive
        after this call. Returns whether the agent had answered the previous round."""
        self._io(agent, "begin_round")
        return self._inbox.begin_round(agent)

    def wait_answers(self, agents: Sequence[str], timeout_s: float) -> list[str]:
        """Block (wall clock, at most ``timeout_s``) until each of ``agents`` has answered
        since its :meth:`begin_round`: a whole command group it accepts received (desired
        heading, speed and depth; or thrusters). Returns those still silent (none: [])."""
        for agent in agents:
            self._io(agent, "wait_answers")
        return self._inbox.wait_answers(agents, timeout_s)

    def wait_for_controller(self, agent: str, timeout_s: float) -> bool:
        """Block (wall clock) until ``/<agent>/odom`` has a matched subscriber and one of
        the agent's command topics a matched publisher (its controller, for a lockstep
        start); True when that happened within ``timeout_s``."""
        io = self._io(agent, "wait_for_controller")
        return _poll_until(
            lambda: io.pubs["odom"].get_subscription_count() > 0
            and self._inbox.has_publisher(agent),
            timeout_s)

    @property
    def failing_topics(self) -> tuple[str, ...]:
        """The topics on which a write has failed so far, in the order they first failed
        (see :mod:`.writer`)."""
        return self._writer.failing_topics

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
