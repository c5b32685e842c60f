"""The simulation loop: integer ticks, one documented update order, read-only hooks.

One tick of the physics step ``dt`` does, in this order (docs/design.md, "data flows one way"):

1. **inputs from outside** — every one, from the ROS 2 and MOOS bridges, the viewer's
   buttons, a Gymnasium action or a script — wait in one inbox
   (:meth:`Simulation.post` of a variable, :meth:`Simulation.set_actuators` of thruster
   commands) and take effect here, at the start of the tick, in the order they came;
2. **scripted events** that are due (time reached, or condition true) fire once;
3. **dynamics**: every agent's model advances one step with the actuator inputs chosen at
   the end of the previous tick; collisions stop the move; body poses go to the scene;
   divers' bubble bursts that are due leave their regulators (:mod:`uhrisim.sim.bubbles`);
   **teamwork** (:mod:`uhrisim.sim.teamwork`, when the scenario has tools, sites,
   orders or a gripper): divers carry out their orders, grippers grip, objects move (a
   tool, load or site part that moves onto an agent is a collision, the agent shoved
   out);
4. **navigation**: NAV_* are posted (at each agent's helm rate);
5. **contacts**: node reports from simulation truth (degraded as configured) reach the
   other agents' contact managers at the contact rate;
6. **sensors**: sonars that are due ping the scene, cameras that are due take a frame
   (each keyed ``"<agent>/<sensor>"``); agents whose contacts come from their sonar run
   perception on its ping and post the diver track as a contact report
   (:mod:`uhrisim.sim.sonar_contacts`);
   **assistance** (:mod:`uhrisim.sim.assistance`, when an agent has an ``assistant``):
   divers make the signals their orders say (after the teamwork stage), the ROV's
   readers read its frames and pings, and its assistant posts to its helm and gripper;
7. **autonomy**: helms and scripts that are due post DESIRED_*;
8. **control**: controllers turn DESIRED_* into actuator inputs for the next tick;
9. **hooks** receive a :class:`~uhrisim.sim.hooks.TickFrame`.

Every rate is a whole number of ticks, checked when the simulation is built.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.autonomy.params import checked_value
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned, rot_z
from uhrisim.core.rng import component_rng
from uhrisim.core.stops import raise_pending_stop
from uhrisim.scenario.build_world import add_object, build_static_scene, object_mesh
from uhrisim.scenario.load import ScenarioFile
from uhrisim.sim.bubbles import DiverBubbles
from uhrisim.sim.build import build_agents, build_events
from uhrisim.sim.community import Value
from uhrisim.sim.contacts import TruthContacts
from uhrisim.sim.drivers import ScriptedDriver
from uhrisim.sim.hooks import (
    AgentSnapshot,
    AgentSnapshots,
    HelmRecord,
    Hook,
    SimEvent,
    TickFrame,
    sensor_key,
)
from uhrisim.sim.hooks import BaseHook as BaseHook  # where many hooks still import it from
from uhrisim.sim.overlap import push_out, sphere_overlaps
from uhrisim.sim.quiet import BOX_MARGIN_M, QuietTicks, floor_reach
from uhrisim.sim.script import ScriptDriver
from uhrisim.sim.sonar_contacts import SonarContacts
from uhrisim.sim.state import Agent, ScheduledEvent
from uhrisim.sim.teamwork import TeamStage
from uhrisim.world.kick import diver_kick_phase_rate
from uhrisim.world.scene import Scene

log = logging.getLogger(__name__)

SURFACE_DEPTH = 0.0  # m; bodies cannot leave the water


class Simulation:
    """Owns all mutable state; advance it with :meth:`step` or :meth:`run`."""

    def __init__(self, source: ScenarioFile, *, seed: int | None = None,
                 raycast_sensors: bool = True, hooks: Sequence[Hook] = ()) -> None:
        self.source = source
        self.scenario = source.scenario
        self.seed = self.scenario.seed if seed is None else seed
        self.dt = 1.0 / self.scenario.physics_rate_hz
        self.tick = 0
        self.raycast_sensors = raycast_sensors  # False: no sonars, no cameras
        self.hooks: list[Hook] = list(hooks)
        self.collisions = 0
        self.events_log: list[SimEvent] = []
        self._pending_events: list[SimEvent] = []
        # inputs from outside, applied at the start of the next tick (see _apply_inbox):
        # ("post", agent, var, value, source) or ("actuators", agent, inputs, until_s)
        self._inbox: list[tuple[Any, ...]] = []
        self._inbox_lock = threading.Lock()
        self.scene: Scene = build_static_scene(source)
        self.agents: dict[str, Agent] = build_agents(self, raycast_sensors)
        self.bubbles = DiverBubbles(self.scene, self.agents, self.rng)
        team = TeamStage(source, self.scene, self.agents, self.dt, self.record_event)
        self.team: TeamStage | None = team if team.active else None
        self.contacts = TruthContacts(self.agents, self.dt, self.rng)
        self.sonar_contacts = SonarContacts(self.agents, self.dt, source, self.record_event)
        self.assistance = None
        if any(a.config.assistant is not None for a in self.agents.values()):
            from uhrisim.sim.assistance import AssistanceStage  # the hri extra: py_trees
            self.assistance = AssistanceStage(source, self.scene, self.agents, self.team,
                                              self.sonar_contacts, self.record_event,
                                              lambda: self.collisions)
        self.events: list[ScheduledEvent] = build_events(self)
        self._waiting_events = list(self.events)  # not fired yet, in the scenario's order
        self.raycaster = self.scene.raycaster("embree") if any(
            a.sonars or a.cameras for a in self.agents.values()) else None
        self.refresh_static_obstacles()
        # for each agent, the others it can run into and the distance that is a touch (m)
        self._others = {a.name: tuple((o, a.radius + o.radius) for o in self.agents.values()
                                      if o is not a) for a in self.agents.values()}
        floor = self.scene.seafloor
        self._shallowest_floor = float(np.min(floor.depth)) if floor is not None else np.inf
        self._floor_slope = floor.max_slope if floor is not None else 0.0
        self._scene_dirty = False
        #: (agent, team body) pairs in contact since a body moved onto the agent
        self._team_contacts: set[tuple[str, str]] = set()
        #: the compiled stretch of quiet ticks (None: every tick is the loop's)
        self._quiet = QuietTicks.of(self)
        self._started = False
        self._closed = False
        self.wall_time = 0.0

    # -- time -----------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulation time (s) = ticks x physics step."""
        return self.tick * self.dt

    def rng(self, component: str) -> np.random.Generator:
        """The named random stream of a component (same seed + name => same stream)."""
        return component_rng(self.seed, component)

    # -- inputs from outside ---------------------------------------------------------------
    def post(self, agent: str, var: str, value: Value, source: str = "external") -> None:
        """Queue a variable for an agent's community (thread-safe; applied next tick)."""
        if agent not in self.agents:
            raise ConfigError(f"unknown agent {agent!r}; agents: {', '.join(self.agents)}")
        value = checked_value(agent, var, value)
        with self._inbox_lock:
            self._inbox.append(("post", agent, var, value, source))

    def set_actuators(self, agent: str, inputs: Sequence[float], hold_s: float = 1.0) -> None:
        """Drive an agent's actuators directly (an external controller), for ``hold_s``
        simulated seconds from now; then its own controller takes over again (a safe
        fallback). Checked now, queued in the inbox like :meth:`post` (thread-safe): the
        controller stage of the next tick applies them."""
        if agent not in self.agents:
            raise ConfigError(f"unknown agent {agent!r}; agents: {', '.join(self.agents)}")
        size = self.agents[agent].inputs.size
        values = np.asarray(inputs, dtype=float)
        if values.shape != (size,) or not np.all(np.isfinite(values)):
            raise ConfigError(f"actuator inputs for {agent!r} must be {size} finite numbers, "
                              f"got {list(inputs)!r}")
        with self._inbox_lock:
            self._inbox.append(("actuators", agent, values, self.t + hold_s))

    def refresh_static_obstacles(self) -> None:
        """Recompute the collision broad phase after the scene's geometry changed. The
        bodies it leaves to others: the agents (their spheres), bubbles and slates (no
        obstacles) and the team's tools, sites and loads (obstacles through their own
        pre-check, :meth:`_team_in_reach`)."""
        self._static_boxes = static_obstacle_boxes(self.scene)
        self._not_obstacles = frozenset(self.agents) | self.bubbles.body_names | (
            self.team.body_names if self.team is not None else frozenset()) | (
            self.assistance.body_names if self.assistance is not None else frozenset())
        self._has_movable_objects = any(n not in self._not_obstacles
                                        for n in self.scene.body_names)

    def record_event(self, kind: str, detail: str) -> None:
        event = SimEvent(self.t, kind, detail)
        self.events_log.append(event)
        self._pending_events.append(event)
        log.info("t=%.2f %s: %s", event.t, kind, detail)

    # -- the loop -------------------------------------------------------------------------
    def start(self) -> None:
        if self._started:
            return
        self._started = True
        for agent in self.agents.values():
            self._post_nav(agent, self.t)
            self._control(agent)
        for hook in self.hooks:
            hook.on_start(self)

    def step(self) -> TickFrame:
        """Advance one physics step and return what happened (also given to the hooks)."""
        frame = self._step(build_frame=True)
        assert frame is not None
        return frame

    def _step(self, build_frame: bool) -> TickFrame | None:
        """One tick; a frame is made only if someone looks, and its agent snapshots are
        taken as hooks read them (all of them for ``build_frame``)."""
        if not self._started:
            self.start()
        raise_pending_stop()  # a stop signal some library swallowed (core/stops.py)
        if self._inbox:  # (read without the lock: a post racing in is applied next tick)
            self._apply_inbox()
        if self._waiting_events:
            self._fire_events()
        t = self.t
        for agent in self.agents.values():
            self._advance(agent, t)
        self.tick += 1
        return self._after_moves(build_frame)

    def _after_moves(self, build_frame: bool) -> TickFrame | None:
        """The rest of a tick once every agent has moved (stages 3 to 9)."""
        agents = self.agents.values()
        tick, t = self.tick, self.t
        if self.bubbles.active:
            self.bubbles.release(t)
        if self.team is not None:
            moved = self.team.step(tick, t)
            self._scene_dirty = True
            if moved or self._team_contacts:
                self._struck_by_team(moved)
        if self.assistance is not None:
            self.assistance.perform(t)
        for agent in agents:
            if tick % agent.driver_period == 0:
                self._post_nav(agent, t)
        self.contacts.step(tick, t)
        pings, images = self._sense() if self.raycaster is not None else ({}, {})
        perception = self.sonar_contacts.step(tick, t, pings) if (
            self.sonar_contacts.observers) else {}
        if self.assistance is not None:
            self.assistance.read(pings, images)
            self.assistance.step(tick, t)
        helm: dict[str, HelmRecord] = {}
        for agent in agents:
            if agent.driver is not None and tick % agent.driver_period == 0:
                record = agent.driver.tick(t, agent)
                if record is not None:
                    agent.last_helm = record
                    helm[agent.name] = record
                if self.assistance is not None:
                    self.assistance.after_helm(agent, t)
            if tick % agent.control_period == 0:
                self._control(agent)
        if not (build_frame or self.hooks):  # nobody reads the posts: drop them
            for agent in agents:
                agent.community.take_log()
            self._pending_events.clear()
            return None
        posts = tuple(p for a in agents for p in a.community.take_log())
        snapshots = AgentSnapshots(tuple(self.agents), self._snapshot_of)
        if build_frame:
            snapshots.take_all()
        joints = self.team.joint_samples() if self.team is not None else {}
        frame = TickFrame(self.tick, t, snapshots, pings, helm, posts,
                          tuple(self._pending_events), images, perception, joints)
        self._pending_events.clear()
        for hook in self.hooks:
            hook.on_tick(frame)
        snapshots.close()
        return frame

    def run(self, duration: float | None = None,
            progress: Callable[[float], None] | None = None,
            should_stop: Callable[[], bool] | None = None) -> None:
        """Advance ``duration`` simulated seconds (default: the scenario's). Can be called
        again to go on; :meth:`close` ends the hooks (closes recordings, bridges)."""
        duration = self.scenario.duration if duration is None else duration
        end_tick = self.tick + round(duration / self.dt)
        wall_start = time.perf_counter()
        # nobody looks at a tick: its quiet ones may go in stretches (sim/quiet.py)
        quiet = self._quiet if not self.hooks and should_stop is None else None
        try:
            self.start()
            while self.tick < end_tick:
                moved = False  # has a stretch made the moves of the tick it ended on?
                if quiet is not None:
                    raise_pending_stop()
                    done, moved = quiet.run(end_tick, progress is not None)
                    if done and not moved:
                        continue
                if moved:
                    self._after_moves(build_frame=False)
                else:
                    self._step(build_frame=False)
                if progress is not None and self.tick % 100 == 0:
                    progress(self.t)
                if should_stop is not None and should_stop():
                    break
        finally:
            self.wall_time += time.perf_counter() - wall_start

    def close(self, error: BaseException | None = None) -> None:
        """End every hook once (``error``: why the run stopped, if it failed)."""
        if self._closed:
            return
        self._closed = True
        if self._started:
            for hook in self.hooks:
                hook.on_end(self, error)

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        self.close(exc)

    # -- tick stages ----------------------------------------------------------------------
    def _apply_inbox(self) -> None:
        """The inputs from outside, in the order they came (the tick's first stage)."""
        with self._inbox_lock:
            inbox, self._inbox = self._inbox, []
        for kind, agent, *rest in inbox:
            if kind == "post":
                var, value, source = rest
                self.agents[agent].community.post(var, value, self.t, source)
            else:
                target = self.agents[agent]
                target.actuator_override, target.actuator_override_until = rest

    def _fire_events(self) -> None:
        for event in list(self._waiting_events):
            cfg = event.config
            due = (cfg.at is not None and self.t >= cfg.at - 1e-9) or (
                event.condition is not None
                and event.condition.evaluate(self.agents[cfg.agent].community.values()))
            if due:
                event.fired = True
                self._waiting_events.remove(event)
                self._apply_event(event)

    def _apply_event(self, event: ScheduledEvent) -> None:
        """Carry out a scripted event's action and log it."""
        cfg = event.config
        if cfg.post is not None:
            post = cfg.post
            self.agents[post.agent].community.post(post.var, post.value, self.t, "event")
            self.record_event("event", f"posted {post.var}={post.value} to {post.agent}")
        elif cfg.add_object is not None:
            where = self.source.where("events", event.index, "add_object")
            obj = cfg.add_object
            add_object(self.scene, obj, self.source, where)
            self.refresh_static_obstacles()
            self.record_event("event", f"added object {obj.label!r}")
            self._count_struck(obj, where, "added")
        elif cfg.move_object is not None:
            move = cfg.move_object
            if move.label not in self.scene.body_names:
                raise ConfigError(f"move_object: no movable body named {move.label!r}; movable: "
                                  f"{', '.join(self.scene.body_names)}",
                                  where=self.source.where("events", event.index, "move_object"))
            _, rotation, _ = self.scene.pose(move.label)
            self.scene.set_pose(move.label, np.array(move.position.as_list()), rotation)
            self.record_event("event", f"moved {move.label!r} to {move.position.as_list()}")
            moved = next(o for o in self.source.scenario.all_objects()
                         if o.movable and o.label == move.label)
            placed = moved.model_copy(update={"position": move.position})
            self._count_struck(placed, self.source.where("events", event.index, "move_object"),
                               "moved")
        elif cfg.script is not None:
            agent = self.agents[cfg.agent]
            if isinstance(agent.driver, ScriptedDriver):
                agent.driver.script.replace(cfg.script)
            else:
                agent.driver = ScriptedDriver(ScriptDriver(cfg.script))
                agent.driver_period = max(1, round(0.25 / self.dt))
            self.record_event("event", f"new script for {cfg.agent} ({len(cfg.script)} legs)")

    def _count_struck(self, obj: Any, where: str, how: str) -> None:
        """An object an event put where an agent is: a collision of that agent (it did not
        move into the object, so the moving-sphere check of :meth:`_advance` cannot see
        it), and the agent is pushed out the shortest way, at rest
        (:mod:`uhrisim.sim.overlap`)."""
        mesh = object_mesh(obj, self.source, where)
        if not mesh.is_watertight:
            return
        for agent in self.agents.values():
            if sphere_overlaps(mesh, agent.state[:3], agent.radius):
                self._shove(agent, mesh, f"{obj.label!r}, which an event {how} onto it")

    def _struck_by_team(self, moved: frozenset[str]) -> None:
        """A tool, load or site part that moved onto an agent (a rising load, a swelling
        bag; not one it works with, :meth:`TeamStage.left_out`): a collision of that agent,
        once per contact — the pair stays in contact until their bounding spheres part —
        and the agent is pushed out, as by an object an event puts there."""
        team = self.team
        assert team is not None
        for agent_name, name in list(self._team_contacts):
            centre, reach = team.obstacles.sphere(name)
            agent = self.agents[agent_name]
            if not math.dist(centre, agent.state[:3]) <= reach + agent.radius:
                self._team_contacts.discard((agent_name, name))
        for name in sorted(moved):
            centre, reach = team.obstacles.sphere(name)
            for agent in self.agents.values():
                if (name in team.left_out(agent.name)
                        or not math.dist(centre, agent.state[:3]) <= reach + agent.radius
                        or (agent.name, name) in self._team_contacts
                        or not team.obstacles.box_near(name, agent.state[:3], agent.radius)):
                    continue
                self._sync_scene()
                mesh = self.scene.bodies[self.scene.body_names.index(name)].mesh_world()
                if sphere_overlaps(mesh, agent.state[:3], agent.radius):
                    self._team_contacts.add((agent.name, name))
                    self._shove(agent, mesh, f"{name}, which moved onto it")

    def _shove(self, agent: Agent, mesh: Any, what: str) -> None:
        """A collision of ``agent`` with ``mesh`` (closed, NED), which came onto it (it did
        not move into it, so the moving-sphere check of :meth:`_advance` cannot see it):
        counted and logged, and the agent pushed out the shortest way, at rest
        (:mod:`uhrisim.sim.overlap`)."""
        centre = agent.state[:3]
        self.collisions += 1
        agent.in_contact = True
        state = agent.state.copy()
        state[:3] = push_out(mesh, centre, agent.radius)
        state[2] = max(state[2], SURFACE_DEPTH)
        if agent.model.contact_stops is not None:
            state[agent.model.contact_stops] = 0.0
        agent.update(state=state)
        self._scene_dirty = True
        self.record_event("collision", f"{agent.name} touched {what} at NED "
                          f"{np.round(centre, 2).tolist()}; pushed out to "
                          f"{np.round(state[:3], 2).tolist()}")

    def _advance(self, agent: Agent, t: float) -> None:
        """Step ``agent``'s model from time ``t`` (s) over one tick; stop it at the surface
        and at what it touches."""
        previous = agent.state  # plants return a new state; this one stays as it was
        new_state = agent.plant.step(t, previous, agent.inputs)
        model = agent.model
        if new_state[2] < SURFACE_DEPTH:  # cannot fly out of the water
            new_state[2] = SURFACE_DEPTH
            if model.surface_stops is not None:  # no upward heave through the surface
                new_state[model.surface_stops] = max(new_state[model.surface_stops], 0.0)
        fraction, touched = self._clear_fraction(agent, previous[:3].tolist(),
                                                 new_state[:3].tolist())
        if fraction < 1.0:
            if not agent.in_contact:  # count each contact once, at its onset
                self.collisions += 1
                self.record_event("collision", f"{agent.name} touched {touched}")
            start, end = previous[:3], new_state[:3]
            new_state[:3] = start + (end - start) * max(0.0, fraction - 1e-3)
            if model.contact_stops is not None:
                new_state[model.contact_stops] = 0.0  # inelastic stop against the obstacle
        agent.in_contact = fraction < 1.0
        agent.update(state=new_state)
        if agent.is_diver_body:
            speed = abs(agent.nav().speed)
            agent.kick_phase += diver_kick_phase_rate(speed) * self.dt
        self._scene_dirty = True

    def _sync_scene(self) -> None:
        """Move the bodies in the scene to the agents' poses (lazily: only the sonar and
        the collision narrow phase look at the scene)."""
        if not self._scene_dirty:
            return
        for agent in self.agents.values():
            nav = agent.nav()
            self.scene.set_pose(agent.name, nav.position_ned, rot_z(nav.yaw),
                                agent.kick_phase if agent.is_diver_body else None,
                                checked=False)  # (states are kept finite, tick by tick)
        self.bubbles.pose(self.t)
        if self.team is not None:
            self.team.pose_scene()
        self._scene_dirty = False

    def _clear_fraction(self, agent: Agent, start: list[float], end: list[float]
                        ) -> tuple[float, str]:
        """Fraction of the move start->end (NED, m) free of other agents, static geometry
        and the team's tools, sites and loads (but those it works with,
        :meth:`TeamStage.left_out`), and what it touches ("" when the move is free)."""
        for other, touch in self._others[agent.name]:
            centre = other.state[:3].tolist()
            end_distance = math.dist(end, centre)
            if end_distance < touch and end_distance < math.dist(
                    start, centre):  # touching and approaching
                return 0.0, other.name
        team = self._team_in_reach(agent, start, end)
        if team or self._near_static(agent, end, math.dist(start, end)):
            if team or self._has_movable_objects:  # else no obstacle's pose matters
                self._sync_scene()
            free, what, where = self.scene.segment_contact(
                np.array(start), np.array(end), agent.radius,
                exclude=self._not_obstacles.difference(team))
            if free < 1.0:
                if what in team:
                    return free, f"{what} at NED {np.round(where, 2).tolist()}"
                return free, f"the scene at NED {np.round(end, 2).tolist()}"
        return 1.0, ""

    def _team_in_reach(self, agent: Agent, start: list[float], end: list[float]
                       ) -> list[str]:
        """The team bodies a move start->end (NED, m) of ``agent`` can touch, by their
        bounding spheres (:mod:`uhrisim.sim.team_obstacles`); those it works with are
        left out."""
        if self.team is None or start == end:
            return []
        return self.team.obstacles.in_reach(agent.name, start, end, agent.radius,
                                            self.team.left_out(agent.name))

    def _near_static(self, agent: Agent, point: list[float], step_m: float) -> bool:
        """Cheap broad phase: is ``point`` (NED, m), the end of a move of ``step_m``, within
        reach of any static geometry? A hit of the narrow phase's ray bundle lies within
        radius + step of the end, where the floor is at most max slope x that shallower
        than under it."""
        if self._has_movable_objects:
            return True  # movable objects have no precomputed bounds: always look closely
        reach = floor_reach(agent.radius, step_m, self._floor_slope)
        if point[2] + reach >= self._shallowest_floor and point[2] + reach >= float(
                self.scene.depth_at(point[0], point[1])):
            return True
        margin = agent.radius + BOX_MARGIN_M
        lows, highs = self._static_boxes
        if lows.size == 0:
            return False
        inside = np.all((point >= lows - margin) & (point <= highs + margin), axis=1)
        return bool(np.any(inside))

    def _post_nav(self, agent: Agent, t: float) -> None:
        """NAV_* of ``agent`` now (time ``t``, s) to its community."""
        nav = agent.nav()
        north, east, depth = nav.position_ned.tolist()
        x_east, y_north = moos_xy_from_ned(north, east)
        agent.community.post_many(
            (("NAV_X", x_east), ("NAV_Y", y_north), ("NAV_DEPTH", depth),
             ("NAV_HEADING", float(heading_deg_from_yaw(nav.yaw))),
             ("NAV_SPEED", float(nav.speed))), t, "uhrisim")

    def _sense(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """Sonar pings and camera frames of the sensors due now, by ``"<agent>/<sensor>"``."""
        pings, images = {}, {}
        for agent in self.agents.values():
            for slot in agent.sonars:
                if self.tick % slot.period == 0:
                    pings[sensor_key(agent.name, slot.name)] = self._sense_from(
                        agent, slot.sonar.ping)
            for cam in agent.cameras:
                if self.tick % cam.period == 0:
                    images[sensor_key(agent.name, cam.name)] = self._sense_from(
                        agent, cam.camera.capture)
        return pings, images

    def _sense_from(self, agent: Agent, sense: Callable[..., Any]) -> Any:
        """``sense(raycaster, position NED, rotation body→NED, t, exclude=..., medium=...)``
        from the agent's pose now, the agent's own body unseen, through the silt in the
        water (None: none)."""
        self._sync_scene()
        nav = agent.nav()
        medium = self.team.medium(self.t) if self.team is not None else None
        return sense(self.raycaster, nav.position_ned, rot_z(nav.yaw), self.t,
                     exclude=frozenset({agent.name}), medium=medium)

    def _control(self, agent: Agent) -> None:
        if agent.actuator_override is not None:
            if self.t <= agent.actuator_override_until:
                agent.update(inputs=agent.actuator_override)
                return
            agent.actuator_override = None
            self.record_event("actuators", f"{agent.name}: external thruster commands went "
                              "stale; own controller resumed")
        if agent.directed is not None:  # a diver carrying out its orders
            agent.update(inputs=agent.directed)
            return
        heading, speed, depth = agent.desired()
        agent.update(inputs=agent.controller.inputs(agent.state, heading, speed, depth))

    # -- read-only views ------------------------------------------------------------------
    def snapshot(self, agent: Agent) -> AgentSnapshot:
        heading, speed, depth = agent.desired()
        return AgentSnapshot(agent.name, agent.config.model, agent.nav(),
                             tuple(agent.inputs.tolist()), heading, speed, depth,
                             str(agent.community.get("MODE", "")))

    def _snapshot_of(self, name: str) -> AgentSnapshot:
        return self.snapshot(self.agents[name])

    def snapshots(self) -> dict[str, AgentSnapshot]:
        return {name: self.snapshot(agent) for name, agent in self.agents.items()}



def static_obstacle_boxes(scene: Scene) -> tuple[NDArray, NDArray]:
    """Axis-aligned bounds (NED) of every static object except the sea floor."""
    lows, highs = [], []
    for obj in scene.static_objects:
        if obj.label == "seafloor":
            continue
        bounds = np.asarray(obj.mesh.bounds)
        lows.append(bounds[0])
        highs.append(bounds[1])
    if not lows:
        return np.empty((0, 3)), np.empty((0, 3))
    return np.array(lows), np.array(highs)

