"""The VideoRay Pro 4's manipulator option: a single-function gripper under the bow.

VideoRay sells a manipulator accessory for the Pro 4 that the pilot opens and closes
with the hand controller's "Manipulator Open" and "Manipulator Close" buttons (VideoRay
documentation, e.g. the Cygnus thickness-gauge swing arm, which "uses the standard
manipulator buttons", download.videoray.com); ballast in the skid pods trims the vehicle
with an accessory fitted (Pro 4 Ultra Operator's Manual, "Buoyancy and Depth Control").
Its dimensions and performance were not found in a published datasheet here, so every
number below is an **assumption**, sized to the vehicle (0.375 × 0.289 × 0.223 m) and to
micro-ROV grippers of its class:

* jaw centre at ``position_frd`` = (0.25, 0, 0.14) m: 6 cm ahead of the bow, 3 cm below
  the hull, on the centre line;
* jaws open to 6 cm (``jaw_opening``), close or open in 1.5 s;
* grip force 30 N; rubber-lined jaws on metal, friction 0.4: a held object slips out
  when its in-water weight exceeds ``2 mu F`` = 24 N;
* an object is taken when its grasp point is within 3 cm of the jaw centre
  (``capture_tolerance``) and its grip is no thicker than the opening;
* the manipulator's own weight is trimmed out by ballast (part of the neutral vehicle).

The state machine (:class:`GripperState`): ``open`` → ``closing`` → ``closed`` (on an
object, when the jaws meet its grip, or empty) → ``opening`` → ``open``; what it holds is
the workspace's record (:meth:`uhrisim.teamwork.workspace.Workspace.held_by`). Commands
arrive as "open"/"close" (the helm's variable, MOOS and ROS 2 alike, in the integration).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.settings import check_settings, setting
from uhrisim.world.events import WorldEvent

Phase = Literal["open", "closing", "closed", "opening"]


@dataclass(frozen=True)
class GripperSpec:
    """The gripper's geometry and performance (module docstring; SI)."""

    position_frd: tuple[float, float, float] = setting(
        (0.25, 0.0, 0.14), "m", ge=-1.0, le=1.0, doc="jaw centre in the body frame (FRD)")
    jaw_opening: float = setting(0.06, "m", gt=0.0, le=0.5, doc="gap of the open jaws")
    close_time_s: float = setting(1.5, "s", gt=0.0, le=60.0, doc="time to close fully")
    open_time_s: float = setting(1.5, "s", gt=0.0, le=60.0, doc="time to open fully")
    grip_force_n: float = setting(30.0, "N", gt=0.0, le=1000.0, doc="squeeze of the jaws")
    friction: float = setting(0.4, "1", gt=0.0, le=2.0,
                              doc="jaw-object friction coefficient (holds 2 μ F)")
    capture_tolerance: float = setting(0.03, "m", gt=0.0, le=0.2,
                                       doc="how far off the jaw centre an object is caught")

    def __post_init__(self) -> None:
        check_settings(self)

    @property
    def holding_force_n(self) -> float:
        """The largest in-water weight (N) the jaws hold without slipping: 2 mu F."""
        return 2.0 * self.friction * self.grip_force_n

    def jaw_centre_ned(self, vehicle_pose: NDArray[np.float64]) -> NDArray[np.float64]:
        """Jaw centre in NED for the vehicle's 4x4 body→NED pose."""
        return vehicle_pose[:3, :3] @ self._position_frd + vehicle_pose[:3, 3]

    @cached_property
    def _position_frd(self) -> NDArray[np.float64]:
        """``position_frd`` as an array (read-only), made once."""
        position = np.asarray(self.position_frd)
        position.setflags(write=False)
        return position


@dataclass(frozen=True)
class GripperState:
    """Phase and jaw travel (0 open, 1 fully closed)."""

    phase: Phase = "open"
    travel: float = 0.0

    def gap(self, spec: GripperSpec) -> float:
        """Distance between the jaws (m)."""
        return spec.jaw_opening * (1.0 - self.travel)


def command(spec: GripperSpec, state: GripperState, close: bool, t: float, actor: str = ""
            ) -> tuple[GripperState, list[WorldEvent]]:
    """Start closing (``close``) or opening; no change if it is already going that way."""
    del spec
    if close and state.phase in ("open", "opening"):
        return replace(state, phase="closing"), [WorldEvent(t, "gripper_closing", actor)]
    if not close and state.phase in ("closed", "closing"):
        return replace(state, phase="opening"), [WorldEvent(t, "gripper_opening", actor)]
    return state, []


def advance(spec: GripperSpec, state: GripperState, dt: float, t: float, actor: str = "",
            grip_width: float | None = None) -> tuple[GripperState, list[WorldEvent]]:
    """Move the jaws for ``dt`` s. ``grip_width`` (m): the thickness of an object between
    the jaws, if any: closing stops when the gap reaches it (``gripper_closed`` with
    ``on_width``); otherwise the jaws close fully (``gripper_closed``, empty)."""
    if state.phase == "closing":
        travel = state.travel + dt / spec.close_time_s
        if grip_width is not None and spec.jaw_opening * (1.0 - travel) <= grip_width:
            travel = 1.0 - grip_width / spec.jaw_opening
            return GripperState("closed", travel), [
                WorldEvent(t, "gripper_closed", actor, detail={"on_width": grip_width})]
        if travel >= 1.0:
            return GripperState("closed", 1.0), [
                WorldEvent(t, "gripper_closed", actor, reason="empty")]
        return replace(state, travel=travel), []
    if state.phase == "opening":
        travel = state.travel - dt / spec.open_time_s
        if travel <= 0.0:
            return GripperState("open", 0.0), [WorldEvent(t, "gripper_opened", actor)]
        return replace(state, travel=travel), []
    return state, []
