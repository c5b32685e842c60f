"""The ROS 2 bridge: the live output of the ROS translation plus an external command input.

``Ros2Bridge`` is a :class:`~uhrisim.ros.writer.RosWriter` — the same ``write_*`` API,
messages, names and frames as the recording (:class:`uhrisim.record.McapRecorder`) —
whose messages go to DDS: each topic of :mod:`uhrisim.ros.topics` has a publisher made at
start with the QoS of its kind (:mod:`.topics`), and a volatile topic is written only
while someone subscribes (:meth:`Ros2Bridge.wants`). It owns one rclpy ``Context`` (never
the global default one), one node and a background executor thread that only serves the
command subscriptions. The simulation thread calls the ``write_*`` methods (they hand the
serialised message to DDS and return; none waits for a subscriber) and ``commands()`` (a
lock-guarded read of the latest values). The rates at which a run publishes are gates in
simulated time (:meth:`Ros2Bridge.odometry_due`, :meth:`Ros2Bridge.sonar_due`, and
``/clock`` in :meth:`Ros2Bridge.write_clock`). Topics, frames, units, rates and QoS are
documented in docs/bridges-ros2.md.

The rest is in rooms of its own: :mod:`.topics` (QoS), :mod:`.commands` (commands coming
in, their freshness, lockstep answers), :mod:`.writer` (writes and statistics),
:mod:`.params` (the node's parameters).

Time: every ``header.stamp`` is the simulation time. ``/clock`` (rosgraph_msgs/Clock)
lets ROS nodes run with ``use_sim_time:=true``.
"""

from __future__ import annotations

import importlib
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Literal

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from uhrisim.core.errors import BridgeError, ConfigError
from uhrisim.ros.convert import RateGate
from uhrisim.ros.topics import GLOBAL_TOPICS, WORLD_FRAME, QosKind, agent_topics
from uhrisim.ros.writer import RosWriter

from .commands import CommandInbox
from .interfaces import build_hint
from .params import BridgeParameters
from .params import declare as declare_parameters
from .spec import AgentBridgeSpec, AgentCommands, apply_env_defaults, check_domain_id
from .topics import QOS_CLOCK, QOS_CLOCK_RELIABLE, QOS_SENSOR, QOS_SENSOR_RELIABLE, qos_for
from .writer import TopicWriter

__all__ = ["Ros2Bridge"]

log = logging.getLogger(__name__)

#: Longest wait of the command executor for something to do (s): also the longest a
#: close waits for it when its wake-up races a turn (~1 ms of CPU an idle turn).
_IDLE_SPIN_S = 0.2


def _poll_until(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Check ``condition`` every 20 ms (wall clock) until it holds, at most ``timeout_s``
    (ROS graph changes, which rclpy only lets us poll); True when it held."""
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.02)
    return True


class Ros2Bridge(RosWriter):
    """Publishes simulation state to ROS 2 (the :class:`~uhrisim.ros.writer.RosWriter`
    API) and collects external commands.

    Parameters
    ----------
    agents:
        One :class:`AgentBridgeSpec` per agent (topics ``<name>/...`` in the node's
        namespace: ``/<name>/odom`` without one); only these agents can be written.
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
        Publish ``/clock`` (:meth:`write_clock`: each new simulation time, gated by
        ``clock_rate_hz``).
    clock_rate_hz:
        Throttle ``/clock`` to this rate in simulation time (``None``: every change).
        Worth setting when the loop runs free at thousands of ticks per second.
    reliable_sensors:
        Publish sensor images/clouds reliably instead of best effort (see QoS).
    publish_unsubscribed:
        Write every message even to topics nobody subscribes to. By default a volatile
        topic without a matched subscriber is skipped (no subscriber could receive what
        it missed; the conversion and the DDS write are saved); the latched
        ``/helm/mode``, ``/tf_static`` and ``/scene/markers`` are always written.
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
        super().__init__(world_frame, frame_prefix)
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
        #: the node's parameters as read at start (the defaults until then)
        self.parameters = self._defaults
        # reliable commands: the state profile's settings (reliable, keep the last 10)
        self._reliable_commands = reliable_commands
        self._writer = TopicWriter(publish_unsubscribed)
        self._specs = {s.name: s for s in specs}
        self._gates: dict[str, tuple[RateGate, dict[str, RateGate]]] = {}
        self._inbox = CommandInbox(specs, float(command_timeout_s), timeout_clock)
        self._t_clock_published: float | None = None
        self._context: Context | None = None
        self._node: Any = None
        self._executor: SingleThreadedExecutor | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._closed = False
        self._pubs: dict[str, Any] = {}  # relative topic -> publisher
        self._topic: dict[str, str] = {}  # relative topic -> its resolved name

    # ----------------------------------------------------------------- lifecycle
    @property
    def started(self) -> bool:
        """True between :meth:`start` and :meth:`close`."""
        return self._node is not None and not self._closed

    @property
    def agents(self) -> tuple[AgentBridgeSpec, ...]:
        """The agent specs, in the order given."""
        return tuple(self._specs.values())

    @property
    def node_name(self) -> str:
        """The node's name (after any ``__node:=`` remapping, once started)."""
        return self._node.get_name() if self._node is not None else self._node_name

    @property
    def namespace(self) -> str:
        """The node's namespace once started (``""``: the root, else ``"/name"``)."""
        ns = self._node.get_namespace() if self._node is not None else self._namespace
        return ns.rstrip("/")

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
        topics = [(key, kind, qos) for key, (kind, qos) in GLOBAL_TOPICS.items()
                  if key != "clock" or self._publish_clock]
        topics += [(f"{spec.name}/{key}", kind, qos) for spec in self._specs.values()
                   for key, kind, qos in agent_topics(spec.sonars, spec.cameras, spec.helm,
                                                      spec.joints)]
        missing: set[str] = set()
        for topic, typename, kind in topics:
            self._create(topic, typename, kind, missing)
        if missing:
            log.warning("ROS 2 bridge: no %s topics: their messages are not built (run %s)",
                        ", ".join(sorted(missing)), build_hint())
        command_qos = qos_for("state" if self._reliable_commands else "command")
        for name in self._specs:
            self._inbox.subscribe(node, name, command_qos)
        self._executor = SingleThreadedExecutor(context=ctx)
        self._executor.add_node(node)
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._spin, name=f"uhrisim-ros2-{self._node_name}", daemon=True
        )
        self._thread.start()
        log.info(
            "ROS 2 bridge %r started: domain %s, agents %s",
            self._node_name, self._domain_id, list(self._specs),
        )

    def _apply(self, params: BridgeParameters) -> None:
        """Rates, frames and QoS from the node's parameters (before any publisher)."""
        self._clock_gate = RateGate(params.clock_rate_hz or None)
        self._sensor_qos = QOS_SENSOR_RELIABLE if params.sensor_qos == "reliable" \
            else QOS_SENSOR
        self._clock_qos = QOS_CLOCK_RELIABLE if params.clock_qos == "reliable" else QOS_CLOCK
        RosWriter.__init__(self, params.world_frame, params.frame_prefix)
        self._specs = {name: replace(spec,
                                     odom_rate_hz=params.odom_rate_hz or spec.odom_rate_hz,
                                     sonar_rate_hz=params.sonar_rate_hz or spec.sonar_rate_hz)
                       for name, spec in self._specs.items()}
        self._gates = {name: (RateGate(spec.odom_rate_hz),
                              {s: RateGate(spec.sonar_rate_hz) for s in spec.sonars})
                       for name, spec in self._specs.items()}
        self.parameters = params

    def _create(self, topic: str, typename: str, kind: QosKind,
                missing: set[str] | None = None) -> Any:
        """The publisher of ``topic`` (relative) for ``typename`` with the QoS of ``kind``
        (None, noted in ``missing``, when the message package is not built)."""
        try:
            msg_type = message_class(typename)
        except ImportError:
            if missing is not None:
                missing.add(typename.partition("/")[0])
            return None
        qos = (self._sensor_qos if kind == "sensor" else
               self._clock_qos if kind == "clock" else qos_for(kind))
        pub = self._pubs[topic] = self._writer.create(self._node, msg_type, topic, qos)
        self._topic[topic] = pub.topic_name
        return pub

    def _spin(self) -> None:
        ex = self._executor
        assert ex is not None
        while not self._stop.is_set():
            try:
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
            # the DDS participant goes now, not at the interpreter's exit (seconds there)
            self._context.destroy()
        log.info("ROS 2 bridge %r closed", self._node_name)

    def __enter__(self) -> Ros2Bridge:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----------------------------------------------------------------- the output
    def _check_open(self, where: str) -> None:
        if not self.started:
            raise BridgeError(f"Ros2Bridge.{where}: bridge is not running (call start())")

    def _begin(self, where: str, t: float) -> tuple[int, int, int]:
        begun = super()._begin(where, t)
        self._inbox.note_time(float(t))  # the receipt time of the next commands
        return begun

    def agent(self, name: str, where: str = "Ros2Bridge") -> Any:
        if name not in self._specs:
            raise ConfigError(f"unknown agent {name!r}; known: {list(self._specs)}", where)
        return super().agent(name, where)

    def wants(self, topic: str) -> bool:
        """Would a message on ``topic`` (relative) reach anyone: a publisher exists (its
        message package is built) and someone subscribes (or ``publish_unsubscribed``)?
        A topic the bridge has no publisher for yet (a perception marker topic) is made
        on its first write."""
        pub = self._pubs.get(topic)
        if pub is None:
            return topic not in self._topic and self.started
        return self._writer.wanted(pub)

    def _emit(self, topic: str, typename: str, qos: QosKind, t_ns: int, data: bytes) -> None:
        pub = self._pubs.get(topic)
        if pub is None:
            if topic in self._topic:
                return  # its message package is not built
            pub = self._create(topic, typename, qos)
            if pub is None:
                self._topic[topic] = ""
                return
        self._writer.write(pub, data, self._topic[topic])

    def write_clock(self, t: float) -> None:
        """``/clock`` at ``t`` (s) if simulation time changed and the clock's rate gate
        (``clock_rate_hz``) is due."""
        t = float(t)
        self._check_open("write_clock")
        self._inbox.note_time(t)
        if self._publish_clock and t != self._t_clock_published and self._clock_gate.due(t):
            super().write_clock(t)
            self._t_clock_published = t

    def twin_count(self) -> int:
        """How many *other* nodes on the domain have this node's name and namespace (a
        second simulator started the same way: its ``/clock`` and topics would mix with
        ours). A ROS graph query, cheap; discovery may take a moment to show a twin. 0
        once ROS is shut down under the bridge (the run goes on, see :mod:`.writer`)."""
        self._check_open("twin_count")
        try:
            me = (self._node.get_name(), self._node.get_namespace())
            names = self._node.get_node_names_and_namespaces()
        except Exception:  # rclpy's InvalidHandle / RCLError: the context is gone
            return 0
        return max(0, sum(1 for pair in names if pair == me) - 1)

    def stop_clock(self) -> None:
        """Publish no more ``/clock`` (another simulator's clock is on the topic)."""
        self._publish_clock = False

    @property
    def publishes_clock(self) -> bool:
        """Does :meth:`write_clock` still publish ``/clock``?"""
        return self._publish_clock

    # ----------------------------------------------------------------- rates
    def note_time(self, t_sim: float) -> None:
        """Tell the bridge the simulation time (s) without publishing anything: the
        receipt time of commands that arrive next (``timeout_clock="sim"``)."""
        self._inbox.note_time(float(t_sim))

    def _agent_gates(self, agent: str, where: str) -> tuple[RateGate, dict[str, RateGate]]:
        self._check_open(where)
        gates = self._gates.get(agent)
        if gates is None:
            raise ConfigError(f"unknown agent {agent!r}; known: {list(self._specs)}",
                              f"Ros2Bridge.{where}")
        return gates

    @property
    def wake_time(self) -> float:
        """Before this simulation time (s) neither ``/clock`` nor any agent's odometry is
        due: a loop may call only :meth:`note_time` until then (sonar pings and helm
        decisions are not gated by it)."""
        wake = self._clock_gate.wake_time if self._publish_clock else math.inf
        for nav, _ in self._gates.values():
            wake = min(wake, nav.wake_time)
        return wake

    def odometry_due(self, agent: str, t_sim: float) -> bool:
        """Is ``agent``'s odometry due at ``t_sim`` (s), at its ``odom_rate_hz`` in
        simulated time, and would it reach anyone (odometry, pose or ``/tf``)? A due
        gate with nobody to receive moves on to its next period, as if it had gone out;
        a True answer passes the gate: write it then (:meth:`write_odometry`)."""
        gate = self._agent_gates(agent, "odometry_due")[0]
        if not gate.is_due(t_sim):
            return False
        gate.due(t_sim)
        return any(self.wants(t) for t in (f"{agent}/odom", f"{agent}/pose", "tf"))

    def sonar_due(self, agent: str, sonar: str, t_sim: float) -> bool:
        """Is a ping of ``agent``'s sonar ``sonar`` due at ``t_sim`` (s), at its
        ``sonar_rate_hz`` in simulated time? True passes the gate."""
        gates = self._agent_gates(agent, "sonar_due")[1]
        if sonar not in gates:
            raise ConfigError(f"agent {agent!r} was configured without a sonar {sonar!r} "
                              f"(its sonars: {list(gates)})", "Ros2Bridge.sonar_due")
        return gates[sonar].due(t_sim)

    def extras_subscribed(self) -> bool:
        """Does anyone subscribe to a ``vars`` topic or to ``/events`` (so that the
        simulation's postings and events are worth handing over)?"""
        return self.wants("events") or any(self.wants(f"{name}/vars")
                                           for name in self._specs)

    # ----------------------------------------------------------------- commands
    def commands(self, agent: str, t_sim: float) -> AgentCommands:
        """The fresh commands for ``agent`` at simulation time ``t_sim`` (s).

        See :class:`AgentCommands` for the meaning of ``None`` and ``stale``. Also records
        ``t_sim`` as the bridge's current simulation time (the receipt time of commands
        that arrive next, with ``timeout_clock="sim"``).
        """
        self._agent_gates(agent, "commands")
        return self._inbox.commands(agent, t_sim)

    def say(self, text: str, warn: bool = True) -> None:
        """One line from the node's logger (``/rosout`` and the console): a warning, or
        information with ``warn=False``; nothing before :meth:`start` or after close."""
        if not self.started:
            return
        # rclpy fixes one severity per call site: one call each
        if warn:
            self._node.get_logger().warning(text)
        else:
            self._node.get_logger().info(text)

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
        self._agent_gates(agent, "depth_above_floor")
        return self._inbox.validator.depth_above_floor(agent, depth, deepest)

    # ----------------------------------------------------------------- lockstep
    def begin_round(self, agent: str) -> bool:
        """Lockstep: start a round for ``agent`` (call it before publishing the state the
        round answers): from now on :meth:`wait_answers` waits for commands that arrive
        after this call. Returns whether the agent had answered the previous round."""
        self._agent_gates(agent, "begin_round")
        return self._inbox.begin_round(agent)

    def wait_answers(self, agents: Sequence[str], timeout_s: float) -> list[str]:
        """Block (wall clock, at most ``timeout_s``) until each of ``agents`` has answered
        since its :meth:`begin_round`: a whole command group it accepts received (desired
        heading, speed and depth; or thrusters). Returns those still silent (none: [])."""
        for agent in agents:
            self._agent_gates(agent, "wait_answers")
        return self._inbox.wait_answers(agents, timeout_s)

    def wait_for_controller(self, agent: str, timeout_s: float) -> bool:
        """Block (wall clock) until ``/<agent>/odom`` has a matched subscriber and one of
        the agent's command topics a matched publisher (its controller, for a lockstep
        start); True when that happened within ``timeout_s``."""
        self._agent_gates(agent, "wait_for_controller")
        odom = self._pubs[f"{agent}/odom"]
        return _poll_until(
            lambda: odom.get_subscription_count() > 0
            and self._inbox.has_publisher(agent),
            timeout_s)

    def command_source(self, agent: str) -> tuple[tuple[str, ...], bool]:
        """``agent``'s command topics (resolved names) and whether a publisher is matched
        on one of them now: what to tell a user whose controller is silent."""
        self._agent_gates(agent, "command_source")
        return self._inbox.topics(agent), self._inbox.has_publisher(agent)

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
        """Block (wall clock) until every topic in ``topics`` (resolved names) has a
        subscriber, or the timeout passes; True on success. On a topic the bridge publishes
        that is a subscriber its publisher has matched (the graph shows it earlier; a
        message written in between is lost to it), on any other one in the graph. For
        tests and tools, not for the sim loop. DDS discovery of a new node takes from
        ~0.1 s to a few seconds."""
        published = set(self._topic.values())
        return _poll_until(lambda: all(self._writer.matched_readers(t) > 0 if t in published
                                       else self.subscriber_count(t) > 0 for t in topics),
                           timeout_s)


def message_class(typename: str) -> type:
    """The rclpy message class of ``typename`` (``"nav_msgs/msg/Odometry"``);
    ImportError when its package is not built."""
    package, _, name = typename.rpartition("/")
    return getattr(importlib.import_module(package.replace("/", ".")), name)
