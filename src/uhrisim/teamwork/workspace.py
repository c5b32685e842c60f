"""The changing world of a team: where every object is, who holds it, each site's state.

A :class:`Workspace` is the mutable state the simulation owns for teamwork (habit 3:
nothing else changes it): the objects (tools and loads) with their poses (4x4 body→NED)
and where they are — ``"floor"``, ``"water"`` (falling or rising), ``"surface"``,
``"held"``, ``"in:<basket>"`` (lying in a tool basket, moving with it) or
``"rigged:<load>"`` (a lift bag made fast to a load) — who holds what (carrier name →
object; an object may have two holders at a handover), and the state of every work site.

:meth:`Workspace.carry` moves held objects with their carriers' grip frames;
:meth:`Workspace.step` advances the physics (free objects fall or rise, lift bags
inflate, loads lift, hatches swing, basket contents follow) and returns the events.
The acts (:mod:`uhrisim.teamwork.acts`) change holders and site states.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.dynamics import free_body as fb
from uhrisim.world.events import WorldEvent
from uhrisim.world.tools import Tool
from uhrisim.world.worksites import (
    FlangeSpec,
    FlangeState,
    HatchSpec,
    HatchState,
    LiftBagSpec,
    LiftBagState,
    LoadSpec,
    bag_semi_axes,
)

FloorDepth = Callable[[float, float], float]


def pose_matrix(position_ned: ArrayLike, yaw: float = 0.0) -> NDArray[np.float64]:
    """4x4 body→NED of a level object at ``position_ned`` heading ``yaw`` (rad)."""
    m = np.eye(4)
    m[:3, :3] = rot_z(yaw)
    m[:3, 3] = np.asarray(position_ned, dtype=float)
    return m


@dataclass
class Thing:
    """An object's state: pose (4x4 body→NED), velocity (NED m/s), where it is, and
    its pose relative to what carries it (a basket, a grip)."""

    pose: NDArray[np.float64]
    where: str = "floor"
    velocity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    relative: NDArray[np.float64] | None = None

    @property
    def position(self) -> NDArray[np.float64]:
        return self.pose[:3, 3]


@dataclass
class Workspace:
    """Objects, holders and site states (module docstring). Build it, then
    :meth:`put` every object where it starts."""

    tools: dict[str, Tool] = field(default_factory=dict)
    loads: dict[str, LoadSpec] = field(default_factory=dict)
    flanges: dict[str, FlangeSpec] = field(default_factory=dict)
    hatches: dict[str, HatchSpec] = field(default_factory=dict)
    bags: dict[str, LiftBagSpec] = field(default_factory=dict)
    things: dict[str, Thing] = field(default_factory=dict)
    flange_states: dict[str, FlangeState] = field(default_factory=dict)
    hatch_states: dict[str, HatchState] = field(default_factory=dict)
    bag_states: dict[str, LiftBagState] = field(default_factory=dict)
    holders: dict[str, str] = field(default_factory=dict)

    @classmethod
    def of(cls, tools: Iterable[Tool] = (), loads: Iterable[LoadSpec] = (),
           flanges: Iterable[FlangeSpec] = (), hatches: Iterable[HatchSpec] = (),
           bags: Iterable[LiftBagSpec] = ()) -> Workspace:
        """A workspace with these objects and sites (names must be unique); lift bags
        need a tool of kind ``lift_bag`` of the same name."""
        ws = cls()
        for group, items in (("tools", tools), ("loads", loads), ("flanges", flanges),
                             ("hatches", hatches), ("bags", bags)):
            for item in items:
                taken = item.name in ws.names() and not (group == "bags" and
                                                          item.name in ws.tools)
                if taken:
                    raise ConfigError(f"name {item.name!r} is used twice", where="Workspace")
                getattr(ws, group)[item.name] = item
        for bag in ws.bags:
            if bag not in ws.tools or ws.tools[bag].kind != "lift_bag":
                raise ConfigError(f"lift bag {bag!r} needs a lift_bag tool of that name",
                                  where="Workspace")
        ws.flange_states = {n: s.initial_state() for n, s in ws.flanges.items()}
        ws.hatch_states = {n: s.initial_state() for n, s in ws.hatches.items()}
        ws.bag_states = {n: s.initial_state() for n, s in ws.bags.items()}
        return ws

    # ------------------------------------------------------------------ lookups
    def names(self) -> set[str]:
        """Every object and site name."""
        return set(self.tools) | set(self.loads) | set(self.flanges) | set(self.hatches) | set(
            self.bags)

    def thing(self, name: str) -> Thing:
        """The state of object ``name``; ConfigError naming the objects otherwise."""
        try:
            return self.things[name]
        except KeyError:
            have = ", ".join(sorted(self.things)) or "none"
            raise ConfigError(f"no object {name!r} (have {have})", where="Workspace") from None

    def held_by(self, carrier: str) -> str | None:
        """The object ``carrier`` holds, or None."""
        return self.holders.get(carrier)

    def holders_of(self, obj: str) -> tuple[str, ...]:
        """Who holds ``obj`` (two at a handover), in the order they took it."""
        return tuple(c for c, o in self.holders.items() if o == obj)

    def hydro_of(self, obj: str) -> fb.Hydro:
        return self.tools[obj].hydro if obj in self.tools else self.loads[obj].hydro

    def grasp_point(self, obj: str) -> NDArray[np.float64]:
        """Where a hand or jaw takes ``obj``, NED (m): a tool's grasp point, a load's
        lifting eye."""
        t = self.thing(obj)
        local = (self.tools[obj].grasp_offset() if obj in self.tools
                 else self.loads[obj].attachment_site())
        return t.pose[:3, :3] @ local + t.pose[:3, 3]

    def grip_width(self, obj: str) -> float:
        """What a hand or jaw closes on (m)."""
        return self.tools[obj].grasp_width if obj in self.tools else 0.02

    # ------------------------------------------------------------------ placing
    def put(self, obj: str, position_ned: ArrayLike, yaw: float = 0.0,
            where: str = "floor") -> None:
        """Place ``obj`` (its reference point at ``position_ned``) at rest; ``where`` may
        be ``"in:<basket>"`` to put it in a basket (it then moves with the basket)."""
        if obj not in self.tools and obj not in self.loads:
            raise ConfigError(f"no object {obj!r} to put", where="Workspace.put")
        thing = Thing(pose_matrix(position_ned, yaw), where)
        if where.startswith("in:"):
            basket = self.thing(where[3:])
            thing.relative = np.linalg.inv(basket.pose) @ thing.pose
        self.things[obj] = thing

    def carry(self, carrier: str, grip_frame: NDArray[np.float64],
              velocity: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        """Move what ``carrier`` holds with its 4x4 grip frame (NED). A shared object
        follows its first holder."""
        obj = self.held_by(carrier)
        if obj is None or self.holders_of(obj)[0] != carrier:
            return
        thing = self.things[obj]
        thing.pose = grip_frame @ thing.relative
        thing.velocity = np.asarray(velocity, dtype=float)

    def take(self, carrier: str, obj: str, grip_frame: NDArray[np.float64]) -> None:
        """Record that ``carrier`` holds ``obj`` with its grip frame now (NED)."""
        thing = self.thing(obj)
        if not self.holders_of(obj):
            thing.relative = np.linalg.inv(grip_frame) @ thing.pose
            thing.where = "held"
            thing.velocity = np.zeros(3)
        self.holders[carrier] = obj

    def let_go(self, carrier: str) -> str | None:
        """``carrier`` lets go; returns the object if nobody holds it any more (it is then
        free in the water: :meth:`step` decides whether it rests or moves)."""
        obj = self.holders.pop(carrier, None)
        if obj is None:
            return None
        remaining = self.holders_of(obj)
        if remaining:
            first = remaining[0]
            del self.holders[first]  # re-take by the new first holder keeps the pose
            self.holders[first] = obj
            return None
        thing = self.things[obj]
        thing.where, thing.relative = "water", None
        return obj

    # ------------------------------------------------------------------ physics
    def step(self, t: float, dt: float, floor_depth: FloorDepth) -> list[WorldEvent]:
        """Advance the free objects, lift bags, loads, hatches and basket contents by
        ``dt`` s (module docstring); return their events."""
        events: list[WorldEvent] = []
        for name, spec in self.hatches.items():
            self.hatch_states[name], ev = spec.advance(self.hatch_states[name], dt, t)
            events += ev
        for name, spec in self.bags.items():
            state = self.bag_states[name]
            depth = float(self.thing(name).position[2])
            self.bag_states[name], ev = spec.advance(state, dt, t, depth)
            events += ev
        for name, thing in self.things.items():
            if thing.where not in ("water", "floor", "surface"):
                continue
            events += self._move_free(name, thing, dt, t, floor_depth)
        for thing in self.things.values():  # contents and rigging follow
            if thing.where.startswith("in:"):
                thing.pose = self.things[thing.where[3:]].pose @ thing.relative
            elif thing.where.startswith("rigged:"):
                load = self.things[thing.where[7:]]
                eye = self.loads[thing.where[7:]].attachment_site()
                thing.pose = pose_matrix(load.pose[:3, :3] @ eye + load.pose[:3, 3],
                                         math.atan2(load.pose[1, 0], load.pose[0, 0]))
        return events

    def _bag_gas(self, load: str, depth: float) -> tuple[float, list[str]]:
        """Gas (m³) of the bags rigged to ``load`` at ``depth``, and their names."""
        rigged = [b for b, s in self.bag_states.items() if s.attached_to == load]
        return sum(self.bags[b].gas_m3(self.bag_states[b], depth) for b in rigged), rigged

    def _move_free(self, name: str, thing: Thing, dt: float, t: float,
                   floor_depth: FloorDepth) -> list[WorldEvent]:
        x = np.concatenate([thing.position, thing.velocity])
        hydro = self.hydro_of(name)
        gas = 0.0
        if name in self.loads:
            gas, rigged = self._bag_gas(name, float(x[2]))
            if rigged:  # load and bags rise as one; the swollen bags drag with C_d 1
                bag_area = math.pi * bag_semi_axes(gas)[0] ** 2
                area = hydro.area + bag_area
                hydro = fb.combine(hydro, *(self.bags[b].fabric for b in rigged),
                                   drag_coefficient=(hydro.drag_coefficient * hydro.area
                                                     + bag_area) / area,
                                   area=area, bottom_offset=hydro.bottom_offset)
        elif name in self.bags:
            gas = self.bags[name].gas_m3(self.bag_states[name], float(x[2]))
        floor = float(floor_depth(x[0], x[1]))
        x, where = fb.step(x, hydro, dt, floor, gas)
        before = thing.where
        thing.pose[:3, 3], thing.velocity, thing.where = x[:3], x[3:], where
        if where == before:
            return []
        kind = {("floor", "water"): "lifted_off", ("water", "floor"): "landed",
                ("water", "surface"): "surfaced", ("surface", "water"): "sank"}
        return [WorldEvent(t, kind.get((before, where), f"now_{where}"), name,
                           detail={"depth": float(x[2])})]
