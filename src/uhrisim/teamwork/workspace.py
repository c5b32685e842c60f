"""The changing world of a team: where every object is, who holds it, each site's state.

A :class:`Workspace` is the mutable state the simulation owns for teamwork (habit 3:
nothing else changes it): the objects (tools and loads) with their poses (4x4 body→NED)
and where they are — ``"floor"``, ``"water"`` (falling or rising), ``"surface"``,
``"held"``, ``"on:<platform>"`` (on a fixed structure's top, :class:`Platform`),
``"in:<basket>"`` (lying in a tool basket, moving with it) or ``"rigged:<load>"`` (a
lift bag made fast to a load) — who holds what (carrier name →
object; an object may have two holders at a handover), and the state of every work site.

:meth:`Workspace.carry` moves held objects with their carriers' grip frames;
:meth:`Workspace.step` advances the physics (free objects fall or rise, lift bags
inflate, loads lift, hatches swing, basket contents follow) and returns the events.
The acts (:mod:`uhrisim.teamwork.acts`) change holders and site states.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
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

#: A released object rests when a support is within this below it (m).
SUPPORT_TOLERANCE_M = 0.05

#: the velocity (NED m/s) of what is carried by a grip at rest
_AT_REST = (0.0, 0.0, 0.0)
#: the bytes of a velocity array at rest (three +0.0)
_NO_VELOCITY = np.zeros(3).tobytes()


@dataclass(frozen=True)
class Platform:
    """A level top surface of a fixed structure (a work stand, a structure's deck) that
    objects can be put on: centre of its top (NED m), size (m, along and across its
    heading), heading (rad)."""

    name: str
    top_centre_ned: tuple[float, float, float]
    size: tuple[float, float]
    yaw: float = 0.0

    def covers(self, point_ned: ArrayLike) -> bool:
        """Whether ``point_ned`` lies over (or under) the top surface."""
        north = float(point_ned[0]) - self.top_centre_ned[0]  # type: ignore[index]
        east = float(point_ned[1]) - self.top_centre_ned[1]  # type: ignore[index]
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        along, across = c * north + s * east, -s * north + c * east
        return abs(along) <= 0.5 * self.size[0] and abs(across) <= 0.5 * self.size[1]


def pose_matrix(position_ned: ArrayLike, yaw: float = 0.0) -> NDArray[np.float64]:
    """4x4 body→NED of a level object at ``position_ned`` heading ``yaw`` (rad)."""
    n, e, d = (float(v) for v in position_ned)  # type: ignore[union-attr]
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, n], [s, c, 0.0, e], [0.0, 0.0, 1.0, d],
                     [0.0, 0.0, 0.0, 1.0]])


@dataclass
class Thing:
    """An object's state: pose (4x4 body→NED), velocity (NED m/s), where it is, and
    its pose relative to what carries it (a basket, a grip). A move replaces the pose
    array, never changes it in place (the team stage keeps the last one it saw)."""

    pose: NDArray[np.float64]
    where: str = "floor"
    velocity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    relative: NDArray[np.float64] | None = None
    #: what its pose last followed from, in a basket or rigged to a load: (the
    #: support's pose, its relative pose, the pose worked out), or carried at rest:
    #: (the grip frame, its relative pose, the pose, the velocity): the very same
    #: objects give the same pose, kept (the team stage then needs to compare nothing)
    followed: tuple[Any, ...] = field(default=(), repr=False, compare=False)

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
    platforms: dict[str, Platform] = field(default_factory=dict)
    things: dict[str, Thing] = field(default_factory=dict)
    flange_states: dict[str, FlangeState] = field(default_factory=dict)
    hatch_states: dict[str, HatchState] = field(default_factory=dict)
    bag_states: dict[str, LiftBagState] = field(default_factory=dict)
    holders: dict[str, str] = field(default_factory=dict)
    #: each object's last :meth:`support_below`: (the floor function, its pose and the
    #: baskets' poses then, the answer): the very same objects give the same answer
    _supports: dict[str, tuple[Any, ...]] = field(default_factory=dict, repr=False,
                                                   compare=False)
    #: whether each object alone is lighter than water (:meth:`_floats`)
    _floating: dict[str, bool] = field(default_factory=dict, repr=False, compare=False)
    #: each object's last :meth:`grasp_point`: (its pose array then, the point)
    _grasp_points: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = field(
        default_factory=dict, repr=False, compare=False)

    @classmethod
    def of(cls, tools: Iterable[Tool] = (), loads: Iterable[LoadSpec] = (),
           flanges: Iterable[FlangeSpec] = (), hatches: Iterable[HatchSpec] = (),
           bags: Iterable[LiftBagSpec] = (), platforms: Iterable[Platform] = ()
           ) -> Workspace:
        """A workspace with these objects and sites (names must be unique); lift bags
        need a tool of kind ``lift_bag`` of the same name."""
        ws = cls()
        for group, items in (("tools", tools), ("loads", loads), ("flanges", flanges),
                             ("hatches", hatches), ("bags", bags), ("platforms", platforms)):
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
        return (set(self.tools) | set(self.loads) | set(self.flanges) | set(self.hatches)
                | set(self.bags) | set(self.platforms))

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
        pose = self.thing(obj).pose
        last = self._grasp_points.get(obj)  # (kept for the very pose array)
        if last is None or last[0] is not pose:
            local = (self.tools[obj].grasp_offset() if obj in self.tools
                     else self.loads[obj].attachment_site())
            last = self._grasp_points[obj] = (pose, pose[:3, :3] @ local + pose[:3, 3])
        return last[1].copy()

    def grip_width(self, obj: str) -> float:
        """What a hand or jaw closes on (m)."""
        return self.tools[obj].grasp_width if obj in self.tools else 0.02

    # ------------------------------------------------------------------ placing
    def put(self, obj: str, position_ned: ArrayLike, yaw: float = 0.0,
            where: str = "floor", pitch: float = 0.0) -> None:
        """Place ``obj`` (its reference point at ``position_ned``, heading ``yaw``, its
        long axis pitched ``pitch`` rad: -pi/2 stands a tool on its working end) at rest;
        ``where``: ``"floor"``, ``"on:<platform>"``, ``"in:<basket>"`` (it then moves
        with the basket) or ``"water"`` (free)."""
        if obj not in self.tools and obj not in self.loads:
            raise ConfigError(f"no object {obj!r} to put", where="Workspace.put")
        pose = pose_matrix(position_ned, yaw)
        c, s = math.cos(pitch), math.sin(pitch)
        pose[:3, :3] = pose[:3, :3] @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        thing = Thing(pose, where)
        if where.startswith("in:"):
            basket = self.thing(where[3:])
            thing.relative = np.linalg.inv(basket.pose) @ thing.pose
        self.things[obj] = thing

    def support_below(self, obj: str, floor_depth: FloorDepth) -> tuple[str, float]:
        """The nearest support under ``obj`` and the gap (m) from its bottom down to it:
        the floor (``"floor"``), a platform's top (``"on:<name>"``) or the inside bottom of
        a level tool basket whose opening it is over (``"in:<name>"``). Kept while the
        object and every basket keep their pose arrays (poses are replaced, never
        changed in place)."""
        baskets = tuple(thing.pose for name, thing in self.things.items()
                        if name != obj and name in self.tools
                        and self.tools[name].kind == "tool_basket")
        pose = self.things[obj].pose
        last = self._supports.get(obj)
        if (last is not None and last[0] is floor_depth and last[1] is pose
                and len(last[2]) == len(baskets)
                and all(a is b for a, b in zip(last[2], baskets, strict=True))):
            return last[3]
        best = self._support_below(obj, floor_depth)
        self._supports[obj] = (floor_depth, pose, baskets, best)
        return best

    def _support_below(self, obj: str, floor_depth: FloorDepth) -> tuple[str, float]:
        x, y, z = self.things[obj].position
        bottom = z + self.hydro_of(obj).bottom_offset
        best = ("floor", float(floor_depth(x, y)) - bottom)
        for name, platform in self.platforms.items():
            gap = platform.top_centre_ned[2] - bottom
            if platform.covers((x, y)) and -0.01 <= gap < best[1]:
                best = (f"on:{name}", gap)
        for name, basket in self.things.items():
            if name == obj or name not in self.tools or self.tools[name].kind != "tool_basket":
                continue
            length, width, height = self.tools[name].size
            local = basket.pose[:3, :3].T @ (np.array([x, y, bottom]) - basket.position)
            inside = abs(local[0]) < 0.5 * length and abs(local[1]) < 0.5 * width
            gap = 0.5 * height - 0.01 - local[2]  # down to the basket's inside bottom
            if inside and -0.01 <= gap < best[1]:
                best = (f"in:{name}", gap)
        return best

    def rest_on(self, obj: str, support: str, gap: float) -> None:
        """Lower ``obj`` by ``gap`` onto ``support`` (from :meth:`support_below`), level."""
        thing = self.things[obj]
        position = thing.position + np.array([0.0, 0.0, gap])
        yaw = math.atan2(thing.pose[1, 0], thing.pose[0, 0])
        self.put(obj, position, yaw, where=support)

    def carry(self, carrier: str, grip_frame: NDArray[np.float64],
              velocity: ArrayLike = _AT_REST) -> None:
        """Move what ``carrier`` holds with its 4x4 grip frame (NED). A shared object
        follows its first holder. Kept when the object, at rest in the grip, follows
        the very grip frame array it followed last (grip frames are not changed in
        place)."""
        obj = self.held_by(carrier)
        if obj is None or self.holders_of(obj)[0] != carrier:
            return
        thing = self.things[obj]
        last = thing.followed  # the very grip frame it followed last, at rest: kept
        if (velocity is _AT_REST and len(last) == 4 and last[0] is grip_frame
                and last[1] is thing.relative and last[2] is thing.pose
                and last[3] is thing.velocity):
            return
        thing.pose = grip_frame @ thing.relative
        thing.velocity = np.asarray(velocity, dtype=float)
        thing.followed = (grip_frame, thing.relative, thing.pose, thing.velocity) if (
            velocity is _AT_REST) else ()

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
        gassed = [b for b, s in self.bag_states.items() if s.gas_surface_litres > 0.0]
        for name, thing in self.things.items():
            if self._may_move(name, thing, gassed):
                events += self._move_free(name, thing, dt, t, floor_depth)
        for thing in self.things.values():  # contents and rigging follow
            if thing.where.startswith("in:"):
                self._follow(thing, self.things[thing.where[3:]].pose, thing.relative, None)
            elif thing.where.startswith("rigged:"):
                load = thing.where[7:]
                self._follow(thing, self.things[load].pose, None, load)
        return events

    def _follow(self, thing: Thing, support: NDArray[np.float64],
                relative: NDArray[np.float64] | None, load: str | None) -> None:
        """Put ``thing`` where its support's pose puts it: at its ``relative`` pose (in a
        basket), or level at the lifting eye of ``load`` (a bag rigged to it); kept when
        its support's and relative pose and its own are those it last followed."""
        last = thing.followed
        if last and last[0] is support and last[1] is relative and last[2] is thing.pose:
            return
        if load is None:
            thing.pose = support @ relative
        else:
            eye = self.loads[load].attachment_site()
            thing.pose = pose_matrix(support[:3, :3] @ eye + support[:3, 3],
                                     math.atan2(support[1, 0], support[0, 0]))
        thing.followed = (support, relative, thing.pose)

    def _may_move(self, name: str, thing: Thing, gassed: list[str]) -> bool:
        """Whether the physics must step ``name``: free in the water or at the surface, or
        resting (on the floor or a platform) and lighter than water — a bag with gas in it
        (``gassed``: those bags) or a load with such a bag rigged may be (what rests heavier
        than water stays)."""
        if thing.where in ("water", "surface"):
            return True
        if thing.where != "floor" and not thing.where.startswith("on:"):
            return False  # held, in a basket, rigged: moved by what it is with
        if name in self.tools and name not in self.bags:
            return self._floats(name)
        return (name in gassed or any(self.bag_states[b].attached_to == name for b in gassed)
                or self._floats(name))

    def _floats(self, name: str) -> bool:
        """Whether object ``name`` alone is lighter than water (asked once per object)."""
        if name not in self._floating:
            self._floating[name] = self.hydro_of(name).in_water_weight() < 0.0
        return self._floating[name]

    @staticmethod
    def _stays(thing: Thing, depth: float, resting_depth: float, weight: float) -> bool:
        """Whether a resting ``thing`` (its reference point at ``depth``, m) of in-water
        weight ``weight`` (N) stays as it is, bit for bit: it rests
        (:func:`~uhrisim.dynamics.free_body.rests`) where it is, with no velocity."""
        return (fb.rests(depth, weight, resting_depth)
                and struct.pack("<d", depth) == struct.pack("<d", resting_depth)
                and thing.velocity.tobytes() == _NO_VELOCITY)

    def _bag_gas(self, load: str, depth: float) -> tuple[float, list[str]]:
        """Gas (m³) of the bags rigged to ``load`` at ``depth``, and their names."""
        rigged = [b for b, s in self.bag_states.items() if s.attached_to == load]
        return sum(self.bags[b].gas_m3(self.bag_states[b], depth) for b in rigged), rigged

    def _move_free(self, name: str, thing: Thing, dt: float, t: float,
                   floor_depth: FloorDepth) -> list[WorldEvent]:
        depth = float(thing.pose[2, 3])
        hydro = self.hydro_of(name)
        gas, rigged = 0.0, []
        if name in self.loads:
            gas, rigged = self._bag_gas(name, depth)
        elif name in self.bags:
            gas = self.bags[name].gas_m3(self.bag_states[name], depth)
        support, gap = self.support_below(name, floor_depth)
        resting_on = depth + hydro.bottom_offset + gap  # depth of what is below
        if thing.where == support and self._stays(thing, depth, resting_on - hydro.bottom_offset,
                                                  fb.combined_weight(hydro, *(
                                                      self.bags[b].fabric for b in rigged),
                                                      gas_volume=gas)):
            return []  # resting as it is: what the step would give, its arrays kept
        if rigged:  # load and bags rise as one; the swollen bags drag with C_d 1
            bag_area = math.pi * bag_semi_axes(gas)[0] ** 2
            area = hydro.area + bag_area
            hydro = fb.combine(hydro, *(self.bags[b].fabric for b in rigged),
                               drag_coefficient=(hydro.drag_coefficient * hydro.area
                                                 + bag_area) / area,
                               area=area, bottom_offset=hydro.bottom_offset)
        x = np.concatenate([thing.position, thing.velocity])
        before = thing.where
        stepped, where = fb.step(x, hydro, dt, resting_on, gas)
        if where == "floor" and support != "floor" and before == support:
            where = support  # still resting there (pinned by the step)
        if where == before and stepped.tobytes() == x.tobytes():
            return []  # it stays as it is: its pose and velocity arrays are kept
        x = stepped
        pose = thing.pose.copy()  # a new pose, never changed in place: the stage compares
        pose[:3, 3] = x[:3]        # pose objects to see what moved (sim/teamwork.py)
        thing.pose, thing.velocity, thing.where = pose, x[3:], where
        if where == "floor" and support != "floor":
            self.rest_on(name, support, 0.0)  # in a basket or on a platform
            where = support
        if where == before:
            return []
        landed = where == "floor" or where.startswith(("in:", "on:"))
        rested = before == "floor" or before.startswith("on:")
        kind = ("landed" if before == "water" and landed
                else "lifted_off" if rested and where == "water"
                else {("water", "surface"): "surfaced",
                      ("surface", "water"): "sank"}.get((before, where), f"now_{where}"))
        return [WorldEvent(t, kind, name, detail={"depth": float(x[2]), "on": where})]
