"""Order-based diver scripts: typed orders, their preconditions and effects, a validator.

A diver's script is a list of orders (the paper asks for the human to be scripted; the
signals themselves come with the next issue):

=====================  =====================================================================
order                  meaning
=====================  =====================================================================
``GoTo``               walk or swim to an object, a site or a point (north, east)
``PickUp``             take an object with a hand (from where it lies, or from whoever holds it)
``UseOn``              work a site with the held tool for ``seconds`` (a bolt, a latch, a load)
``Remove``             take out a loose bolt, or the cover, by hand
``Operate``            open/close a hatch; start/stop inflating a rigged lift bag
``PutDown``            put the held object on a platform or into a basket
``HandTo``             hand the held object to another diver's hand or the ROV's gripper
``WaitUntil``          wait until a condition holds (``timeout_s``)
``Signal``             make a signal (a named pose held for a while: a placeholder)
``SetMode``            walk or swim
=====================  =====================================================================

:func:`validate_orders` refuses, before the run, orders that cannot be executed, with one
line each naming the order: a tool or site that does not exist, a tool that does not fit
the site, a bolt that is not there, a condition that means nothing for its subject, a
site no walking path reaches (over the floor, no slope steeper than the diver walks), a
site higher than a walking diver reaches, and orders whose preconditions the orders
before them never make true (the cover before every bolt is out, a tool handed on that
is no longer held, a bolt taken out before it was worked loose).
"""

from __future__ import annotations

import math
import re
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from uhrisim.dynamics.diver_body import SIDES, Side

if TYPE_CHECKING:
    from uhrisim.teamwork.workspace import Workspace

#: Signals a script may make (placeholders: each is the signal-ready pose, held).
SIGNALS = ("ok", "up", "down", "stop", "come_here", "hold_this")


@dataclass(frozen=True)
class GoTo:
    target: str | tuple[float, float]
    standoff_m: float = 0.6


@dataclass(frozen=True)
class PickUp:
    obj: str
    hand: Side = "right"


@dataclass(frozen=True)
class UseOn:
    tool: str
    site: str
    seconds: float
    part: int = 0


@dataclass(frozen=True)
class Remove:
    site: str
    part: int | Literal["cover"]


@dataclass(frozen=True)
class Operate:
    site: str
    action: Literal["open", "close", "inflate", "stop"]


@dataclass(frozen=True)
class PutDown:
    obj: str
    on: str


@dataclass(frozen=True)
class HandTo:
    obj: str
    receiver: str


@dataclass(frozen=True)
class WaitUntil:
    subject: str
    state: str
    timeout_s: float = 600.0


@dataclass(frozen=True)
class Signal:
    name: str
    seconds: float = 2.0
    channel: str | None = None  # a command performed on a channel (docs/hri.md)


@dataclass(frozen=True)
class SetMode:
    mode: Literal["walk", "swim"]


Order = GoTo | PickUp | UseOn | Remove | Operate | PutDown | HandTo | WaitUntil | Signal | SetMode


def describe(order: Order) -> str:
    """A short human name for an order (errors, the task-progress panel)."""
    match order:
        case GoTo(target=target):
            return f"go to {target}"
        case PickUp(obj=obj):
            return f"pick up {obj}"
        case UseOn(tool=tool, site=site, seconds=seconds):
            return f"use {tool} on {site} for {seconds:g} s"
        case Remove(site=site, part=part):
            return f"remove {site} {part if part == 'cover' else f'bolt {part}'}"
        case Operate(site=site, action=action):
            return f"{action} {site}"
        case PutDown(obj=obj, on=on):
            return f"put {obj} on {on}"
        case HandTo(obj=obj, receiver=receiver):
            return f"hand {obj} to {receiver}"
        case WaitUntil(subject=subject, state=state):
            return f"wait until {subject} {state}"
        case Signal(name=name):
            return f"signal {name}"
        case SetMode(mode=mode):
            return mode
    raise TypeError(f"not an order: {order!r}")


# ---------------------------------------------------------------------------- conditions

_BOLT = re.compile(r"bolt(\d+)_(loose|out)$")


def condition_holds(ws: Workspace, subject: str, state: str) -> bool:
    """Whether ``subject`` is in ``state`` now (:func:`condition_error` lists the
    states each kind of subject has)."""
    if subject in ws.flanges:
        spec, s = ws.flanges[subject], ws.flange_states[subject]
        if state == "cover_off":
            return not s.cover_on
        if state == "all_bolts_out":
            return all(s.removed)
        m = _BOLT.match(state)
        status = spec.bolt_status(s, int(m.group(1)))
        return status == "removed" if m.group(2) == "out" else status in ("loose", "removed")
    if subject in ws.hatches:
        return ws.hatches[subject].status(ws.hatch_states[subject]) == state
    if subject in ws.bags and state in ("full", "rigged", "inflating"):
        s = ws.bag_states[subject]
        return {"full": s.full, "rigged": s.attached_to is not None,
                "inflating": s.inflating}[state]
    thing = ws.thing(subject)
    if state == "held":
        return thing.where == "held"
    if state.startswith("held_by:"):
        return ws.held_by(state[8:]) == subject
    if state == "lifted":
        return thing.where in ("water", "surface") and subject in ws.loads
    return thing.where == state  # floor, water, surface, in:<basket>, on:<platform>


def condition_error(ws: Workspace, subject: str, state: str) -> str | None:
    """Why ``subject state`` is not a condition (None: it is)."""
    if subject not in ws.names():
        return f"no object or site {subject!r} (have {', '.join(sorted(ws.names()))})"
    if subject in ws.flanges:
        m = _BOLT.match(state)
        if state in ("cover_off", "all_bolts_out"):
            return None
        if m and int(m.group(1)) < ws.flanges[subject].n_bolts:
            return None
        return (f"{subject} (a flange) has states cover_off, all_bolts_out, bolt<i>_loose, "
                f"bolt<i>_out with i < {ws.flanges[subject].n_bolts}, not {state!r}")
    if subject in ws.hatches:
        states = ("latched", "closed", "opening", "open", "closing")
        return None if state in states else (
            f"{subject} (a hatch) has states {', '.join(states)}, not {state!r}")
    if subject in ws.platforms:
        return f"{subject} is a platform: it has no states"
    ok = state in ("held", "floor", "water", "surface") or state.startswith(
        ("held_by:", "in:", "on:"))
    ok |= subject in ws.bags and state in ("full", "rigged", "inflating")
    ok |= subject in ws.loads and state == "lifted"
    return None if ok else f"{subject} has no state {state!r}"


# ---------------------------------------------------------------------------- walking

#: Grid step (m) of the walkability check.
WALK_GRID_M = 0.5
#: A walking diver reaches work up to this height above the floor (m): shoulder height
#: (0.818 of 1.75 m) plus the arm (0.66 m), less a margin.
WALKING_REACH_HEIGHT_M = 2.0


def walkable_region(floor_depth: Callable, extent: tuple[float, float, float, float],
                    start: tuple[float, float], max_slope: float,
                    step: float = WALK_GRID_M) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which points of a ``step`` grid over ``extent`` (north_min, north_max, east_min,
    east_max) a walking diver reaches from ``start``: breadth-first over neighbours
    whose depth differs by at most ``max_slope`` × distance (and that have a floor).
    Returns (north, east, reached (n, m) bool)."""
    north = np.arange(extent[0], extent[1] + 1e-9, step)
    east = np.arange(extent[2], extent[3] + 1e-9, step)
    nn, ee = np.meshgrid(north, east, indexing="ij")
    depth = np.asarray(floor_depth(nn, ee), dtype=float)
    reached = np.zeros(depth.shape, bool)
    i0 = int(np.clip(round((start[0] - north[0]) / step), 0, len(north) - 1))
    j0 = int(np.clip(round((start[1] - east[0]) / step), 0, len(east) - 1))
    if not np.isfinite(depth[i0, j0]):
        return north, east, reached
    reached[i0, j0] = True
    queue = deque([(i0, j0)])
    while queue:
        i, j = queue.popleft()
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
            a, b = i + di, j + dj
            if not (0 <= a < len(north) and 0 <= b < len(east)) or reached[a, b]:
                continue
            rise = abs(depth[a, b] - depth[i, j])
            if np.isfinite(depth[a, b]) and rise <= max_slope * step * math.hypot(di, dj):
                reached[a, b] = True
                queue.append((a, b))
    return north, east, reached


def target_point(ws: Workspace, target: str) -> np.ndarray | None:
    """Where an order's object or site is (NED), None if unknown."""
    if target in ws.things:
        return ws.grasp_point(target)
    if target in ws.flanges:
        return np.asarray(ws.flanges[target].position_ned, dtype=float)
    if target in ws.hatches:
        return ws.hatches[target].latch_position()
    if target in ws.platforms:
        return np.asarray(ws.platforms[target].top_centre_ned, dtype=float)
    return None


# ---------------------------------------------------------------------------- validation


@dataclass(frozen=True)
class DiverSetup:
    """What the validator needs to know of the diver the orders are for: its name, whether
    it walks on weighted boots (else it swims), where it starts, the steepest floor it
    walks up."""

    name: str
    walks: bool
    start_ne: tuple[float, float]
    max_slope: float = 0.3


def _names(group: Iterable[str]) -> str:
    return ", ".join(sorted(group)) or "none"


def validate_orders(orders: Sequence[Order], diver: DiverSetup, ws: Workspace,
                    floor_depth: Callable, extent: tuple[float, float, float, float],
                    carriers: Iterable[str] = ()) -> list[str]:
    """Every reason the orders cannot be executed, one line each (empty: they can)."""
    # here: the scenario schema builds orders without the workspace's meshes (trimesh)
    from uhrisim.teamwork.acts import TOOL_FOR, site_kind

    errors: list[str] = []
    known_carriers = set(carriers) | {f"{diver.name}/{s}_hand" for s in SIDES}
    north, east, reached = (walkable_region(floor_depth, extent, diver.start_ne,
                                            diver.max_slope)
                            if diver.walks else (None, None, None))
    holding: dict[str, str] = {}  # object -> hand, as the orders go
    work: dict[tuple[str, int], float] = {}  # seconds of wrench work per bolt so far
    out: set[tuple[str, int]] = set()
    for k, order in enumerate(orders, start=1):
        where = f"order {k} ({describe(order)})"

        def fail(message: str, where: str = where) -> None:
            errors.append(f"{where}: {message}")

        for name in _referenced(order):
            if name not in ws.names():
                fail(f"no object or site {name!r} (have {_names(ws.names())})")
        if any(n not in ws.names() for n in _referenced(order)):
            continue
        match order:
            case SetMode(mode="swim") if diver.walks:
                fail("a diver on weighted boots walks; swimming needs model: diver")
            case PickUp(obj=obj, hand=hand):
                if obj not in ws.tools:
                    fail(f"{obj} is not something a hand carries (tools: {_names(ws.tools)})")
                elif hand not in SIDES:
                    fail(f"hand must be left or right, not {hand!r}")
                else:
                    holding[obj] = hand
            case UseOn(tool=tool, site=site, part=part, seconds=seconds):
                kind = site_kind(ws, site)
                if kind is None:
                    fail(f"{site} is not a work site (flanges, hatches, loads)")
                elif tool not in ws.tools or ws.tools[tool].kind != TOOL_FOR[kind]:
                    fail(f"a {kind} needs a {TOOL_FOR[kind]}; {tool} is "
                         f"{'a ' + ws.tools[tool].kind if tool in ws.tools else 'no tool'}")
                elif kind == "flange" and not 0 <= part < ws.flanges[site].n_bolts:
                    fail(f"{site} has bolts 0 to {ws.flanges[site].n_bolts - 1}, not {part}")
                elif not seconds > 0:
                    fail(f"seconds must be > 0, got {seconds}")
                elif tool not in holding and not _tool_free(ws, tool):
                    fail(f"{tool} is not held and not lying free to fetch")
                else:
                    if kind == "flange":
                        work[site, part] = work.get((site, part), 0.0) + seconds
                    if kind == "load":
                        holding.pop(tool, None)  # the bag stays rigged to the load
            case Remove(site=site, part=part):
                if site not in ws.flanges:
                    fail(f"{site} is not a flange")
                elif part == "cover":
                    missing = [b for b in range(ws.flanges[site].n_bolts) if (site, b) not in out]
                    if missing:
                        fail(f"the cover comes off only with every bolt out; no order before "
                             f"takes out bolt(s) {', '.join(map(str, missing))}")
                elif not (isinstance(part, int) and 0 <= part < ws.flanges[site].n_bolts):
                    fail(f"{site} has bolts 0 to {ws.flanges[site].n_bolts - 1}, not {part!r}")
                elif work.get((site, part), 0.0) < ws.flanges[site].loosen_time_s:
                    fail(f"bolt {part} is tight: the orders before give it "
                         f"{work.get((site, part), 0.0):g} s of wrench work, it needs "
                         f"{ws.flanges[site].loosen_time_s:g} s")
                else:
                    out.add((site, part))
            case Operate(site=site, action=action):
                if action in ("open", "close") and site not in ws.hatches:
                    fail(f"{site} is not a hatch")
                elif action in ("inflate", "stop") and site not in ws.bags:
                    fail(f"{site} is not a lift bag")
                elif action not in ("open", "close", "inflate", "stop"):
                    fail(f"action must be open, close, inflate or stop, not {action!r}")
            case PutDown(obj=obj, on=on):
                if obj not in holding:
                    fail(f"{obj} is not held: no order before picks it up")
                elif on not in ws.platforms and not (on in ws.tools and
                                                     ws.tools[on].kind == "tool_basket"):
                    fail(f"{on} is neither a platform nor a tool basket")
                else:
                    holding.pop(obj)
            case HandTo(obj=obj, receiver=receiver):
                if receiver not in known_carriers:
                    fail(f"no carrier {receiver!r} (have {_names(known_carriers)})")
                elif obj not in holding:
                    fail(f"{obj} is not held: no order before picks it up")
                else:
                    holding.pop(obj)
            case WaitUntil(subject=subject, state=state):
                reason = condition_error(ws, subject, state)
                if reason:
                    fail(reason)
                elif state.startswith(f"held_by:{diver.name}/") and state.endswith("_hand"):
                    holding[subject] = state.split("/")[-1].removesuffix("_hand")  # given him
            case Signal(name=name, channel=None) if name not in SIGNALS:
                fail(f"unknown signal {name!r} (have {', '.join(SIGNALS)})")
        if reached is not None and not isinstance(order, (WaitUntil, Signal, SetMode)):
            for name in _referenced(order):
                reason = _walk_reason(ws, name, floor_depth, north, east, reached)
                if reason:
                    fail(reason)
    return errors


def _tool_free(ws: Workspace, tool: str) -> bool:
    thing = ws.things.get(tool)
    return thing is not None and thing.where != "held"


def _referenced(order: Order) -> list[str]:
    """Names of objects and sites an order refers to (not carriers, not points)."""
    match order:
        case GoTo(target=str(target)):
            return [target]
        case PickUp(obj=obj) | HandTo(obj=obj):
            return [obj]
        case UseOn(tool=tool, site=site):
            return [tool, site]
        case Remove(site=site) | Operate(site=site):
            return [site]
        case PutDown(obj=obj, on=on):
            return [obj, on]
        case WaitUntil(subject=subject):
            return [subject]
    return []


def worked_at(order: Order | None, diver: str) -> tuple[str, ...]:
    """The objects and sites ``order`` names that ``diver``'s hands work at (what his
    collision sphere leaves out while it runs, docs/teamwork.md): every name of the
    order but the subject of a wait — unless he waits to take it in his own hand."""
    match order:
        case WaitUntil(subject=subject, state=state) if state.startswith(f"held_by:{diver}/"):
            return (subject,)
        case WaitUntil() | None:
            return ()
    return tuple(_referenced(order))


def _walk_reason(ws: Workspace, name: str, floor_depth: Callable, north: np.ndarray,
                 east: np.ndarray, reached: np.ndarray) -> str | None:
    """Why a walking diver cannot get to ``name`` (None: it can)."""
    point = target_point(ws, name)
    if point is None:
        return None
    # grid points within 1 m of it, on the same ground (no step between them and it)
    under = float(floor_depth(point[0], point[1]))
    nn, ee = np.meshgrid(north, east, indexing="ij")
    near = ((np.abs(nn - point[0]) <= 1.0) & (np.abs(ee - point[1]) <= 1.0)
            & (np.abs(np.asarray(floor_depth(nn, ee), dtype=float) - under)
               <= 0.3 * np.hypot(nn - point[0], ee - point[1]) + 0.05))
    if not (near & reached).any():
        return (f"no walking path reaches {name} at ({point[0]:.1f}, {point[1]:.1f}): "
                "the floor between is too steep or missing")
    height = float(floor_depth(point[0], point[1])) - point[2]
    if height > WALKING_REACH_HEIGHT_M:
        return (f"{name} is {height:.1f} m above the floor: a walking diver reaches "
                f"{WALKING_REACH_HEIGHT_M:.1f} m")
    return None
