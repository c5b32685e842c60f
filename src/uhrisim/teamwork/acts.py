"""Acts: grasp, release, place, drop, hand over, use — the rules in one place.

Every act takes the :class:`~uhrisim.teamwork.workspace.Workspace`, a **carrier** (a
diver's hand, :class:`Hand`, or the ROV's gripper, :class:`Jaws`) as it is this tick, and
returns :class:`~uhrisim.world.events.WorldEvent` s: the change it made, or a failed
event whose ``reason`` says why (one line). The simulation calls them at one fixed stage
of its tick, after the bodies have moved and before the physics of free objects.

The rules:

* **grasp** — the object exists; the carrier holds nothing; a hand is open (fingers less
  than 30 % closed), the jaws have just closed on it (the simulation asks
  :func:`between_jaws` what they will meet while they close); the grasp point is
  **within reach** (a hand: the arm can put its grip point there with the diver's
  posture and legs as they are, :func:`uhrisim.dynamics.diver_body.solve_reach`; the
  jaws: no arm, so reach is the tolerance); the
  carrier's grip point is **within tolerance** of it (a hand 5 cm: a gloved hand closes
  on what is at its palm, assumed; the jaws their capture tolerance); the grip fits the
  jaws and its in-water weight does not exceed what they hold. An object someone else
  holds may be grasped too: both then hold it (that is a handover's middle).
* **release** — the carrier holds something; if nobody else holds it, it is free: it
  rests where it is when a support (the floor, a basket's bottom, a platform) is within
  5 cm below it, else it falls (``drop``, counted as a dropped object) onto the first
  support under it.
* **place** — release at a chosen point: within reach and tolerance, over a support.
* **hand over** — the receiver grasps (every grasp rule) while the giver still holds;
  at that moment both hold (the event lists both); then the giver releases.
* **use** — the carrier holds a tool of the kind the site needs, the tool's working
  point reaches the site's work point (grip-to-work distance within the tool's length
  plus 5 cm), and the site's own transition does the rest (a wrench works a bolt, a
  hammer frees a latch, a lift bag is made fast to a load's eye).
* **by hand** — take out a loose bolt, take off the cover, open or close a hatch, open
  or shut a lift bag's inflation: within reach of the part.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.dynamics.diver_body import DiverSkeleton, ReachSolution, Side, solve_reach
from uhrisim.teamwork.gripper import GripperSpec, GripperState
from uhrisim.teamwork.workspace import SUPPORT_TOLERANCE_M, FloorDepth, Workspace, pose_matrix
from uhrisim.world.events import WorldEvent

#: A gloved hand takes what is within this of its palm centre (m; assumed).
HAND_TOLERANCE_M = 0.05
#: Fingers closed beyond this fraction count as a closed hand.
OPEN_HAND_CLOSURE = 0.3
#: What each site needs to be worked.
TOOL_FOR = {"flange": "wrench", "hatch": "hammer", "load": "lift_bag"}


@dataclass(frozen=True)
class Hand:
    """A diver's hand this tick: the diver's body pose (4x4 body→NED, origin at the hip
    centre), skeleton and joint angles."""

    diver: str
    side: Side
    skeleton: DiverSkeleton
    q: NDArray[np.float64]
    body_pose: NDArray[np.float64]

    @property
    def name(self) -> str:
        return f"{self.diver}/{self.side}_hand"

    def grip_frame(self) -> NDArray[np.float64]:
        """4x4 NED pose of the hand (origin at its grip point; read-only)."""
        return self.skeleton.hand_frame_ned(self.q, self.side, self.body_pose)

    def to_body(self, point_ned: ArrayLike) -> NDArray[np.float64]:
        r, p = self.body_pose[:3, :3], self.body_pose[:3, 3]
        return r.T @ (np.asarray(point_ned, dtype=float) - p)

    def reach(self, point_ned: ArrayLike) -> ReachSolution:
        """Can this arm put the grip point on ``point_ned`` from where the diver is?"""
        return solve_reach(self.skeleton, self.side, self.to_body(point_ned), self.q)

    def is_open(self) -> bool:
        return self.skeleton.grip_closure(self.q, self.side) <= OPEN_HAND_CLOSURE


@dataclass(frozen=True)
class Jaws:
    """The ROV's gripper this tick: the vehicle's pose (4x4 body→NED), spec and state."""

    rov: str
    spec: GripperSpec
    state: GripperState
    body_pose: NDArray[np.float64]

    @property
    def name(self) -> str:
        return f"{self.rov}/gripper"

    def grip_frame(self) -> NDArray[np.float64]:
        m = self.body_pose.copy()
        m[:3, 3] = self.spec.jaw_centre_ned(self.body_pose)
        return m


Carrier = Hand | Jaws


def _failed(t: float, kind: str, subject: str, carrier: Carrier, reason: str) -> WorldEvent:
    return WorldEvent(t, kind, subject, carrier.name, False, reason)


def _distance(carrier: Carrier, point: NDArray[np.float64]) -> float:
    return float(np.linalg.norm(carrier.grip_frame()[:3, 3] - point))


def _reach_reason(carrier: Carrier, point: NDArray[np.float64], tolerance: float
                  ) -> str | None:
    """Why ``carrier`` cannot put its grip point on ``point`` now (None: it can):
    out of reach, or not there (farther than ``tolerance``)."""
    if isinstance(carrier, Hand):
        solution = carrier.reach(point)
        if not solution.ok:
            return solution.reason
    distance = _distance(carrier, point)
    if distance > tolerance:
        what = "hand" if isinstance(carrier, Hand) else "jaw centre"
        return f"{what} {distance:.2f} m from it (tolerance {tolerance:.2f} m)"
    return None


def grasp(ws: Workspace, carrier: Carrier, obj: str, t: float) -> list[WorldEvent]:
    """Take hold of ``obj`` (module docstring: the grasp rules, in order)."""
    if obj not in ws.things:
        return [_failed(t, "grasp_failed", obj, carrier, f"no object {obj!r}")]
    held = ws.held_by(carrier.name)
    if held is not None:
        return [_failed(t, "grasp_failed", obj, carrier, f"already holds {held}")]
    where = ws.things[obj].where
    if where.startswith("rigged:"):
        return [_failed(t, "grasp_failed", obj, carrier, f"it is rigged to {where[7:]}")]
    if isinstance(carrier, Hand) and not carrier.is_open():
        return [_failed(t, "grasp_failed", obj, carrier, "the hand is closed")]
    if isinstance(carrier, Jaws) and carrier.state.phase != "closed":
        return [_failed(t, "grasp_failed", obj, carrier, f"the jaws are {carrier.state.phase}")]
    tolerance = HAND_TOLERANCE_M if isinstance(carrier, Hand) else carrier.spec.capture_tolerance
    reason = _reach_reason(carrier, ws.grasp_point(obj), tolerance)
    if reason:
        return [_failed(t, "grasp_failed", obj, carrier, reason)]
    if isinstance(carrier, Jaws):
        width = ws.grip_width(obj)
        if width > carrier.spec.jaw_opening:
            return [_failed(t, "grasp_failed", obj, carrier,
                            f"grip {width:.3f} m wider than the jaws open "
                            f"({carrier.spec.jaw_opening:.3f} m)")]
        weight = ws.hydro_of(obj).in_water_weight()
        if abs(weight) > carrier.spec.holding_force_n:
            return [_failed(t, "grasp_failed", obj, carrier,
                            f"too heavy for the jaws: {abs(weight):.1f} N in water, they "
                            f"hold {carrier.spec.holding_force_n:.1f} N")]
    others = ws.holders_of(obj)
    ws.take(carrier.name, obj, carrier.grip_frame())
    detail = {"holders": ", ".join((*others, carrier.name))}
    return [WorldEvent(t, "grasp", obj, carrier.name, detail=detail)]


def release(ws: Workspace, carrier: Carrier, t: float, floor_depth: FloorDepth
            ) -> list[WorldEvent]:
    """Let go of what ``carrier`` holds: it rests on a support within 5 cm below it,
    or falls (``drop``); if someone else still holds it, it stays with them."""
    obj = ws.held_by(carrier.name)
    if obj is None:
        return [_failed(t, "release_failed", "", carrier, "holds nothing")]
    free = ws.let_go(carrier.name)
    if free is None:
        return [WorldEvent(t, "release", obj, carrier.name,
                           detail={"holders": ", ".join(ws.holders_of(obj))})]
    support, gap = ws.support_below(obj, floor_depth)
    if gap <= SUPPORT_TOLERANCE_M:
        ws.rest_on(obj, support, gap)
        return [WorldEvent(t, "release", obj, carrier.name, detail={"on": support})]
    return [WorldEvent(t, "drop", obj, carrier.name, detail={"fall_m": round(gap, 3)})]


def _hang_level(ws: Workspace, obj: str, grasp_ned: NDArray[np.float64]) -> None:
    """Turn ``obj`` level (keeping its heading) with its grasp point at ``grasp_ned``."""
    thing = ws.things[obj]
    level = pose_matrix(np.zeros(3), math.atan2(thing.pose[1, 0], thing.pose[0, 0]))
    local = (ws.tools[obj].grasp_offset() if obj in ws.tools
             else ws.loads[obj].attachment_site())
    level[:3, 3] = grasp_ned - level[:3, :3] @ local
    thing.pose = level


def place(ws: Workspace, carrier: Carrier, target_ned: ArrayLike, t: float,
          floor_depth: FloorDepth) -> list[WorldEvent]:
    """Put what ``carrier`` holds down with its grasp point at ``target_ned``: the
    carrier must reach it (and be there), a support must be within 5 cm below it."""
    obj = ws.held_by(carrier.name)
    if obj is None:
        return [_failed(t, "place_failed", "", carrier, "holds nothing")]
    target = np.asarray(target_ned, dtype=float)
    tolerance = HAND_TOLERANCE_M if isinstance(carrier, Hand) else carrier.spec.capture_tolerance
    reason = _reach_reason(carrier, target, tolerance)
    if reason:
        return [_failed(t, "place_failed", obj, carrier, reason)]
    if len(ws.holders_of(obj)) > 1:
        return [_failed(t, "place_failed", obj, carrier, "someone else holds it too")]
    thing = ws.things[obj]
    before = thing.pose.copy()
    _hang_level(ws, obj, target)  # put down level, its grasp point at the target
    support, gap = ws.support_below(obj, floor_depth)
    if gap > SUPPORT_TOLERANCE_M:
        thing.pose = before
        return [_failed(t, "place_failed", obj, carrier,
                        f"nothing to put it on within {SUPPORT_TOLERANCE_M:.2f} m "
                        f"({support} {gap:.2f} m below)")]
    ws.let_go(carrier.name)
    ws.rest_on(obj, support, gap)
    return [WorldEvent(t, "place", obj, carrier.name, detail={"on": support})]


def hand_over(ws: Workspace, giver: Carrier, receiver: Carrier, obj: str, t: float,
              floor_depth: FloorDepth) -> list[WorldEvent]:
    """The receiver grasps ``obj`` while the giver holds it, then the giver lets go."""
    if ws.held_by(giver.name) != obj:
        return [_failed(t, "handover_failed", obj, giver, f"{giver.name} does not hold {obj}")]
    taken = grasp(ws, receiver, obj, t)
    if not taken[-1].ok:
        return [*taken, _failed(t, "handover_failed", obj, giver, taken[-1].reason)]
    both = ws.holders_of(obj)
    handover = WorldEvent(t, "handover", obj, giver.name,
                          detail={"to": receiver.name, "holders": ", ".join(both)})
    return [*taken, handover, *release(ws, giver, t, floor_depth)]


def _work_point(ws: Workspace, site: str, part: int | str) -> NDArray[np.float64] | str:
    """Where a tool works on ``site`` (NED), or why there is no such place."""
    if site in ws.flanges:
        spec = ws.flanges[site]
        if not isinstance(part, int) or not 0 <= part < spec.n_bolts:
            return f"no bolt {part!r} on {site} (bolts 0 to {spec.n_bolts - 1})"
        return spec.bolt_position(part)
    if site in ws.hatches:
        return ws.hatches[site].latch_position()
    if site in ws.loads:
        return ws.grasp_point(site)
    return f"no work site {site!r}"


def site_kind(ws: Workspace, site: str) -> str | None:
    """'flange', 'hatch', 'load' or None."""
    for kind, group in (("flange", ws.flanges), ("hatch", ws.hatches), ("load", ws.loads)):
        if site in group:
            return kind
    return None


def use(ws: Workspace, carrier: Carrier, site: str, part: int | str, dt: float, t: float
        ) -> list[WorldEvent]:
    """Work ``site`` (``part``: a bolt number, else ignored) for ``dt`` s with the held
    tool: a wrench on a flange bolt, a hammer on a hatch latch, a lift bag on a load's
    eye (made fast at once)."""
    tool = ws.held_by(carrier.name)
    kind = site_kind(ws, site)
    if kind is None:
        return [_failed(t, "use_failed", site, carrier, f"no work site {site!r}")]
    if tool is None or ws.tools.get(tool) is None or ws.tools[tool].kind != TOOL_FOR[kind]:
        holding = f"holds {tool}" if tool else "holds nothing"
        return [_failed(t, "use_failed", site, carrier,
                        f"a {kind} needs a {TOOL_FOR[kind]} ({carrier.name} {holding})")]
    point = _work_point(ws, site, part)
    if isinstance(point, str):
        return [_failed(t, "use_failed", site, carrier, point)]
    spec = ws.tools[tool]
    span = float(np.linalg.norm(np.subtract(spec.working_point, spec.grasp_point)))
    gap = _distance(carrier, point)
    if gap > span + HAND_TOLERANCE_M:
        return [_failed(t, "use_failed", site, carrier,
                        f"the {spec.kind} does not reach: {gap:.2f} m from the work point, "
                        f"the tool spans {span:.2f} m")]
    if kind == "flange":
        ws.flange_states[site], events = ws.flanges[site].work(
            ws.flange_states[site], int(part), dt, t, carrier.name)
        return events
    if kind == "hatch":
        ws.hatch_states[site], events = ws.hatches[site].work(
            ws.hatch_states[site], dt, t, carrier.name)
        return events
    return _rig_bag(ws, carrier, tool, site, t)


def _rig_bag(ws: Workspace, carrier: Carrier, bag: str, load: str, t: float
             ) -> list[WorldEvent]:
    state, events = ws.bags[bag].attach(ws.bag_states[bag], load, t, carrier.name)
    if events and events[-1].ok:
        ws.bag_states[bag] = state
        ws.let_go(carrier.name)
        ws.things[bag].where = f"rigged:{load}"
    return events


def _by_hand(ws: Workspace, carrier: Carrier, point: NDArray[np.float64], subject: str,
             kind: str, t: float, change: Callable[[], list[WorldEvent]]
             ) -> list[WorldEvent]:
    reason = _reach_reason(carrier, point, HAND_TOLERANCE_M)
    if reason:
        return [_failed(t, kind, subject, carrier, reason)]
    return change()


def remove_bolt(ws: Workspace, carrier: Carrier, flange: str, bolt: int, t: float
                ) -> list[WorldEvent]:
    """Take a loose bolt out by hand."""
    spec = ws.flanges[flange]

    def change() -> list[WorldEvent]:
        ws.flange_states[flange], events = spec.remove_bolt(ws.flange_states[flange], bolt,
                                                            t, carrier.name)
        return events

    return _by_hand(ws, carrier, spec.bolt_position(bolt), flange, "remove_failed", t, change)


def remove_cover(ws: Workspace, carrier: Carrier, flange: str, t: float) -> list[WorldEvent]:
    """Take the cover off by hand (every bolt out)."""
    spec = ws.flanges[flange]

    def change() -> list[WorldEvent]:
        ws.flange_states[flange], events = spec.remove_cover(ws.flange_states[flange], t,
                                                             carrier.name)
        return events

    return _by_hand(ws, carrier, spec.cover_grasp_position(), flange, "remove_failed", t,
                    change)


def operate_hatch(ws: Workspace, carrier: Carrier, hatch: str, open_: bool, t: float
                  ) -> list[WorldEvent]:
    """Swing a hatch open or shut by its handle."""
    spec = ws.hatches[hatch]

    def change() -> list[WorldEvent]:
        ws.hatch_states[hatch], events = spec.command(ws.hatch_states[hatch], open_, t,
                                                      carrier.name)
        return events

    return _by_hand(ws, carrier, spec.handle_position(ws.hatch_states[hatch]), hatch,
                    "open_failed", t, change)


def inflate(ws: Workspace, carrier: Carrier, bag: str, on: bool, t: float) -> list[WorldEvent]:
    """Open (``on``) or shut the inflation of a rigged lift bag at its mouth."""
    state = ws.bag_states[bag]
    if state.attached_to is None:
        return [_failed(t, "inflate_failed", bag, carrier, f"{bag} is not rigged to a load")]

    def change() -> list[WorldEvent]:
        ws.bag_states[bag], events = ws.bags[bag].set_inflating(state, on, t, carrier.name)
        return events

    mouth = ws.grasp_point(state.attached_to)
    return _by_hand(ws, carrier, mouth, bag, "inflate_failed", t, change)


def between_jaws(ws: Workspace, jaws: Jaws) -> str | None:
    """The free object whose grasp point is nearest the jaw centre within the capture
    tolerance (what the closing jaws will meet), or None."""
    centre = jaws.grip_frame()[:3, 3]
    best, best_d = None, jaws.spec.capture_tolerance
    for name, thing in ws.things.items():
        if thing.where in ("held",) or thing.where.startswith("rigged:"):
            continue
        d = float(np.linalg.norm(ws.grasp_point(name) - centre))
        if d <= best_d:
            best, best_d = name, d
    return best


@dataclass(frozen=True)
class ActRequest:
    """An act a script (or a pilot) asks for this tick; :func:`perform` does it.

    ``kind``: grasp, release, place, hand_over, use, remove_bolt, remove_cover,
    operate_hatch, inflate. ``carrier``: who acts; ``subject``: the object or site;
    ``part``: a bolt number; ``flag``: open/on for hatches and bags; ``target``: where to
    place; ``receiver``: the carrier that takes a handover.
    """

    kind: str
    carrier: str
    subject: str = ""
    part: int = 0
    flag: bool = True
    target: tuple[float, float, float] | None = None
    receiver: str = ""

    def by(self, carrier: str) -> ActRequest:
        """This request with ``carrier`` acting (``dataclasses.replace``'s answer, made
        directly)."""
        return ActRequest(self.kind, carrier, self.subject, self.part, self.flag,
                          self.target, self.receiver)


def perform(request: ActRequest, ws: Workspace, carriers: dict[str, Carrier], t: float,
            dt: float, floor_depth: FloorDepth) -> list[WorldEvent]:
    """Do ``request`` with the carriers as they are this tick (name -> Hand or Jaws)."""
    carrier = carriers.get(request.carrier)
    if carrier is None:
        return [WorldEvent(t, f"{request.kind}_failed", request.subject, request.carrier, False,
                           f"no carrier {request.carrier!r}")]
    match request.kind:
        case "grasp":
            return grasp(ws, carrier, request.subject, t)
        case "release":
            return release(ws, carrier, t, floor_depth)
        case "place":
            return place(ws, carrier, request.target, t, floor_depth)
        case "hand_over":
            receiver = carriers.get(request.receiver)
            if receiver is None:
                return [_failed(t, "handover_failed", request.subject, carrier,
                                f"no carrier {request.receiver!r}")]
            return hand_over(ws, carrier, receiver, request.subject, t, floor_depth)
        case "use":
            return use(ws, carrier, request.subject, request.part, dt, t)
        case "remove_bolt":
            return remove_bolt(ws, carrier, request.subject, request.part, t)
        case "remove_cover":
            return remove_cover(ws, carrier, request.subject, t)
        case "operate_hatch":
            return operate_hatch(ws, carrier, request.subject, request.flag, t)
        case "inflate":
            return inflate(ws, carrier, request.subject, request.flag, t)
    return [_failed(t, "act_failed", request.subject, carrier, f"no act {request.kind!r}")]
