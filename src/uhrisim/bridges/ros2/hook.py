"""A simulation hook that attaches a running simulation to ROS 2 (``Ros2Bridge``).

Each tick the hook (a read-only observer, like the recorder) publishes every linked
agent's odometry and ``/tf`` (gated to ``odom_rate_hz`` in simulated time), each new
sonar ping, camera frame and helm decision, the community postings and events, and
``/clock``; at start it publishes the static scene as markers and the sensor mounts on
``/tf_static``: the topics the recording has (:mod:`uhrisim.record.hook`).
Volatile topics go out only while someone subscribes to them (nobody could tell the
difference, :class:`Ros2Bridge` ``publish_unsubscribed``): the fan image of a ping is
formed, and a snapshot taken for odometry, only for a subscriber. Commands received
from ROS 2 enter the simulation through the typed input paths every outside command
uses:

* ``/<agent>/cmd/desired_*`` -> :meth:`Simulation.post` of ``DESIRED_HEADING`` /
  ``DESIRED_SPEED`` / ``DESIRED_DEPTH`` (source ``"ros2"``), once per received message,
  applied at the start of the next tick. Switch the agent's built-in helm off
  (``driver: none``) or its own DESIRED_* will overwrite them.
* ``/<agent>/cmd/thrusters`` -> :meth:`Simulation.set_actuators` with
  ``hold_s = command_timeout_s``: the simulation falls back to the agent's own
  controller when no new thruster command arrives in time.
* Every command is checked against the agent's envelope first (:mod:`.limits`: speeds
  within what the vehicle can do, no reverse unless its controller reverses, depth within
  [0, floor below it - ``depth_clearance_m``], thrusters within ±150 and three of them).
* Each desired topic ages on its own (:attr:`~uhrisim.bridges.ros2.spec.AgentCommands.lapsed`):
  one with nothing accepted for ``command_timeout_s`` (refused, silent, or never sent
  while the others are) falls back once: ``DESIRED_SPEED = 0``, ``DESIRED_HEADING`` /
  ``DESIRED_DEPTH`` = the heading / depth at that moment. When every command is older
  than the timeout the hook performs the safe stop once (all three fallbacks). Each such
  transition, and commands becoming active again, is a ``bridge`` event and a line from
  the node's logger (``/rosout`` and the console). A thruster override outlives the command timeout
  by one command poll, so the safe stop's setpoints are in place before the vehicle's
  own controller takes over again: it does not turn back to an old heading.

A write that fails (ROS shut down under the bridge) does not stop the run: the bridge
counts it, and the hook records a ``bridge`` event when a topic first fails.

The hook does not pace the loop: to run in step with live ROS nodes, pace the simulation
at real time (``uhrisim.sim.pacing.Pacer``) or let nodes use ``/clock``
(``use_sim_time:=true``). In lockstep (``lockstep=True``) it waits, each odometry period,
for the controllers' answers: runs with outside nodes in the loop become repeatable.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

from uhrisim.bridges.helm_watch import OutsideHelmWatch, driven_from_outside, say_loudly
from uhrisim.core.errors import BridgeError, ConfigError
from uhrisim.core.frames import heading_deg_from_yaw
from uhrisim.ros.convert import RateGate
from uhrisim.ros.markers import SCENE_MAX_TRIANGLES_PER_OBJECT
from uhrisim.ros.tick import TickWriter
from uhrisim.ros.topics import DESIRED_KEYS, ros_name
from uhrisim.scenario.schema import HelmWatchSection
from uhrisim.sim.drivers import HelmDriver
from uhrisim.sim.hooks import TickFrame, split_sensor_key
from uhrisim.sim.simulation import BaseHook, Simulation

from .limits import CommandEnvelope
from .spec import COMMAND_GROUPS, AgentBridgeSpec, AgentCommands, node_namespace

if TYPE_CHECKING:
    from .bridge import Ros2Bridge

__all__ = ["Ros2BridgeHook", "command_envelope"]

log = logging.getLogger(__name__)

#: Wall seconds a lockstep start waits after finding the controllers (see on_start).
LOCKSTEP_SETTLE_S = 0.5

#: Default vertical clearance (m) kept between a commanded depth and the floor below.
DEPTH_CLEARANCE_M = 0.5

_DESIRED_VARS = (
    ("desired_heading_deg", "DESIRED_HEADING"),
    ("desired_speed", "DESIRED_SPEED"),
    ("desired_depth", "DESIRED_DEPTH"),
)


def command_envelope(agent: Any) -> CommandEnvelope:
    """What a simulated agent (``Simulation.agents[name]``) can be commanded to do: its
    model's top speed (:attr:`uhrisim.vehicles.VehicleModel.max_speed`) and whether its
    controller reverses (none of uhrisim's does: ``reverses`` on the controller says so)."""
    return CommandEnvelope(max_speed=agent.model.max_speed(agent.plant.params),
                           reverse=bool(getattr(agent.controller, "reverses", False)))


class Ros2BridgeHook(BaseHook):
    """One :class:`~uhrisim.bridges.ros2.bridge.Ros2Bridge` for the linked agents.

    ``agents``: the agents to bridge (default: all). Each is published under the ROS name
    the recorder uses (:func:`uhrisim.record.hook.ros_name`; usually the agent's name).
    ``accept``: command groups taken from ROS (:data:`~uhrisim.bridges.ros2.spec.COMMAND_GROUPS`;
    ``()`` = publish only): a sequence for every linked vehicle and every diver driven
    from outside (``driver: external`` or ``none``) — any other diver is ground truth only
    — or a mapping agent -> groups (None: that default; an agent it does not name
    accepts nothing).
    An agent without a helm of its own (driven from outside, or scripted) has no
    ``helm/*`` topics; an articulated diver has ``joint_states``.
    ``odom_rate_hz``: odometry rate in simulated time (``None``: every tick);
    ``sonar_rate_hz``: ``None`` publishes every ping the simulation makes.
    ``publish_scene``: send the static scene as ``/scene/markers`` at start.
    ``clock_rate_hz``: ``/clock`` rate in simulated time (``None``: every tick; 10 Hz, the
    default of Gazebo's ``gazebo_ros_init``, is on the same ticks as 10 Hz odometry).
    ``command_poll_hz``: how often incoming commands are read into the simulation
    (``None``: every tick); they act at most 1/rate s (simulated) after arrival.
    ``lockstep``: on each odometry tick, after publishing, wait (at most
    ``lockstep_timeout_s`` wall seconds) until every linked agent that accepts commands
    has answered with a whole command group, and apply the answers on the next tick: runs
    with a controller that answers each odometry message are then repeatable. At start
    the hook waits up to ``lockstep_start_timeout_s`` for each such agent's controller to
    appear (discovery alone can take seconds). An agent whose controller stays silent for
    a round is no longer waited for (a ``bridge`` event says so) until it answers again;
    its commands then go stale and the safe stop follows.
    ``depth_clearance_m``: commanded depths are clamped to the floor below the vehicle less
    this (m). ``namespace``, ``ros_args``: the node's namespace and ROS arguments
    (remappings, parameters: :mod:`.params`). ``helm_watch``: how an agent driven from ROS
    (``driver: external`` or ``none``, accepting commands) whose commands do not come is
    reported (:mod:`uhrisim.bridges.helm_watch`; default: the schema's defaults).
    Other arguments go to :class:`Ros2Bridge`.
    """

    def __init__(
        self,
        agents: Sequence[str] | None = None,
        *,
        accept: Sequence[str] | Mapping[str, Sequence[str] | None] = COMMAND_GROUPS,
        odom_rate_hz: float | None = 10.0,
        sonar_rate_hz: float | None = None,
        publish_scene: bool = True,
        node_name: str = "uhrisim",
        domain_id: int | None = None,
        command_timeout_s: float = 1.0,
        timeout_clock: Literal["sim", "wall"] = "sim",
        clock_rate_hz: float | None = 10.0,
        command_poll_hz: float | None = 20.0,
        reliable_sensors: bool = False,
        lockstep: bool = False,
        lockstep_timeout_s: float = 10.0,
        lockstep_start_timeout_s: float = 30.0,
        depth_clearance_m: float = DEPTH_CLEARANCE_M,
        namespace: str = "",
        ros_args: Sequence[str] = (),
        helm_watch: HelmWatchSection | None = None,
    ) -> None:
        for name, value in (("lockstep_timeout_s", lockstep_timeout_s),
                            ("lockstep_start_timeout_s", lockstep_start_timeout_s)):
            if not (value > 0 and math.isfinite(value)):
                raise ConfigError(f"must be a positive number of seconds, got {value!r}",
                                  f"Ros2BridgeHook.{name}")
        self._names = None if agents is None else tuple(agents)
        self._accept: tuple[str, ...] | dict[str, tuple[str, ...] | None] = (
            {name: None if groups is None else tuple(groups)
             for name, groups in accept.items()}
            if isinstance(accept, Mapping) else tuple(accept))
        self._odom_rate = odom_rate_hz
        self._sonar_rate = sonar_rate_hz
        self._publish_scene = publish_scene
        self._bridge_kw: dict[str, Any] = {
            "node_name": node_name,
            "domain_id": domain_id,
            "command_timeout_s": command_timeout_s,
            "timeout_clock": timeout_clock,
            "clock_rate_hz": clock_rate_hz,
            "reliable_sensors": reliable_sensors,
            "reliable_commands": lockstep,  # a lost command would stall a round
            "namespace": namespace,
            "ros_args": tuple(ros_args),
        }
        #: the node's namespace ("" or "/name"): a recording of this run uses it too
        self.ros_namespace = node_namespace(namespace, tuple(ros_args))
        self._lockstep = lockstep
        self._lockstep_timeout = lockstep_timeout_s
        self._lockstep_start_timeout = lockstep_start_timeout_s
        self._stepped: list[str] = []  # ROS names of the agents lockstep rounds wait for
        self._lapsed: set[str] = set()  # ... that did not answer their last round
        self.n_rounds = 0
        self._timeout = command_timeout_s
        # a thruster override lasts until the safe stop has surely been posted
        self._hold_s = command_timeout_s + (0.0 if command_poll_hz is None
                                            else 1.0 / command_poll_hz)
        self._clearance = depth_clearance_m
        self._command_gate = RateGate(command_poll_hz)
        self.bridge: Ros2Bridge | None = None
        self._out: TickWriter | None = None  # the tick's products through the bridge
        self._sim: Simulation | None = None
        self._ros: dict[str, str] = {}  # simulation agent name -> ROS namespace
        # per linked agent: (ROS name, simulation name, accept commands)
        self._links: list[tuple[str, str, bool]] = []
        self._accepting = False
        self._publish_wake = self._wake_time = -math.inf
        self._seen: dict[str, int] = {}
        self._active: dict[str, bool] = {}
        # per agent: the desired topics lapsed at the last poll (their fallbacks posted)
        self._fallen_back: dict[str, frozenset[str]] = {}
        self._failing: tuple[str, ...] = ()  # bridge.failing_topics, as last recorded
        self._extras = False  # someone subscribes to vars or /events (refreshed at 10 Hz)
        self._twin_seen = False  # another node of our name and namespace was seen
        self.n_posted = 0
        self.n_rejected = 0
        self._watch_settings = helm_watch or HelmWatchSection()
        self.watches: dict[str, OutsideHelmWatch] = {}  # by simulation agent name

    def on_start(self, sim: Simulation) -> None:
        from .bridge import Ros2Bridge

        names = list(sim.agents) if self._names is None else list(self._names)
        unknown = [n for n in names if n not in sim.agents]
        if unknown:
            raise ConfigError(
                f"ROS 2 hook names unknown agent(s) {unknown}; agents: {', '.join(sim.agents)}"
            )
        self._ros = {name: ros_name(name) for name in names}  # same names as recordings
        if len(set(self._ros.values())) != len(names):
            raise ConfigError(f"ROS 2 hook: agent names collide as ROS names: {self._ros}")
        articulated = set(sim.team.joint_samples()) if sim.team is not None else set()
        specs = [
            AgentBridgeSpec(
                self._ros[name],
                sonars=tuple(slot.name for slot in sim.agents[name].sonars),
                cameras=tuple(slot.name for slot in sim.agents[name].cameras),
                accept=self._accepted(name, sim.agents[name]),
                sonar_rate_hz=self._sonar_rate,
                odom_rate_hz=self._odom_rate,
                envelope=command_envelope(sim.agents[name]),
                helm=isinstance(sim.agents[name].driver, HelmDriver),
                joints=name in articulated,
            )
            for name in names
        ]
        self._sim = sim
        self.bridge = Ros2Bridge(specs, **self._bridge_kw)
        self.bridge.start()
        if self.bridge.namespace != self.ros_namespace:  # e.g. a node-specific remapping
            log.warning("ROS 2 node namespace %r, not %r: the recording's topics are not "
                        "the live ones", self.bridge.namespace, self.ros_namespace)
        self._links = [(spec.name, name, bool(spec.accept))
                       for spec, name in zip(self.bridge.agents, self._ros, strict=True)]
        self._accepting = any(accept for *_, accept in self._links)
        self._out = TickWriter(self.bridge, names)
        self._out.start(sim, scene=self._publish_scene,
                        max_triangles=SCENE_MAX_TRIANGLES_PER_OBJECT)
        if self._lockstep:
            self._await_controllers()
        # simulation times before which nothing is due (see on_tick)
        self._publish_wake = self._wake_time = -math.inf
        self._seen = dict.fromkeys(names, 0)
        self._active = dict.fromkeys(names, False)
        self._fallen_back: dict[str, frozenset[str]] = dict.fromkeys(names, frozenset())
        self.watches = {name: self._watch(sim, ros) for ros, name, accept in self._links
                        if accept and driven_from_outside(sim.agents[name])}
        self._failing = ()
        self._twin_seen = False

    def _accepted(self, name: str, agent: Any) -> tuple[str, ...]:
        """The command groups agent ``name`` takes from ROS (see the class)."""
        if isinstance(self._accept, dict):
            named = self._accept.get(name, ())  # an agent not named: nothing
            if named is not None:
                return named
            default = COMMAND_GROUPS  # named without groups: its default
        else:
            default = self._accept
        ground_truth = agent.model.diver is not None and not driven_from_outside(agent)
        return () if ground_truth else default

    def _watch(self, sim: Simulation, ros: str) -> OutsideHelmWatch:
        """The watch of an agent driven from ROS, started now."""
        bridge = self.bridge
        assert bridge is not None

        def hint(state: str | None) -> str:
            del state
            topics, matched = bridge.command_source(ros)
            where = f"{topics[0].rsplit('/', 1)[0]}/*" if topics else f"/{ros}/cmd/*"
            return (f": a node publishes on {where} but sends nothing" if matched else
                    f": no node publishes on {where} (is the controller running, on this "
                    "ROS_DOMAIN_ID, in this namespace?)")

        watch = OutsideHelmWatch(f"ROS 2 agent {ros!r}", "commands", self._watch_settings,
                                 say_loudly(sim, log), hint)
        watch.start(sim.t)
        return watch

    def _await_controllers(self) -> None:
        """Lockstep start: every agent that accepts commands needs its controller (an
        error here ends the run; the simulation's close then closes the bridge)."""
        bridge = self.bridge
        assert bridge is not None
        self._stepped = [ros for ros, _, accept in self._links if accept]
        self._lapsed = set()
        self.n_rounds = 0
        if not self._stepped:
            raise ConfigError("ROS 2 lockstep needs an agent that accepts commands "
                              "(links: [{agent: ..., accept: [desired]}])")
        for ros in self._stepped:
            if not bridge.wait_for_controller(ros, self._lockstep_start_timeout):
                raise BridgeError(
                    f"ROS 2 lockstep: no controller for {ros!r} within "
                    f"{self._lockstep_start_timeout:g} s (no node subscribed to /{ros}/odom and "
                    f"publishing /{ros}/cmd/*, reliably: rclpy's default QoS)")
        # we see the controller's writers matched; its writers may see our readers a
        # moment later, and a command written before that would not reach us
        time.sleep(LOCKSTEP_SETTLE_S)

    def on_tick(self, frame: TickFrame) -> None:
        bridge, sim = self.bridge, self._sim
        if bridge is None or sim is None:
            return
        t = float(frame.t)
        pings, helm, images = frame.pings, frame.helm, frame.images
        out = self._out
        assert out is not None
        if self._extras and (frame.posts or frame.events):
            out.posts(frame.posts)
            out.events(frame.events)
        if t < self._wake_time and not pings and not helm and not images:
            bridge.note_time(t)  # nothing due: most ticks of a 60 Hz loop
            return
        rounds: list[str] = []  # lockstep: agents whose answer to this tick is awaited
        if t >= self._publish_wake or pings or helm or images:
            bridge.write_clock(t)
            due = [name for ros, name, _ in self._links if bridge.odometry_due(ros, t)]
            for name in due:  # the snapshot is taken only when odometry goes out
                ros = self._ros[name]
                if ros in self._stepped:
                    rounds.append(ros)
                    self._begin_round(sim, bridge, ros, t)
            out.odometry(t, frame.agents, due)
            if frame.joints:
                out.joints(t, {name: frame.joints[name] for name in due
                               if name in frame.joints})
            if due:
                out.objects(t)
            for name, decision in helm.items():
                out.helm(name, t, decision)
            for key, ping in pings.items():
                agent, sonar = split_sensor_key(key)
                if agent in self._ros and bridge.sonar_due(self._ros[agent], sonar, t):
                    out.ping(key, ping)
                    seen = frame.perception.get(key)
                    if seen is not None:
                        out.perception(key, t, seen, ping)
            for key, image in images.items():
                out.image(key, image)
            self._publish_wake = bridge.wake_time
            self._extras = bridge.extras_subscribed()  # checked at most at 10 Hz
            if not self._twin_seen and bridge.twin_count() > 0:
                self._twin_seen = True
                bridge.stop_clock()
                self._announce(sim, f"ros2: another node named {bridge.node_name!r} in "
                                    f"namespace {bridge.namespace or '/'!r} on this domain "
                                    "(a second simulator?): this one publishes no /clock "
                                    "from now on; give each simulator its own namespace "
                                    "(--ros-args -r __ns:=/sim_a) or node name")
            if bridge.failing_topics != self._failing:  # rare: note it in the recording
                new = bridge.failing_topics[len(self._failing):]
                self._failing = bridge.failing_topics
                sim.record_event("bridge", f"ros2: writes to {', '.join(new)} failed (the "
                                           "run goes on; counts in metrics.json, see the log)")
        if rounds:
            self._await_answers(sim, bridge, [r for r in rounds if r not in self._lapsed], t)
        if rounds or (self._accepting and self._command_gate.due(t)):
            for ros, name, accept in self._links:
                if accept:
                    self._take_commands(sim, ros, name, bridge.commands(ros, t), frame)
        else:
            bridge.note_time(t)
        self._wake_time = min(self._publish_wake, self._command_gate.wake_time
                              if self._accepting else math.inf)

    def _begin_round(self, sim: Simulation, bridge: Ros2Bridge, ros: str, t: float) -> None:
        """A lockstep round for ``ros`` starts; one that had lapsed is waited for again
        once it has answered."""
        if bridge.begin_round(ros) and ros in self._lapsed:
            self._lapsed.discard(ros)
            sim.record_event("bridge", f"ros2 {ros}: controller answering again at "
                                       f"t={t:.2f} s: lockstep resumed")

    def _await_answers(self, sim: Simulation, bridge: Ros2Bridge, agents: list[str],
                       t: float) -> None:
        """Wait for the answers of ``agents`` to the state at ``t`` (a lockstep round,
        counted in ``n_rounds``); a silent one lapses."""
        if not agents:
            return
        self.n_rounds += 1
        for ros in bridge.wait_answers(agents, self._lockstep_timeout):
            self._lapsed.add(ros)
            sim.record_event("bridge", f"ros2 {ros}: no answer to t={t:.2f} s within "
                                       f"{self._lockstep_timeout:g} s: not waited for until "
                                       "it answers again (lockstep lapsed)")

    def _above_floor(self, sim: Simulation, ros: str, name: str, depth: float,
                     frame: TickFrame) -> float:
        """``depth`` (m) clamped to the floor below the vehicle now less the clearance."""
        floor = getattr(sim.scene, "seafloor", None)
        if floor is None or self.bridge is None:
            return depth
        north, east, _ = frame.agents[name].nav.position_ned
        deepest = float(floor.depth_at(float(north), float(east))) - self._clearance
        return self.bridge.depth_above_floor(ros, depth, deepest)

    def _take_commands(self, sim: Simulation, ros: str, name: str, cmd: AgentCommands,
                       frame: TickFrame) -> None:
        watch = self.watches.get(name)
        if cmd.received_count != self._seen[name]:
            self._seen[name] = cmd.received_count
            if watch is not None:
                watch.command(frame.t)
            for field, var in _DESIRED_VARS:
                value = getattr(cmd, field)
                if value is not None:
                    if var == "DESIRED_DEPTH":
                        value = self._above_floor(sim, ros, name, value, frame)
                    sim.post(name, var, float(value), source="ros2")
                    self.n_posted += 1
            if cmd.thrusters is not None:
                try:
                    sim.set_actuators(name, cmd.thrusters, hold_s=self._hold_s)
                except ConfigError as exc:
                    self.n_rejected += 1
                    log.warning("ROS 2 %s: thruster command rejected: %s", name, exc)
        if watch is not None:
            watch.check(frame.t)
        newly_lapsed = cmd.lapsed - self._fallen_back[name]
        self._fallen_back[name] = cmd.lapsed
        active = cmd.received and not cmd.stale
        if active != self._active[name]:
            self._active[name] = active
            if active:
                self._announce(sim, f"ros2 {ros}: external commands active", warn=False)
            else:
                held = self._fall_back(sim, name, DESIRED_KEYS, frame)
                self._announce(sim, f"ros2 {ros}: commands stale for {self._timeout:g} s: "
                                    f"safe stop ({held})")
        elif active and newly_lapsed:
            keys = [k for k in DESIRED_KEYS if k in newly_lapsed]
            held = self._fall_back(sim, name, keys, frame)
            topics = ", ".join(f"/{ros}/cmd/{k}" for k in keys)
            self._announce(sim, f"ros2 {ros}: nothing accepted on {topics} for "
                                f"{self._timeout:g} s: {held}")

    def _fall_back(self, sim: Simulation, name: str, keys: Sequence[str],
                   frame: TickFrame) -> str:
        """Post the fallback of each desired topic of ``keys`` (speed 0, hold the heading
        and the depth of this moment); returns what was held, in words."""
        nav = frame.agents[name].nav
        # rounded first, then wrapped: 359.96 deg reads "0.0", never "360.0"
        heading = round(float(heading_deg_from_yaw(nav.yaw)), 1) % 360.0
        depth = float(nav.position_ned[2])
        fallbacks = {"desired_heading": ("DESIRED_HEADING", heading,
                                         f"hold heading {heading:.1f} deg"),
                     "desired_speed": ("DESIRED_SPEED", 0.0, "speed 0"),
                     "desired_depth": ("DESIRED_DEPTH", depth, f"hold depth {depth:.2f} m")}
        said = []
        for key in sorted(keys, key=list(fallbacks).index):
            var, value, words = fallbacks[key]
            sim.post(name, var, value, source="ros2")
            said.append(words)
        return ", ".join(said)

    def _announce(self, sim: Simulation, text: str, warn: bool = True) -> None:
        """A safety transition: a ``bridge`` event in the recording (and on ``/events``)
        and a line from the node's logger (``/rosout`` and the console)."""
        sim.record_event("bridge", text)
        if self.bridge is not None:
            self.bridge.say(text, warn=warn)

    def on_end(self, sim: Simulation, error: BaseException | None) -> None:
        del sim, error
        if self.bridge is not None:
            self.bridge.close()

    def summary(self) -> dict[str, Any]:
        stats = self.bridge.stats() if self.bridge is not None else {}
        lockstep = {"lockstep_rounds": self.n_rounds} if self._lockstep else {}
        t = self._sim.t if self._sim is not None else 0.0
        helm = {"helm": {name: w.summary(t) for name, w in self.watches.items()}} \
            if self.watches else {}
        return {"ros2": {**stats, "posted": self.n_posted, "rejected": self.n_rejected,
                         **lockstep, **helm}}
