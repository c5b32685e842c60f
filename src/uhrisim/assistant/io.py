"""The assistant's I/O: what it reads each tick and what it writes, nothing else.

The tree never touches the simulation, MOOS or ROS 2; whoever runs it fills an
:class:`AssistantInputs` each tick and carries out the :class:`AssistantOutputs` — the
simulation loop, a MOOS app or a ROS 2 node alike (docs/hri.md, "Wiring").

**Reads** (NED metres, compass degrees; docs/conventions.md): the ROV's navigation, the
diver's track (from the sonar tracker or, in a test, the truth; None when there is
none), the gripper's state, the signals recognized since the last tick, and where the
tools and work sites are (grasp points, from the mission's map).

**Writes**: helm variable postings in MOOS's vocabulary (x east, y north; see
:data:`HELM_VARS`), only when a value changes; a gripper command ("open"/"close", also
posted as ``GRIPPER_CMD``); the task, the tree's active path and events. While the
assistant backs away from the diver it parks the helm (``MOOS_MANUAL_OVERRIDE = true``)
and posts ``DESIRED_HEADING``/``DESIRED_SPEED`` (astern)/``DESIRED_DEPTH`` itself, as a
pilot taking over would; ``MOOS_MANUAL_OVERRIDE = false`` hands the helm back.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import moos_xy_from_ned
from uhrisim.perception.signals import RecognizedSignal

GripperPhase = Literal["open", "closing", "closed", "opening"]
GripperCommand = Literal["open", "close"]
HelmMode = Literal["FOLLOW", "GOTO", "APPROACH", "FACE"]
Posting = tuple[str, str | float]

#: the helm variables the assistant posts, and what each carries
HELM_VARS: dict[str, str] = {
    "ASSIST_MODE": "the motion primitive: FOLLOW, GOTO, APPROACH or FACE (assistant.bhv)",
    "WPT_UPDATES": "GOTO's point and speed: 'points=x,y # speed=v'",
    "STATION_UPDATES": "APPROACH's point and speeds: 'station_pt=x,y # outer_speed=v # "
                       "transit_speed=v'",
    "HEADING_UPDATES": "FACE's heading: 'heading=deg'",
    "DEPTH_UPDATES": "the depth to hold: 'depth=m'",
    "TRAIL_UPDATES": "FOLLOW's range behind the diver: 'trail_range=m'",
    "MAXSPEED_UPDATES": "the speed ceiling, lowered near the diver: 'max_speed=v'",
    "MOOS_MANUAL_OVERRIDE": "true while the assistant backs away itself, else false",
    "DESIRED_HEADING": "while overriding: the heading (deg) facing the diver",
    "DESIRED_SPEED": "while overriding: astern (m/s, negative) or 0",
    "DESIRED_DEPTH": "while overriding: the depth (m)",
    "GRIPPER_CMD": "the gripper command: open or close",
    "ASSIST_TASK": "the task in hand (a command, or idle)",
    "ASSIST_ACTIVE": "the tree's active path, e.g. 'assistant/guards/too close/back off'",
    "ASSIST_QUERY": "say_again while the ROV shows its 'say again?' cue (its lamps swung "
                    "off the diver and back), else none",
}

_UP = np.array([0.0, 0.0, -1.0])


def _point(value: object, where: str) -> NDArray[np.float64]:
    p = np.asarray(value, dtype=float).reshape(-1)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ConfigError(f"must be 3 finite numbers (NED, m), got {value!r}", where)
    return p


@dataclass(frozen=True)
class RovNav:
    """The ROV's navigation: position (NED, m), compass heading (deg), speed through the
    water along its heading (m/s, negative astern)."""

    position_ned: NDArray[np.float64]
    heading_deg: float
    speed: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_ned", _point(self.position_ned, "RovNav.position"))


@dataclass(frozen=True)
class DiverTrack:
    """The diver as the ROV knows it: body centre (the pelvis, NED m), compass heading
    (deg), horizontal speed (m/s), the track's age (s since its last update) and, when
    known (the articulated diver's joints, in the simulator), head and working hand, and
    the head's velocity relative to the body centre (NED m/s: he rises upright, bends
    to his work; :class:`~uhrisim.assistant.Assistant` fills it in from successive
    tracks when the tracker does not). Without a head the diver is taken as upright,
    the head ``HEAD_ABOVE_M`` above the body centre; without a hand, the hand held out
    in front (``HAND_AHEAD_M`` ahead, ``HAND_ABOVE_M`` up)."""

    position_ned: NDArray[np.float64]
    heading_deg: float
    speed: float = 0.0
    age_s: float = 0.0
    head_ned: NDArray[np.float64] | None = None
    hand_ned: NDArray[np.float64] | None = None
    head_rate_ned: NDArray[np.float64] | None = None

    #: assumed body geometry (m) of a 1.75 m diver (Winter's segment ratios, docs/hri.md)
    HEAD_ABOVE_M = 0.71
    NECK_ABOVE_M = 0.55
    HAND_AHEAD_M = 0.57
    HAND_ABOVE_M = 0.18

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_ned", _point(self.position_ned, "DiverTrack.position"))
        for name in ("head_ned", "hand_ned", "head_rate_ned"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _point(getattr(self, name), f"DiverTrack.{name}"))

    @property
    def forward(self) -> NDArray[np.float64]:
        """Unit horizontal vector of the diver's heading (NED)."""
        h = math.radians(self.heading_deg)
        return np.array([math.cos(h), math.sin(h), 0.0])

    @property
    def head(self) -> NDArray[np.float64]:
        return self.head_ned if self.head_ned is not None else (
            self.position_ned + self.HEAD_ABOVE_M * _UP)

    @property
    def neck(self) -> NDArray[np.float64]:
        """Top of the body segment the body guard keeps away from (below the head)."""
        head = self.head
        axis = head - self.position_ned
        length = float(np.linalg.norm(axis))
        if length == 0.0:
            return head
        return self.position_ned + axis * min(1.0, self.NECK_ABOVE_M / self.HEAD_ABOVE_M)

    def upright(self) -> DiverTrack:
        """The diver as he would be risen upright where he is (head above the body
        centre, DiverTrack's geometry; hand unchanged)."""
        return replace(self, head_ned=None, head_rate_ned=None)

    @property
    def hand(self) -> NDArray[np.float64]:
        return self.hand_ned if self.hand_ned is not None else (
            self.position_ned + self.HAND_AHEAD_M * self.forward + self.HAND_ABOVE_M * _UP)


@dataclass(frozen=True)
class GripperStatus:
    """The gripper: its phase, the object it holds (None: empty) and who else holds that
    object (a diver taking it during a handover)."""

    phase: GripperPhase = "open"
    holding: str | None = None
    shared_with: tuple[str, ...] = ()


@dataclass(frozen=True)
class AssistantInputs:
    """Everything the assistant reads in one tick (module docstring)."""

    t: float
    rov: RovNav
    diver: DiverTrack | None
    gripper: GripperStatus = GripperStatus()
    signals: tuple[RecognizedSignal, ...] = ()
    tools: Mapping[str, NDArray[np.float64]] = field(default_factory=dict)
    sites: Mapping[str, NDArray[np.float64]] = field(default_factory=dict)


@dataclass(frozen=True)
class AssistantOutputs:
    """Everything the assistant writes in one tick (module docstring)."""

    t: float
    posts: tuple[Posting, ...]
    gripper_command: GripperCommand | None
    task: str
    active: str
    events: tuple[str, ...]


def moos_xy(point_ned: NDArray[np.float64]) -> str:
    """``"x,y"`` of a NED point in MOOS's local frame (x east, y north), cm resolution."""
    x, y = moos_xy_from_ned(float(point_ned[0]), float(point_ned[1]))
    return f"{x:.2f},{y:.2f}"
