"""The teamwork stage of the loop: divers carry out their orders, grippers grip, tools and
loads move, silt is stirred up (docs/teamwork.md).

:class:`TeamStage` owns the :class:`~uhrisim.teamwork.workspace.Workspace` (every tool,
site and load of ``world.tools`` / ``world.sites``), the articulated body of each diver
with ``orders`` or drawn as the figure (joint angles, its order executor), each
vehicle's gripper, and the
silt cloud of a soft floor. Built with the simulation (problems with the orders are
refused then, one line each with the order's file:line), it runs after the bodies
move and before the sensors, every ``1 / RATE_HZ`` s:

1. every diver with orders: its executor's directive becomes the plant's inputs
   (``VehicleModel.diver.directed_inputs``; held until the next stage tick); the upper
   body moves towards the directive's joint goal (``step_motion``), the legs as the body
   moves them (walking on the floor, or the flutter kick);
2. every gripper follows its agent's ``GRIPPER`` variable (``open``, ``close``,
   ``catch``: close once an object lies between the jaws; ``give``: open once someone
   else holds what it holds); jaws that close on an object grasp it;
3. the acts asked for are performed (:func:`uhrisim.teamwork.acts.perform`);
4. held objects follow their carriers' grip frames; the workspace steps (free objects
   fall or rise, bags inflate, loads lift);
5. footfalls on a soft floor release silt;
6. the events go back to the executors and into the simulation's events
   (``teamwork``: one line each; ``order``: a step that ended, :func:`order_detail`;
   ``team_state``: a bag's gas or a hatch lid's angle that moved, :func:`site_state_detail`).

The scene follows: tools, sites and loads are dynamic bodies posed from the workspace
(parts of sites by their state), the articulated divers by their joint angles.

Tools, sites and loads are obstacles to the agents' collision spheres (the loop's
collision check, :mod:`uhrisim.sim.simulation`), but for what an agent works with
(:meth:`TeamStage.left_out`): (a) what its own hands or gripper hold (a carried object
moves with its carrier; a hand-over's object is held by both), with what lies in it;
(b) the objects and the site its current order names, where its hands work
(:func:`uhrisim.teamwork.orders.worked_at`), or its task from outside (:attr:`tasks`:
the tool an assistant's ROV fetches); (c) what those rest on or are fixed to (the
basket a tool lies in, the stand under the basket, the load a bag is rigged to). Every
stage tick refreshes the bodies' bounding spheres (:mod:`uhrisim.sim.team_obstacles`)
of those that moved or changed shape (:attr:`TeamStage.moved`): the loop's pre-check.
Deterministic: nothing here draws random numbers.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from uhrisim.control.videoray_p import VideoRayPController
from uhrisim.core.clock import ticks_for_rate
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.dynamics.carried_load import CarriedLoad, box_projected_areas
from uhrisim.dynamics.diver_body import DiverSkeleton, step_motion
from uhrisim.dynamics.plants import LastValue
from uhrisim.scenario.load import ScenarioFile
from uhrisim.scenario.sections import part_settings
from uhrisim.scenario.teamwork import FlangeSite, HatchSite, LoadSite, PlatformSite
from uhrisim.sim.hooks import JointSample
from uhrisim.sim.state import Agent
from uhrisim.sim.team_obstacles import ObstacleSpheres, PartSpheres
from uhrisim.teamwork import acts
from uhrisim.teamwork import gripper as gr
from uhrisim.teamwork import orders as od
from uhrisim.teamwork.executor import DiverView, OrderExecutor, StepRecord
from uhrisim.teamwork.workspace import Platform, Workspace, pose_matrix
from uhrisim.world import worksites as sites
from uhrisim.world.diver_figure import figure_transforms
from uhrisim.world.events import WorldEvent
from uhrisim.world.materials import CONCRETE, STEEL
from uhrisim.world.scene import Scene
from uhrisim.world.silt import SiltCloud, SiltMedium, SiltParams
from uhrisim.world.tools import make_tool

#: How often the stage runs (Hz): the executors, the arms, the grippers, the objects.
RATE_HZ = 20.0

#: The walking paths the validator looks for lie this far around the diver and the
#: objects (m).
_MARGIN_M = 5.0

#: Where a tool with no depth given is first put, above what it rests on (m).
_DROP_HEIGHT_M = 3.0


#: A lift bag's gas is recorded when it has changed by this much (surface litres), a
#: hatch lid's angle when by this much (degrees), and when either stops changing.
STATE_STEP_LITRES = 1.0
STATE_STEP_DEG = 2.0

_SITE_STATE = re.compile(r"^(?P<site>\S+) (?P<what>gas|angle) (?P<value>[-\d.]+) "
                         r"(?P<unit>L|deg)$")


def site_state_detail(site: str, what: str, value: float) -> str:
    """The ``team_state`` event's text: ``"<bag> gas <surface litres> L"`` or
    ``"<hatch> angle <degrees> deg"`` (:func:`parse_site_state` reads it)."""
    unit = "L" if what == "gas" else "deg"
    return f"{site} {what} {value:.2f} {unit}"


def parse_site_state(detail: str) -> tuple[str, str, float] | None:
    """(site, ``"gas"`` or ``"angle"``, value) of a :func:`site_state_detail` text (None
    if it is not one)."""
    m = _SITE_STATE.match(detail)
    return None if m is None else (m["site"], m["what"], float(m["value"]))


def order_detail(diver: str, index: int, step: StepRecord) -> str:
    """The ``order`` event's text for a step that ended: ``"<diver> #<index> <outcome>
    <start>-<end> s: <order>[ (<reason>)]"`` (:func:`parse_order_detail` reads it)."""
    reason = f" ({step.reason})" if step.reason else ""
    fetched = " [fetch]" if step.fetched else ""
    return (f"{diver} #{index} {step.outcome} {step.started:.3f}-{step.ended:.3f} s: "
            f"{od.describe(step.order)}{fetched}{reason}")


_ORDER_DETAIL = re.compile(r"^(?P<diver>\S+) #(?P<index>\d+) (?P<outcome>\w+) "
                           r"(?P<start>[-\d.]+)-(?P<end>[-\d.]+) s: (?P<order>.*?)"
                           r"(?P<fetch> \[fetch\])?(?: \((?P<reason>.*)\))?$")


def parse_order_detail(detail: str) -> dict[str, Any] | None:
    """The fields of an :func:`order_detail` text (None if it is not one): diver, index,
    outcome, start and end (s), order, fetched, reason."""
    m = _ORDER_DETAIL.match(detail)
    if m is None:
        return None
    return {"diver": m["diver"], "index": int(m["index"]), "outcome": m["outcome"],
            "start": float(m["start"]), "end": float(m["end"]), "order": m["order"],
            "fetched": m["fetch"] is not None, "reason": m["reason"] or ""}


@dataclass
class DiverBodyState:
    """A diver's articulated body in the stage: joint angles and speeds (rad, rad/s), the
    goal the arms move to, its executor (None: no orders), the plant state at the last
    stage tick (for footfalls) and how many of its steps were reported."""

    skeleton: DiverSkeleton
    q: NDArray[np.float64]
    qdot: NDArray[np.float64]
    goal: NDArray[np.float64]
    executor: OrderExecutor | None
    last_state: NDArray[np.float64]
    reported: int = 0
    note: str = ""
    #: the arm motion's and the legs' last answers (a still diver asks the same again)
    motion: LastValue = field(default_factory=LastValue, repr=False, compare=False)
    legs: LastValue = field(default_factory=LastValue, repr=False, compare=False)


@dataclass
class GripperSlot:
    """A vehicle's gripper: its spec and state, and what its plant carries."""

    spec: gr.GripperSpec
    state: gr.GripperState = field(default_factory=gr.GripperState)
    carrying: str | None = None


class TeamStage:
    """The teamwork stage (module docstring). ``record(kind, detail)`` logs an event."""

    def __init__(self, source: ScenarioFile, scene: Scene, agents: dict[str, Agent],
                 dt: float, record: Callable[[str, str], None]) -> None:
        self.source, self.scene, self.agents = source, scene, agents
        self.record = record
        world = source.scenario.world
        self.floor = scene.depth_at
        self.period = ticks_for_rate(RATE_HZ, dt, "teamwork stage")
        self.dt = self.period * dt
        self.workspace = self._workspace()
        self.divers: dict[str, DiverBodyState] = {}
        self.grippers: dict[str, GripperSlot] = {}
        #: each agent's last body pose (:meth:`_body_pose_now`): (position and heading
        #: bytes, the read-only pose)
        self._body_poses: dict[str, tuple[bytes, NDArray[np.float64]]] = {}
        self.silt = (SiltCloud(SiltParams(current_ne=world.silt.current_ne), scene.depth_at)
                     if world.silt is not None and world.silt.soft else None)
        self.events: list[WorldEvent] = []  # every event of the run, in order
        #: each bag's gas (surface L) and hatch's angle (deg): last recorded, last tick
        self._recorded_state: dict[str, float] = {}
        self._last_state: dict[str, float] = {}
        #: a diver's arm and trunk goal from outside (name -> t -> joint angles by name,
        #: None: his orders'): the signals he makes (uhrisim.sim.assistance)
        self.arm_poses: dict[str, Callable[[float], dict[str, float] | None]] = {}
        #: what an agent's task from outside works at (name -> the objects and sites):
        #: the tool an assistant's ROV fetches (uhrisim.sim.assistance)
        self.tasks: dict[str, Callable[[], tuple[str, ...]]] = {}
        for index, agent in enumerate(agents.values()):  # what grippers hold is placed
            if agent.config.gripper is not None:         # before the orders are checked
                self.grippers[agent.name] = self._gripper(index, agent)
        for index, agent in enumerate(agents.values()):  # divers with orders or a figure
            if agent.model.diver is not None and (agent.config.orders or
                                                  agent.config.scene_body == "figure"):
                self.divers[agent.name] = self._diver_body(index, agent)
        self._add_bodies()
        self._scene_bodies = frozenset(self.workspace.things) | frozenset(
            self.workspace.flanges) | frozenset(self.workspace.hatches) | frozenset(
            self.workspace.platforms)
        self.obstacles = ObstacleSpheres({b.name: PartSpheres.of(b.geometry)
                                          for b in scene.bodies if b.name in self._scene_bodies})
        for name in self.workspace.platforms:  # fixed: placed once
            position, rotation, _ = scene.pose(name)
            self.obstacles.place(name, _matrix(position, rotation))
        #: each moving body's pose and state at its sphere's last placing
        self._shapes: dict[str, tuple[Any, ...]] = {}
        self._last_inputs: dict[str, tuple[Any, ...]] = {}  # what those followed from
        #: the pose array and state object last compared (poses and frozen states are
        #: replaced, never changed in place: the same objects need no comparing)
        self._seen: dict[str, tuple[Any, Any]] = {}
        ws = self.workspace  # where each bag's and site's state is
        self._states = {name: states for states in (ws.bag_states, ws.flange_states,
                                                    ws.hatch_states) for name in states}
        self._unposed: set[str] = set()  # those the scene has not been told of
        #: the bodies whose sphere moved or changed at the last stage tick
        self.moved: frozenset[str] = frozenset()
        self._left_out: dict[str, frozenset[str]] = {}
        self._work: tuple[Any, ...] = ()  # what was held and each diver's order then
        self._refresh_obstacles()

    @property
    def active(self) -> bool:
        """Whether there is anything for the stage to do."""
        return bool(self.workspace.things or self.divers or self.grippers
                    or self.workspace.flanges or self.workspace.hatches)

    @property
    def body_names(self) -> frozenset[str]:
        """The scene bodies of tools, sites and loads (obstacles through
        :attr:`obstacles` and :meth:`left_out`, not the static broad phase's)."""
        return self._scene_bodies

    def left_out(self, agent: str) -> frozenset[str]:
        """The team bodies ``agent``'s collision sphere leaves out now (module docstring:
        what it holds, what its order works at, what those rest on)."""
        return self._left_out.get(agent, frozenset())

    # ------------------------------------------------------------------ building
    def _where(self, *path: Any) -> str:
        return self.source.where(*path)

    def _workspace(self) -> Workspace:
        world = self.source.scenario.world
        tools = [make_tool(t.kind, t.name, t.mass_kg) for t in world.tools]
        bags = [sites.LiftBagSpec(t.name, t.capacity_litres, t.inflate_rate_lps)
                for t in world.tools if t.kind == "lift_bag"]
        flanges, hatches, loads, platforms = [], [], [], []
        for i, site in enumerate(world.sites):
            at = site.at
            if at.depth is None and not isinstance(site, LoadSite):
                raise ConfigError(f"world.sites[{i}] ({site.name}): give at.depth",
                                  self._where("world", "sites", i, "at"))
            yaw = math.radians(site.heading_deg)
            try:
                match site:
                    case FlangeSite():
                        flanges.append(sites.FlangeSpec(site.name, (at.north, at.east, at.depth),
                                                        yaw, site.bolts,
                                                        loosen_time_s=site.loosen_s))
                    case HatchSite():
                        hatches.append(sites.HatchSpec(site.name, (at.north, at.east, at.depth),
                                                       yaw, site.size, latch_time_s=site.latch_s))
                    case LoadSite():
                        loads.append(sites.steel_load(site.name, site.mass_kg, site.size))
                    case PlatformSite():
                        platforms.append(Platform(site.name, (at.north, at.east, at.depth),
                                                  site.size, yaw))
            except ConfigError as error:
                raise ConfigError(str(error), self._where("world", "sites", i)) from None
        ws = Workspace.of(tools, loads, flanges, hatches, bags, platforms)
        # baskets first: what lies in one is placed relative to it
        placed = sorted(range(len(world.tools)),
                        key=lambda i: world.tools[i].kind != "tool_basket")
        for i in placed:
            self._place(ws, world.tools[i], ("world", "tools", i))
        for i, site in enumerate(world.sites):
            if isinstance(site, LoadSite):
                self._place(ws, site, ("world", "sites", i))
        return ws

    def _place(self, ws: Workspace, item: Any, path: tuple[Any, ...]) -> None:
        """Put a tool or load where the scenario says; with no depth, it rests on what is
        under it (the floor, a platform, a basket's bottom)."""
        where = getattr(item, "where", "floor")
        support = where.partition(":")[2]
        if support and support not in ws.names():
            raise ConfigError(f"{item.name} rests {where.replace(':', ' ')}, which is no "
                              f"tool basket or platform here", self._where(*path))
        at = item.at
        yaw = math.radians(item.heading_deg)
        pitch = math.radians(getattr(item, "pitch_deg", 0.0))
        if at.depth is not None:
            ws.put(item.name, (at.north, at.east, at.depth), yaw, where=where, pitch=pitch)
            return
        above = float(self.floor(at.north, at.east)) - _DROP_HEIGHT_M
        ws.put(item.name, (at.north, at.east, above), yaw, pitch=pitch)
        rests_on, gap = ws.support_below(item.name, self.floor)
        if where != "floor" and rests_on != where:
            raise ConfigError(f"{item.name} at ({at.north:g}, {at.east:g}) is not over "
                              f"{support}: give its position", self._where(*path))
        ws.rest_on(item.name, rests_on, gap)

    def _diver_body(self, index: int, agent: Agent) -> DiverBodyState:
        cfg, diver = agent.config, agent.model.diver
        skeleton = diver.skeleton(cfg, agent.plant)
        q = diver.legs(agent.plant, agent.state, skeleton.vector(
            {"posture": 0.0 if diver.walks else math.pi / 2}), 0.0)
        executor = None
        if cfg.orders:
            orders = [o.order() for o in cfg.orders]
            self._validate(index, agent, orders)
            executor = OrderExecutor(agent.name, orders,
                                     mode="walk" if diver.walks else "swim")
        return DiverBodyState(skeleton, q, np.zeros_like(q), q.copy(), executor,
                              agent.state.copy())

    def _validate(self, index: int, agent: Agent, orders: list[od.Order]) -> None:
        """Refuse orders that cannot be carried out: the first problem, one line, at its
        order's file:line."""
        setup = od.DiverSetup(agent.name, agent.model.diver.walks,
                              (agent.config.start.north, agent.config.start.east))
        ws = self.workspace
        points = [setup.start_ne] + [tuple(p[:2]) for p in (
            od.target_point(ws, n) for n in sorted(ws.names())) if p is not None]
        lo, hi = np.min(points, axis=0) - _MARGIN_M, np.max(points, axis=0) + _MARGIN_M
        extent = (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]))
        carriers = [f"{name}/gripper" for name, a in self.agents.items()
                    if a.config.gripper is not None]
        problems = od.validate_orders(orders, setup, self.workspace, self.floor, extent,
                                      carriers)
        if problems:
            first = problems[0]
            k = int(first.split()[1]) - 1
            raise ConfigError(f"agents[{index}].orders[{k}]: {first}",
                              self._where("agents", index, "orders", k))

    def _gripper(self, index: int, agent: Agent) -> GripperSlot:
        cfg = agent.config.gripper
        slot = GripperSlot(gr.GripperSpec(**part_settings(cfg)))
        agent.community.post("GRIPPER", cfg.command, 0.0, "scenario")
        if cfg.holds is not None:
            ws = self.workspace
            if cfg.holds not in ws.tools:
                raise ConfigError(f"the gripper of {agent.name} holds {cfg.holds!r}, which is "
                                  f"no tool (tools: {', '.join(sorted(ws.tools)) or 'none'})",
                                  self._where("agents", index, "gripper", "holds"))
            jaws = self._jaws(agent.name, slot)
            width = ws.grip_width(cfg.holds)
            slot.state = gr.GripperState("closed", 1.0 - width / slot.spec.jaw_opening)
            grip = jaws.grip_frame()
            # the tool hangs level with its grasp point in the jaws
            yaw = float(agent.state[3])
            ws.put(cfg.holds, grip[:3, 3] - rot_z(yaw) @ ws.tools[cfg.holds].grasp_offset(), yaw)
            ws.take(jaws.name, cfg.holds, grip)
        self._carry_in_dynamics(agent, slot)
        return slot

    def _carry_in_dynamics(self, agent: Agent, slot: GripperSlot) -> None:
        """The vehicle's plant carries what its gripper holds (its mass, added mass, drag
        and in-water weight in eqs 1-4), or nothing; an assistant's ROV knows what it
        holds: its depth controller feeds the in-water weight forward
        and its speed feed-forward the loaded vehicle's drag
        (:meth:`~uhrisim.control.videoray_p.VideoRayPController.holding`)."""
        ws = self.workspace
        held = ws.held_by(f"{agent.name}/gripper")
        if held == slot.carrying:
            return
        load = None
        if held is not None:
            body = self._body_pose_now(agent.name)
            in_body = np.linalg.inv(body) @ ws.thing(held).pose
            areas = (box_projected_areas(ws.tools[held].size, in_body[:3, :3])
                     if held in ws.tools else None)
            load = CarriedLoad(ws.hydro_of(held), tuple(in_body[:3, 3]), areas)
        agent.plant = agent.model.carrying(agent.plant, load)
        slot.carrying = held
        if agent.config.assistant is not None and isinstance(agent.controller,
                                                              VideoRayPController):
            # the plant keeps the empty vehicle's parameters
            agent.controller = agent.controller.holding(agent.plant.params, load)

    def _add_bodies(self) -> None:
        ws, scene = self.workspace, self.scene
        for name, tool in ws.tools.items():  # a lift bag swells: all its sizes, one shown
            shape = ws.bags[name].parts() if name in ws.bags else tool.mesh()
            scene.add_dynamic(name, shape, tool.label, STEEL, *_pose(ws.things[name].pose))
        for name, load in ws.loads.items():
            scene.add_dynamic(name, load.parts(), "load", STEEL, *_pose(ws.things[name].pose))
        for name, spec in ws.flanges.items():
            scene.add_dynamic(name, spec.parts(), "flange", STEEL, *_pose(spec.pose()))
        for name, spec in ws.hatches.items():
            scene.add_dynamic(name, spec.parts(), "hatch", STEEL, *_pose(spec.pose()))
        for name, platform in ws.platforms.items():  # a column from its top to the floor
            top = np.asarray(platform.top_centre_ned)
            height = max(float(self.floor(top[0], top[1])) - top[2], 0.05)
            column = trimesh.creation.box((*platform.size, height))
            column.apply_translation((0.0, 0.0, 0.5 * height))
            scene.add_dynamic(name, column, "platform", CONCRETE, top, rot_z(platform.yaw))

    def _jaws(self, name: str, slot: GripperSlot,
              body_pose: NDArray[np.float64] | None = None) -> acts.Jaws:
        """The gripper of vehicle ``name`` now (``body_pose``: the vehicle's, if known)."""
        return acts.Jaws(name, slot.spec, slot.state,
                         self._body_pose_now(name) if body_pose is None else body_pose)

    def _body_pose_now(self, name: str) -> NDArray[np.float64]:
        """Agent ``name``'s body pose now (4x4 body→NED, level at its heading; the very
        array of the last call while its position and heading hold: what follows from it
        is then kept)."""
        nav = self.agents[name].nav()
        key = nav.position_ned.tobytes() + struct.pack("<d", nav.yaw)
        last = self._body_poses.get(name)
        if last is not None and last[0] == key:
            return last[1]
        pose = pose_matrix(nav.position_ned, nav.yaw)
        pose.setflags(write=False)
        self._body_poses[name] = (key, pose)
        return pose

    # ------------------------------------------------------------------ the tick
    def step(self, tick: int, t: float) -> frozenset[str]:
        """One stage tick (module docstring), if ``tick`` is one; the bodies that moved or
        changed shape in it (:attr:`moved`; none when it is not one)."""
        if tick % self.period:
            return frozenset()
        ws, dt = self.workspace, self.dt
        requests: list[acts.ActRequest] = []
        # the stage moves no agent: their body poses are those of the whole tick
        poses = {name: self._body_pose_now(name) for name in (*self.grippers, *self.divers)}
        # the jaws' grip frames (their vehicles' poses alone place them)
        jaw_frames = {f"{name}/gripper": self._jaws(name, slot, poses[name]).grip_frame()
                      for name, slot in self.grippers.items()}
        grips = {name: frame[:3, 3] for name, frame in jaw_frames.items()}
        for name, body in self.divers.items():
            request = self._move_diver(self.agents[name], body, grips, t, poses[name])
            if request is not None:
                requests.append(request)
        events: list[WorldEvent] = []
        carriers: dict[str, acts.Carrier] = {}
        for name, body in self.divers.items():
            view = self._view(self.agents[name], body, poses[name])  # its hands
            carriers |= {h.name: h for h in (view.hand("left"), view.hand("right"))}
        for name, slot in self.grippers.items():
            events += self._work_gripper(name, slot, t, requests, poses[name])
            carriers[f"{name}/gripper"] = self._jaws(name, slot, poses[name])
        for request in requests:
            events += acts.perform(request, ws, carriers, t, dt, self.floor)
        for name, carrier in carriers.items():
            if ws.held_by(name) is not None:  # an empty hand's frame is not needed
                ws.carry(name, jaw_frames[name] if name in jaw_frames else carrier.grip_frame())
        for name, slot in self.grippers.items():
            self._carry_in_dynamics(self.agents[name], slot)
        events += ws.step(t, dt, self.floor)
        if self.silt is not None:
            for name, body in self.divers.items():
                agent = self.agents[name]
                for sole in agent.model.diver.footfalls(agent.plant, body.last_state,
                                                        agent.state):
                    self.silt.release(t, sole)
        for name, body in self.divers.items():
            body.last_state = self.agents[name].state.copy()
            if body.executor is not None:
                body.executor.observe(events)
                self._report_steps(name, body)
        for event in events:
            self.events.append(event)
            self.record("teamwork", event.line())
        self._record_site_states()
        self._refresh_obstacles()
        return self.moved

    # ------------------------------------------------------------------ obstacles
    def _refresh_obstacles(self) -> None:
        """Place the bounding sphere of every body that moved or changed shape since the
        last stage tick (:attr:`moved`), and work out what each agent leaves out (again
        when what is held, where things are or the orders changed)."""
        ws = self.workspace
        self.moved = self._note_changes()
        work = (tuple(ws.holders.items()), tuple(t.where for t in ws.things.values()), tuple(
            b.executor.current if b.executor is not None else None for b in self.divers.values()),
            tuple(task() for task in self.tasks.values()))
        if work != self._work:  # what is held or worked at, or where things are, changed
            self._work = work
            for name in self.agents:  # an unchanged set is kept (team_obstacles keys on it)
                work_of = self._work_of(name)
                if self._left_out.get(name) != work_of:
                    self._left_out[name] = work_of

    def _note_changes(self) -> frozenset[str]:
        """Compare every tool's, load's and site's shape with the last one seen: the changed
        wait to be posed in the scene and their spheres are placed; returns those whose
        sphere moved."""
        ws = self.workspace
        moved = []
        for name in (*ws.things, *ws.flanges, *ws.hatches):
            thing, states = ws.things.get(name), self._states.get(name)
            objects = (None if thing is None else thing.pose,
                       None if states is None else states[name])
            seen = self._seen.get(name)  # the very objects last seen: nothing changed
            if seen is not None and seen[0] is objects[0] and seen[1] is objects[1]:
                continue
            self._seen[name] = objects
            if states is not None:  # (a plain object's shape is its pose: compared next)
                inputs = self._inputs(name)
                if self._last_inputs.get(name) == inputs:
                    continue
                self._last_inputs[name] = inputs
            shape = self._shape(name)  # (a bolt's wrench work changes no shape)
            if self._shapes.get(name) != shape:
                self._shapes[name] = shape
                self._unposed.add(name)
                if self.obstacles.place(name, *self._body_pose(name)):
                    moved.append(name)
        return frozenset(moved)

    def _shape(self, name: str) -> tuple[Any, ...]:
        """What a tool's, load's or site's pose and parts follow from (:meth:`_body_pose`):
        an object's pose, a bag's shown size, the bolts' and cover's status, a lid's angle."""
        ws = self.workspace
        if name in ws.bags:
            state, pose = ws.bag_states[name], ws.things[name].pose
            return (pose.tobytes(), state.attached_to is not None,
                    ws.bags[name].shown_part(state, float(pose[2, 3])))
        if name in ws.things:
            return (ws.things[name].pose.tobytes(),)
        if name in ws.flanges:
            spec, state = ws.flanges[name], ws.flange_states[name]
            return (state.cover_on, *(spec.bolt_status(state, b) for b in range(spec.n_bolts)))
        return (ws.hatch_states[name].angle,)

    def _inputs(self, name: str) -> tuple[Any, ...]:
        """What :meth:`_shape` reads, as it is: an object's pose, a site's or bag's state
        (frozen: replaced when it changes) — cheap to compare before the shape is."""
        ws = self.workspace
        thing = ws.things.get(name)
        states = self._states.get(name)
        return (None if thing is None else thing.pose.tobytes(),
                None if states is None else states[name])

    def _body_pose(self, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """A tool's, load's or site's pose (4x4 body→NED) and its parts' transforms by its
        state (None: a rigid body)."""
        ws = self.workspace
        if name in ws.bags:
            pose = ws.things[name].pose
            return pose, ws.bags[name].part_transforms(ws.bag_states[name], float(pose[2, 3]))
        if name in ws.things:
            return ws.things[name].pose, None
        if name in ws.flanges:
            spec = ws.flanges[name]
            return spec.pose(), spec.part_transforms(ws.flange_states[name])
        spec = ws.hatches[name]
        return spec.pose(), spec.part_transforms(ws.hatch_states[name])

    def _work_of(self, agent: str) -> frozenset[str]:
        """What ``agent`` works with (module docstring): what its hands or gripper hold and
        what lies in that, what its current order works at, and what those rest on."""
        ws = self.workspace
        held = {ws.held_by(f"{agent}/{c}") for c in ("left_hand", "right_hand", "gripper")}
        held.discard(None)
        body = self.divers.get(agent)
        order = body.executor.current if body is not None and body.executor is not None else None
        named = set(od.worked_at(order, agent))
        if agent in self.tasks:
            named.update(self.tasks[agent]())
        out = held | named
        for name in ws.things:
            supports = self._supports(name)
            if held.intersection(supports):
                out.add(name)  # in a carried basket: it moves with the carrier
            if name in named:
                out.update(supports)
        return frozenset(out)

    def _supports(self, name: str) -> list[str]:
        """What ``name`` rests on or is fixed to, and what that rests on, and so on: the
        basket it lies in, the platform under that, the load a bag is rigged to."""
        ws, chain = self.workspace, []
        where = ws.things[name].where
        while where.startswith(("in:", "on:", "rigged:")) and len(chain) <= len(ws.things):
            support = where.partition(":")[2]
            chain.append(support)
            where = ws.things[support].where if support in ws.things else ""
        return chain

    def _record_site_states(self) -> None:
        """A ``team_state`` event for every bag whose gas and every hatch whose lid has
        moved by a step (:data:`STATE_STEP_LITRES`, :data:`STATE_STEP_DEG`) or stopped
        since the last one: what a replay draws between the teamwork events."""
        ws = self.workspace
        now = {name: ("gas", st.gas_surface_litres, STATE_STEP_LITRES)
               for name, st in ws.bag_states.items()}
        now |= {name: ("angle", math.degrees(st.angle), STATE_STEP_DEG)
                for name, st in ws.hatch_states.items()}
        for name, (what, value, step) in now.items():
            last = self._recorded_state.get(name, 0.0)
            previous = self._last_state.get(name, last)
            moved, still = abs(value - last) >= step, value == previous and value != last
            self._last_state[name] = value
            if moved or still:
                self._recorded_state[name] = value
                self.record("team_state", site_state_detail(name, what, value))

    def _view(self, agent: Agent, body: DiverBodyState, body_pose: NDArray[np.float64]
              ) -> DiverView:
        """The executor's view of a diver now, whose body pose is ``body_pose`` (4x4
        body→NED)."""
        return DiverView(agent.name, agent.model.diver.walks, body.skeleton, body.q,
                         body_pose, agent.nav().speed)

    def _move_diver(self, agent: Agent, body: DiverBodyState, grips: dict[str, NDArray],
                    t: float, body_pose: NDArray[np.float64]) -> acts.ActRequest | None:
        """Run the executor (if any), set the plant's inputs, move the arms and legs."""
        diver = agent.model.diver
        request = None
        if body.executor is not None:
            d = body.executor.tick(self._view(agent, body, body_pose), self.workspace, grips,
                                   t, self.dt)
            agent.directed = diver.directed_inputs(agent.plant, agent.state, d.speed,
                                                   d.turn_rate, d.depth)
            if d.arm_goal is not None:
                body.goal = np.array(d.arm_goal, dtype=float)
            request, body.note = d.act, d.note
        pose = self.arm_poses[agent.name](t) if agent.name in self.arm_poses else None
        if pose is not None:
            body.goal = body.skeleton.vector(pose, body.goal)
        # (the joint arrays are replaced, never changed in place: the answers are kept)
        body.q, body.qdot = body.motion.of(
            body.q.tobytes() + body.qdot.tobytes() + body.goal.tobytes(), step_motion,
            body.skeleton, body.q, body.qdot, body.goal, self.dt)
        body.q = body.legs.of(
            (agent.plant, agent.state.tobytes(), body.q.tobytes(),
             struct.pack("<d", agent.kick_phase)), diver.legs, agent.plant, agent.state,
            body.q, agent.kick_phase)
        return request

    def _work_gripper(self, name: str, slot: GripperSlot, t: float,
                      requests: list[acts.ActRequest], body_pose: NDArray[np.float64]
                      ) -> list[WorldEvent]:
        """Follow the agent's GRIPPER command; jaws that close on an object grasp it,
        jaws that open let go (``body_pose``: the vehicle's now)."""
        ws, actor = self.workspace, f"{name}/gripper"
        command = str(self.agents[name].community.get("GRIPPER", "open"))
        held = ws.held_by(actor)
        jaws = self._jaws(name, slot, body_pose)
        between = None if held else acts.between_jaws(ws, jaws)
        close = {"open": False, "close": True,
                 "catch": held is not None or between is not None,
                 "give": held is not None and len(ws.holders_of(held)) == 1}.get(command,
                                                                                 False)
        events: list[WorldEvent] = []
        slot.state, changed = gr.command(slot.spec, slot.state, close, t, actor)
        events += changed
        if not close and held is not None:
            others = [h for h in ws.holders_of(held) if h != actor]
            events += acts.release(ws, jaws, t, self.floor)
            if command == "give" and others:  # the gripper's side of a hand-over
                events.append(WorldEvent(t, "handover", held, actor, detail={
                    "holders": ", ".join([actor, *others]), "to": ", ".join(others)}))
        width = ws.grip_width(between) if between is not None else None
        slot.state, moved = gr.advance(slot.spec, slot.state, self.dt, t, actor, width)
        events += moved
        if between is not None and any(e.kind == "gripper_closed" and "on_width" in e.detail
                                       for e in moved):
            requests.append(acts.ActRequest("grasp", actor, between))
        return events

    def _report_steps(self, name: str, body: DiverBodyState) -> None:
        steps = body.executor.steps
        while body.reported < len(steps) and steps[body.reported].ended is not None:
            self.record("order", order_detail(name, body.reported, steps[body.reported]))
            body.reported += 1

    def medium(self, t: float) -> SiltMedium | None:
        """The silt in the water at ``t`` as the sensors see it (None: no silt stirred)."""
        return SiltMedium(self.silt, t) if self.silt is not None and self.silt.n_puffs else None

    def joint_samples(self) -> dict[str, JointSample]:
        """Every articulated diver's joints now (for the hooks: recorder, bridges)."""
        return {name: JointSample(body.skeleton.joint_names, tuple(body.q.tolist()),
                                  tuple(body.qdot.tolist()))
                for name, body in self.divers.items()}

    def body_pose(self, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """A diver's body frame now: position NED (m) and rotation body→NED, from its
        state (the scene is posed lazily, only when a sensor or a collision looks)."""
        nav = self.agents[name].nav()
        return np.asarray(nav.position_ned, dtype=float), rot_z(nav.yaw)

    def link_frames(self) -> list[tuple[str, NDArray[np.float64], NDArray[np.float64]]]:
        """Every articulated diver's links now as ``(<agent>/<link>, position NED (3,) m,
        rotation (3x3) → NED)``: the body frame moved as that link is (its rest→posed
        transform, :func:`~uhrisim.world.diver_figure.figure_transforms`, after the
        body's pose), so a link's mesh given in the rest body frame is drawn in it."""
        frames = []
        for name, body in self.divers.items():
            position, rotation = self.body_pose(name)
            posed = figure_transforms(body.skeleton, body.q)
            for link, t in zip(body.skeleton.links, posed, strict=True):
                frames.append((f"{name}/{link}", rotation @ t[:3, 3] + position,
                               rotation @ t[:3, :3]))
        return frames

    def pose_scene(self) -> None:
        """Move the scene's tools, loads, sites' parts (those that moved or changed since
        they were last posed) and articulated divers to now."""
        scene = self.scene
        self._note_changes()  # (the workspace changes only in the stage, or in a test)
        for name in sorted(self._unposed):  # moved or changed since they were last posed
            pose, parts = self._body_pose(name)
            if name in self.workspace.things:
                scene.set_pose(name, *_pose(pose))
            if parts is not None:
                scene.set_part_transforms(name, parts)
        self._unposed.clear()
        for name, body in self.divers.items():
            if self.agents[name].config.scene_body == "figure":
                scene.set_part_transforms(name, figure_transforms(body.skeleton, body.q))


def _pose(m: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return m[:3, 3].copy(), m[:3, :3].copy()


def _matrix(position: NDArray[np.float64], rotation: NDArray[np.float64]
            ) -> NDArray[np.float64]:
    """4x4 body→NED of a position (NED m) and a rotation body→NED."""
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation, position
    return m
