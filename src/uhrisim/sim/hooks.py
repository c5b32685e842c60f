"""The simulation's read-only publish hooks: their interface and what it hands them each tick.

Hooks (recorder, metrics, viewer, ROS 2 and MOOS bridges) get copies and immutable
snapshots; they never mutate simulation state. Commands from outside enter through
:meth:`uhrisim.sim.simulation.Simulation.post` / ``set_actuators`` instead. The interface
(:class:`Hook`, :class:`BaseHook`) lives here rather than with the Simulation so that a
module defining a hook imports it without the simulation's world (trimesh, OpenCV); the
``sim`` its callbacks get is the :class:`~uhrisim.sim.simulation.Simulation` (typed ``Any``
here: this module is below it).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from uhrisim.dynamics.plants import NavState
from uhrisim.sim.community import Post

if TYPE_CHECKING:
    from uhrisim.sensors.camera.camera import CameraFrame
    from uhrisim.sensors.sonar.ping import SonarPing


def sensor_key(agent: str, sensor: str) -> str:
    """The key of a sensor's outputs in a :class:`TickFrame`: ``"<agent>/<sensor>"``
    (e.g. ``"videoray/sonar"``); the ROS topics and frames of the sensor use the same
    two names."""
    return f"{agent}/{sensor}"


def split_sensor_key(key: str) -> tuple[str, str]:
    """``(agent, sensor)`` of a :func:`sensor_key` (neither name holds a ``/``)."""
    agent, _, sensor = key.partition("/")
    return agent, sensor


@dataclass(frozen=True)
class AgentSnapshot:
    """One agent at one tick: truth navigation, actuator inputs, desired values, helm mode."""

    name: str
    model: str
    nav: NavState
    inputs: tuple[float, ...]
    desired_heading_deg: float
    desired_speed: float
    desired_depth: float
    mode: str


@dataclass(frozen=True, slots=True)
class HelmRecord:
    """A helm decision for the audit trail (MOOS vocabulary: compass deg, m/s, m)."""

    heading_deg: float | None
    speed: float | None
    depth: float | None
    contributions: Mapping[str, float]
    total: float
    mode: str
    active: tuple[str, ...]
    all_stop_reason: str | None = None


@dataclass(frozen=True)
class JointSample:
    """An articulated diver's joints at one tick: names, angles (rad), rates (rad/s)."""

    names: tuple[str, ...]
    position: tuple[float, ...]
    velocity: tuple[float, ...]


@dataclass(frozen=True)
class SimEvent:
    """Something noteworthy: a collision, a scripted event firing, a bridge going down."""

    t: float
    kind: str
    detail: str


class AgentSnapshots(Mapping[str, AgentSnapshot]):
    """The agents of one tick by name, each snapshot taken when it is first read.

    A hook that reads no snapshot on a tick (odometry published at 10 Hz of a 60 Hz loop)
    costs nothing for them. Snapshots can be taken while the tick's hooks run; once the
    simulation moves on, reading one that was never taken raises ``RuntimeError`` (it
    would no longer show that tick). Those already taken stay readable.
    """

    def __init__(self, names: tuple[str, ...], take: Callable[[str], AgentSnapshot]) -> None:
        self._names = names
        self._take = take
        self._taken: dict[str, AgentSnapshot] = {}
        self._open = True

    def __getitem__(self, name: str) -> AgentSnapshot:
        snapshot = self._taken.get(name)
        if snapshot is None:
            if name not in self._names:
                raise KeyError(name)
            if not self._open:
                raise RuntimeError(f"the snapshot of {name!r} was not taken during its tick; "
                                   "read TickFrame.agents inside on_tick")
            snapshot = self._taken[name] = self._take(name)
        return snapshot

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def take_all(self) -> AgentSnapshots:
        """Take every snapshot now (a frame that outlives its tick); returns self."""
        for name in self._names:
            self[name]
        return self

    def close(self) -> None:
        """The simulation moved on: no further snapshot can be taken."""
        self._open = False


@dataclass(frozen=True)
class TickFrame:
    """Everything new at one tick; ``pings``/``images``/``helm`` hold only this tick's
    outputs. Sonar pings, camera frames (``images``) and the sonar perception of a ping
    are keyed by sensor, ``"<agent>/<sensor>"`` (:func:`sensor_key`): an agent may carry
    several of each; ``helm`` is keyed by agent.

    ``agents`` is an :class:`AgentSnapshots` when the simulation makes the frame: read it
    during ``on_tick`` (the frame :meth:`Simulation.step` returns has every snapshot).
    """

    tick: int
    t: float
    agents: Mapping[str, AgentSnapshot]
    pings: Mapping[str, SonarPing] = field(default_factory=dict)
    helm: Mapping[str, HelmRecord] = field(default_factory=dict)
    posts: tuple[Post, ...] = ()
    events: tuple[SimEvent, ...] = ()
    images: Mapping[str, CameraFrame] = field(default_factory=dict)  # camera frames
    # What sonar perception made of this tick's pings, by the key of the ping
    # (uhrisim.perception.pipeline.PerceptionFrame)
    perception: Mapping[str, Any] = field(default_factory=dict)
    # The articulated divers' joints by agent (uhrisim.sim.teamwork): names, angles
    # (rad), rates (rad/s)
    joints: Mapping[str, JointSample] = field(default_factory=dict)


class Hook(Protocol):
    """A read-only observer of the simulation (recorder, metrics, viewer, bridges): told
    of the start, handed every tick's :class:`TickFrame`, told of the end (with the error
    that stopped the run, if one did). It changes nothing itself: what it has to say to
    the simulation (a command from outside) goes through the inbox,
    :meth:`~uhrisim.sim.simulation.Simulation.post` and ``set_actuators``, and acts next
    tick."""

    def on_start(self, sim: Any) -> None: ...

    def on_tick(self, frame: TickFrame) -> None: ...

    def on_end(self, sim: Any, error: BaseException | None) -> None: ...


class BaseHook:
    """Convenience base: every callback does nothing."""

    def on_start(self, sim: Any) -> None:
        del sim

    def on_tick(self, frame: TickFrame) -> None:
        del frame

    def on_end(self, sim: Any, error: BaseException | None) -> None:
        del sim, error

    def summary(self) -> dict[str, Any]:
        return {}
