"""External commands in: subscriptions, the latest value of each command with its
receipt time, freshness, and the answers a lockstep round waits for.

An agent that accepts ``"desired"`` listens on ``/<agent>/cmd/desired_heading`` (compass
degrees), ``/desired_speed`` (m/s) and ``/desired_depth`` (m, down), std_msgs/Float64; one
that accepts ``"thrusters"`` on ``/<agent>/cmd/thrusters``, std_msgs/Float64MultiArray
``(port, starboard, vertical)``. Every value passes the agent's
:class:`~uhrisim.bridges.ros2.limits.CommandValidator` first: refused values are not
stored (the previous command stays, and ages), clamped ones are stored clamped.
Each desired value ages on its own: one older than the timeout (refused since, or no
longer sent) is *lapsed*, and so is one never sent once the first desired value of any
kind is older than the timeout (:attr:`~uhrisim.bridges.ros2.spec.AgentCommands.lapsed`).

The subscriptions' callbacks run on the bridge's executor thread and store under a lock;
the simulation thread reads the latest values (:meth:`CommandInbox.commands`). A
command's age is simulation time since its receipt (``timeout_clock="sim"``: receipt is
the newest ``t_sim`` the simulation had passed to the bridge when the message arrived)
or monotonic wall seconds (``"wall"``); older than the timeout it is dropped (see
:class:`~uhrisim.bridges.ros2.spec.AgentCommands` for ``None`` and ``stale``).

Lockstep: :meth:`CommandInbox.begin_round` starts an agent's round; the agent has
answered when a whole command group it accepts has arrived since (all three desired
values, or the thrusters), which :meth:`CommandInbox.wait_answers` waits for.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

from rclpy.qos import QoSProfile
from std_msgs.msg import Float64, Float64MultiArray

from .limits import CommandValidator
from .spec import AgentBridgeSpec, AgentCommands
from .topics import DESIRED_KEYS, THRUSTERS_KEY

log = logging.getLogger(__name__)

#: What :meth:`CommandInbox.commands` answers before any command arrived.
_NO_COMMANDS = AgentCommands()

#: What answers a lockstep round, per accepted command group: every topic of the group.
_ANSWER_GROUPS = {"desired": frozenset(DESIRED_KEYS), "thrusters": frozenset({THRUSTERS_KEY})}


@dataclass
class _Slot:
    """One received command value with its receipt times (mutable, inbox-private)."""

    value: Any
    t_sim: float
    t_wall: float


class _AgentInbox:
    """Subscriptions and command slots of one agent (the inbox's lock guards the slots)."""

    def __init__(self, spec: AgentBridgeSpec) -> None:
        self.spec = spec
        self.subs: dict[str, Any] = {}  # command key -> subscription
        self.slots: dict[str, _Slot] = {}
        self.received = 0  # command messages accepted so far
        self.answered: set[str] = set()  # command keys received since begin_round
        self.desired_since: _Slot | None = None  # the first desired_* value's receipt

    def has_answered(self) -> bool:
        """Since the last :meth:`CommandInbox.begin_round`, a whole command group this
        agent accepts has arrived (all three desired values, or the thrusters)."""
        return any(_ANSWER_GROUPS[group] <= self.answered for group in self.spec.accept)


class CommandInbox:
    """The commands of every agent of ``specs``; ``timeout_s`` and ``timeout_clock`` as
    :class:`~uhrisim.bridges.ros2.bridge.Ros2Bridge`'s ``command_timeout_s`` and
    ``timeout_clock``."""

    def __init__(self, specs: Sequence[AgentBridgeSpec], timeout_s: float,
                 timeout_clock: Literal["sim", "wall"]) -> None:
        self._agents = {s.name: _AgentInbox(s) for s in specs}
        #: checks every command value (its log: the node's rclpy logger once started)
        self.validator = CommandValidator({s.name: s.envelope for s in specs},
                                          log=log.warning)
        self._timeout = timeout_s
        self._timeout_clock = timeout_clock
        self._lock = threading.Lock()
        self._answers = threading.Condition(self._lock)  # lockstep rounds wait on it
        self._t_sim_latest = 0.0

    def subscribe(self, node: Any, agent: str, qos: QoSProfile) -> None:
        """Create ``agent``'s command subscriptions on ``node``: the groups it accepts."""
        inbox = self._agents[agent]
        if "desired" in inbox.spec.accept:
            for key in DESIRED_KEYS:
                inbox.subs[key] = node.create_subscription(
                    Float64, f"{agent}/cmd/{key}", self._make_float_cb(agent, key), qos,
                )
        if "thrusters" in inbox.spec.accept:
            inbox.subs[THRUSTERS_KEY] = node.create_subscription(
                Float64MultiArray, f"{agent}/cmd/thrusters", self._make_thruster_cb(agent),
                qos,
            )

    def has_publisher(self, agent: str) -> bool:
        """Does one of ``agent``'s command topics have a matched publisher now?"""
        return any(sub.get_publisher_count() > 0 for sub in self._agents[agent].subs.values())

    def topics(self, agent: str) -> tuple[str, ...]:
        """``agent``'s command topics, as resolved (the node's namespace applied)."""
        return tuple(sub.topic_name for sub in self._agents[agent].subs.values())

    def note_time(self, t_sim: float) -> None:
        """The simulation time (s) now: the receipt time of commands that arrive next
        (``timeout_clock="sim"``). One attribute store: atomic, the callbacks read it
        under the lock."""
        self._t_sim_latest = t_sim

    @property
    def rejected(self) -> int:
        """Command messages refused so far (clamped ones are not counted here)."""
        return self.validator.refused

    # ----------------------------------------------------------------- callbacks
    def _store(self, agent: str, key: str, value: Any) -> None:
        with self._lock:
            inbox = self._agents[agent]
            slot = inbox.slots[key] = _Slot(value, self._t_sim_latest, time.monotonic())
            if inbox.desired_since is None and key in DESIRED_KEYS:
                inbox.desired_since = slot
            inbox.received += 1
            inbox.answered.add(key)
            self._answers.notify_all()

    def _make_float_cb(self, agent: str, key: str) -> Any:
        def cb(msg: Float64) -> None:
            value = self.validator.desired(agent, key, msg.data)
            if value is not None:
                self._store(agent, key, value)

        return cb

    def _make_thruster_cb(self, agent: str) -> Any:
        def cb(msg: Float64MultiArray) -> None:
            values = self.validator.thrusters(agent, msg.data)
            if values is not None:
                self._store(agent, THRUSTERS_KEY, values)

        return cb

    # ----------------------------------------------------------------- reading
    def commands(self, agent: str, t_sim: float) -> AgentCommands:
        """The fresh commands for ``agent`` at simulation time ``t_sim`` (s), which also
        becomes the receipt time of commands that arrive next."""
        inbox = self._agents[agent]
        t = float(t_sim)
        if not inbox.slots:  # nothing ever received (slots only grow): no lock, no clock read
            self._t_sim_latest = t
            return _NO_COMMANDS
        now_wall = time.monotonic()
        with self._lock:
            self._t_sim_latest = t
            slots = dict(inbox.slots)
            received = inbox.received
            since = inbox.desired_since

        def age(slot: _Slot) -> float:
            return (t - slot.t_sim) if self._timeout_clock == "sim" else (now_wall - slot.t_wall)

        ages = {k: age(s) for k, s in slots.items()}
        fresh = {k: slots[k].value for k, a in ages.items() if a <= self._timeout}
        newest = min(ages.values()) if ages else None
        # a desired value never sent ages from the first desired value of any kind
        lapsed = frozenset() if since is None else frozenset(
            k for k in DESIRED_KEYS
            if (ages[k] if k in ages else age(since)) > self._timeout)
        return AgentCommands(
            desired_heading_deg=fresh.get("desired_heading"),
            desired_speed=fresh.get("desired_speed"),
            desired_depth=fresh.get("desired_depth"),
            thrusters=fresh.get(THRUSTERS_KEY),
            stale=bool(slots) and not fresh,
            lapsed=lapsed,
            age_s=newest,
            received_count=received,
        )

    # ----------------------------------------------------------------- lockstep
    def begin_round(self, agent: str) -> bool:
        """Start a round for ``agent``: :meth:`wait_answers` waits for commands that arrive
        after this call. Returns whether the agent had answered the previous round."""
        inbox = self._agents[agent]
        with self._lock:
            answered = inbox.has_answered()
            inbox.answered.clear()
        return answered

    def wait_answers(self, agents: Sequence[str], timeout_s: float) -> list[str]:
        """Block (wall clock, at most ``timeout_s``) until each of ``agents`` has answered
        since its :meth:`begin_round`. Returns those still silent (none: [])."""
        inboxes = [self._agents[agent] for agent in agents]
        deadline = time.monotonic() + timeout_s
        with self._answers:
            while True:
                silent = [inbox.spec.name for inbox in inboxes if not inbox.has_answered()]
                left = deadline - time.monotonic()
                if not silent or left <= 0.0:
                    return silent
                self._answers.wait(left)
