"""Typed configuration and results of the ROS 2 bridge (no rclpy needed to import).

Topic names, types, frames and QoS are documented in docs/bridges-ros2.md.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import MutableMapping, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

from uhrisim.core.errors import ConfigError

from .limits import THRUSTER_LIMIT, CommandEnvelope

__all__ = ["COMMAND_GROUPS", "ENV_DEFAULTS", "THRUSTER_LIMIT", "AgentBridgeSpec",
           "AgentCommands", "apply_env_defaults", "check_domain_id", "node_namespace"]

#: Command groups an agent may accept from ROS 2: ``"desired"`` = the three
#: ``/<agent>/cmd/desired_*`` topics (what the built-in helm would produce),
#: ``"thrusters"`` = ``/<agent>/cmd/thrusters`` (raw [port, starboard, vertical]).
COMMAND_GROUPS: tuple[str, ...] = ("desired", "thrusters")

#: A ROS 2 name token (one namespace level): a letter, then letters, digits, underscores.
ROS_NAME_TOKEN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def _check_rate(value: float | None, where: str) -> None:
    if value is not None and not (isinstance(value, int | float) and math.isfinite(value)
                                  and value > 0.0):
        raise ConfigError(f"must be a positive rate in Hz or None, got {value!r}", where)


@dataclass(frozen=True)
class AgentBridgeSpec:
    """What the bridge publishes and accepts for one agent (a ROS namespace ``/<name>``).

    ``sonars`` and ``cameras`` name the agent's sensors whose topics it publishes
    (``/<name>/<sensor>/...``, frames ``<name>/<sonar>`` and ``<name>/<camera>_optical``).
    ``odom_rate_hz`` / ``sonar_rate_hz`` throttle publishing in *simulation* time
    (``None``: every call publishes; the sonar rate per sonar); every camera frame the
    simulation makes goes out. ``accept`` lists the command groups subscribed
    (:data:`COMMAND_GROUPS`); ``()`` makes the agent publish-only (e.g. the diver's
    ground truth). ``envelope``: what the vehicle can be commanded to do (speeds, reverse,
    thrusters; :mod:`.limits`), against which every command is checked. ``helm``: the
    agent has a helm of its own whose decisions go out on ``/<name>/helm/*`` (False: those
    topics are not advertised); ``joints``: an articulated body whose joints go out on
    ``/<name>/joint_states``.
    """

    name: str
    sonars: tuple[str, ...] = ("sonar",)
    accept: tuple[str, ...] = COMMAND_GROUPS
    sonar_rate_hz: float | None = None
    odom_rate_hz: float | None = None
    cameras: tuple[str, ...] = ()
    envelope: CommandEnvelope = field(default_factory=CommandEnvelope)
    helm: bool = True
    joints: bool = False

    def __post_init__(self) -> None:
        where = f"AgentBridgeSpec({self.name!r})"
        if not isinstance(self.name, str) or not ROS_NAME_TOKEN.match(self.name):
            raise ConfigError(
                "agent name must be a ROS name token (letter, then letters/digits/_)",
                where=f"{where}.name",
            )
        accept = tuple(self.accept)
        unknown = [a for a in accept if a not in COMMAND_GROUPS]
        if unknown:
            raise ConfigError(
                f"unknown command group(s) {unknown}; choose from {list(COMMAND_GROUPS)}",
                where=f"{where}.accept",
            )
        object.__setattr__(self, "accept", accept)
        sensors = [*self.sonars, *self.cameras]
        for sensor in sensors:
            if not isinstance(sensor, str) or not ROS_NAME_TOKEN.match(sensor):
                raise ConfigError(f"sensor name {sensor!r} is not a ROS name token",
                                  where=f"{where}.sonars")
        if len(set(sensors)) != len(sensors):
            raise ConfigError(f"sensor names must be unique, got {sensors}",
                              where=f"{where}.sonars")
        object.__setattr__(self, "sonars", tuple(self.sonars))
        object.__setattr__(self, "cameras", tuple(self.cameras))
        _check_rate(self.sonar_rate_hz, f"{where}.sonar_rate_hz")
        _check_rate(self.odom_rate_hz, f"{where}.odom_rate_hz")


@dataclass(frozen=True)
class AgentCommands:
    """The latest commands received from ROS 2 for one agent, as of ``t_sim``.

    A field is ``None`` when nothing was received on its topic within the bridge's
    ``command_timeout_s`` (or never). The caller treats ``None`` as "no command":
    zero speed, hold the current depth, zero thrusters.

    ``stale`` is True when commands *were* received for this agent but every one of
    them is now older than the timeout: the peer went silent, perform a safe stop.
    It is False when no command was ever received (the agent is not under external
    control; the built-in helm keeps the vehicle) and while any command is fresh.
    ``age_s`` is the age of the newest command (in the timeout's clock, s), or ``None``.
    ``received_count`` counts every command message accepted for the agent so far (it
    changes when something new arrived, e.g. to forward each one exactly once).
    ``lapsed``: the desired topics (``"desired_heading"``, ``"desired_speed"``,
    ``"desired_depth"``) whose value is older than the timeout: every value refused or
    none sent since, or none ever sent while the first desired value of any kind is older
    than the timeout; empty until a desired value has arrived. The caller falls back per
    topic: zero speed, hold the heading and the depth of that moment.

    Units: ``desired_heading_deg`` compass degrees [0, 360); ``desired_speed`` m/s;
    ``desired_depth`` m, positive down; ``thrusters`` ``(port, starboard, vertical)``,
    dimensionless in [-150, 150].
    """

    desired_heading_deg: float | None = None
    desired_speed: float | None = None
    desired_depth: float | None = None
    thrusters: tuple[float, float, float] | None = None
    stale: bool = False
    lapsed: frozenset[str] = frozenset()
    age_s: float | None = None
    received_count: int = 0

    @property
    def received(self) -> bool:
        """True once any command has been received for this agent."""
        return self.age_s is not None

    @property
    def has_desired(self) -> bool:
        """True when at least one fresh ``desired_*`` value is present."""
        return any(
            v is not None
            for v in (self.desired_heading_deg, self.desired_speed, self.desired_depth)
        )


#: Environment defaults the bridge applies when the user has not set them.
#: ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` keeps DDS discovery on loopback; the old
#: The pre-Jazzy localhost-only switch is ignored by ROS 2 Kilted and is never set here.
ENV_DEFAULTS: dict[str, str] = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}


#: uhrisim's Fast DDS profile: an 8 MiB shared-memory segment (a ping's three images,
#: ~600 kB, exceed the default 512 kB one: best-effort subscribers lost messages), UDP on
#: loopback only. Set as ``FASTDDS_DEFAULT_PROFILES_FILE`` unless the user set their own.
FASTDDS_PROFILE = Path(__file__).with_name("fastdds_profile.xml")


def apply_env_defaults(environ: MutableMapping[str, str] | None = None) -> dict[str, str]:
    """Set each of :data:`ENV_DEFAULTS` that is missing from ``environ`` (default
    ``os.environ``, which rcl reads when a context starts), and
    ``FASTDDS_DEFAULT_PROFILES_FILE`` = :data:`FASTDDS_PROFILE` when the middleware is Fast
    DDS (ROS 2's default) and no profile is set; return those it set."""
    env = os.environ if environ is None else environ
    applied: dict[str, str] = {}
    defaults = dict(ENV_DEFAULTS)
    if env.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp").startswith("rmw_fastrtps"):
        defaults["FASTDDS_DEFAULT_PROFILES_FILE"] = str(FASTDDS_PROFILE)
    for key, value in defaults.items():
        if not env.get(key):
            env[key] = value
            applied[key] = value
    return applied


def node_namespace(namespace: str, ros_args: Sequence[str]) -> str:
    """The namespace a node made with ``namespace`` and ``ros_args`` gets: the last
    ``-r``/``--remap __ns:=...`` of ``ros_args`` wins (as rcl does), normalised to ``""``
    (the root) or ``"/name"``."""
    for flag, value in pairwise(ros_args):
        if flag in ("-r", "--remap") and value.startswith("__ns:="):
            namespace = value.partition(":=")[2]
    namespace = namespace.strip().rstrip("/")
    return namespace if not namespace or namespace.startswith("/") else f"/{namespace}"


def check_domain_id(domain_id: int | None) -> int | None:
    """Validate a ROS domain id (0-232; 0-101 are safe on every OS) or None."""
    if domain_id is None:
        return None
    if isinstance(domain_id, bool) or not isinstance(domain_id, int) or not (
        0 <= domain_id <= 232
    ):
        raise ConfigError(f"must be an integer in 0..232, got {domain_id!r}", "domain_id")
    return domain_id
