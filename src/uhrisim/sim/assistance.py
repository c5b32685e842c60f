"""The assistance stage of the loop: the diver's signals made by his body, read by the
ROV's own camera and sonar, and the diver's assistant driving the ROV (docs/hri.md, "In
the simulation loop").

Built with the simulation when an agent has an ``assistant`` section (the ``hri``
extra: ``py_trees``); names and parameters are checked then, one line each with the
section's file:line. Each tick it does, in the loop's order:

* **perform** (after the teamwork stage): a diver whose order is a ``signal`` with a
  channel makes it (:class:`~uhrisim.perception.signalling.SignalPerformer`), turned
  on the spot to face the ROV: his arms and trunk follow the gesture's keyframes (the
  teamwork stage's ``arm_poses``), or — once he has turned to the ROV and risen
  upright from his work (:meth:`AssistanceStage._ready`; at most ``SLATE_READY_S``) —
  he holds up the slate with the command's marker (a dynamic body in the scene, put
  away under the floor otherwise); the performer's ``issued`` is the truth the metrics
  count against;
* **read** (after the sensors): every frame of the assisted ROV's camera and every ping
  of its sonar that the loop rendered this tick (keyed ``"<agent>/<sensor>"``) goes to
  its :class:`~uhrisim.perception.signal_readers.SignalReaders`; what they say waits
  for the next assistant tick — while the diver is out of the camera's view
  (:meth:`AssistanceStage._diver_in_view`) the gesture reader takes the picture as one
  without him, and a marker read is logged and dropped;
* **assist** (before the helms, at the ROV's helm rate): the assistant gets its inputs —
  the ROV's navigation from the plant, the diver's track (``truth``: his body centre,
  head and right hand from the articulated body; ``sonar``: the ROV's sonar contact,
  depth its own), the gripper's phase and holders from the workspace, the signals read
  since its last tick, the tools' grasp points and the work sites — and its outputs go
  where an outside planner's would: the postings to the ROV's community (the helm's
  mail, the MOOS and ROS 2 bridges: ``ASSIST_*``, the updates, ``MOOS_MANUAL_OVERRIDE``
  and ``DESIRED_*`` while it backs off, posted again after the helm's tick:
  :meth:`AssistanceStage.after_helm`), ``GRIPPER_CMD`` to the gripper's ``GRIPPER``
  (``give`` when the diver holds the object too), its events to the simulation's event
  log (``assistant``).

**The diver's side of a hand-over.** A diver whose order is ``wait_until: <tool>,
state: held_by:<diver>/<side>_hand`` takes the tool when the ROV holds it within
``TAKE_REACH_M`` of his hand for ``TAKE_AFTER_S`` (he reaches for it; the gripper then
opens and the tool is his).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.assistant import (
    Assistant,
    AssistantConfig,
    AssistantInputs,
    DiverTrack,
    GripperStatus,
    RovNav,
)
from uhrisim.assistant.geometry import separations
from uhrisim.assistant.metrics import IssuedSignal, signal_metrics
from uhrisim.assistant.trees import CHEST_ABOVE_PELVIS_M
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw, rot_z
from uhrisim.perception.gesture_reader import GestureReader
from uhrisim.perception.markers import SEARCH_MARGIN_M, MarkerCommands, MarkerReader
from uhrisim.perception.signal_readers import SignalReaders
from uhrisim.perception.signalling import (
    SLATE_AHEAD_M,
    SLATE_READY_S,
    SignalPerformer,
    slate_position,
)
from uhrisim.perception.signals import Command, RecognizedSignal
from uhrisim.perception.sonar_wave import SonarWaveReader
from uhrisim.scenario.assistance import AssistantSection
from uhrisim.scenario.load import ScenarioFile
from uhrisim.sim.hooks import sensor_key
from uhrisim.sim.sonar_contacts import SonarContacts
from uhrisim.sim.state import Agent
from uhrisim.sim.teamwork import TeamStage
from uhrisim.teamwork import orders as od
from uhrisim.teamwork.executor import DiverView
from uhrisim.teamwork.workspace import pose_matrix
from uhrisim.world.scene import Scene
from uhrisim.world.slate import MarkerSlate

#: the diver takes a tool held within this of his hand (m) ...
TAKE_REACH_M = 0.2
#: ... for this long (s)
TAKE_AFTER_S = 1.0
#: a signalling diver turns to face the ROV at this rate per radian off (1/s)
FACE_TURN_GAIN = 1.5
#: he holds the slate up once he faces the ROV within this (deg) ...
SLATE_FACING_DEG = 20.0
#: ... and his trunk is within this of upright (deg; posture and waist)
SLATE_UPRIGHT_DEG = 15.0
#: where a slate that is not held up is kept: under the sea floor (NED, m)
SLATE_AWAY_NED = np.array([0.0, 0.0, 1.0e4])
#: a waiting diver sees the ROV's "say again?" cue (its lamps swung off him and back)
#: within this (m) ...
CUE_SEEN_M = 4.0
#: ... and repeats his last signal at most this many times in one wait
REPEATS_MAX = 2
#: on the sonar's track (no depth), the marker reader looks this far above and below
#: the ROV's depth for the slate (m)
SLATE_SEARCH_DEPTH_M = 3.0


@dataclass
class SignallingDiver:
    """A diver who signals: his performer, his slates (one scene body per marker id his
    orders show) and how many of his steps were looked at."""

    agent: Agent
    performer: SignalPerformer
    slates: dict[int, str] = field(default_factory=dict)
    shown: int | None = None  # the marker id of the slate he holds up (None: put away)
    seen_steps: int = 0
    watcher: Agent | None = None  # the ROV he signals to (he faces it)
    #: a slate signal's order has begun (its start, s; the command) and he gets ready
    slate_due: tuple[float, Command] | None = None
    #: he waits for the ROV to hand him a tool
    receiving: bool = False
    #: his signals repeated on the ROV's "say again?": (the wait's step index, how many)
    repeats: tuple[int, int] = (-1, 0)
    repeated: int = 0  # in all

    def signalling_pose(self, t: float) -> dict[str, float] | None:
        """His joint goals while he signals, gets ready to show the slate or waits for a
        tool from the ROV: upright (a swimmer rises from his swimming posture, as divers
        do to signal or to take a tool; prone, his head lies where the ROV's jaws must
        reach his hand, inside its head guard), the gesture's arms; None otherwise."""
        pose = self.performer.joints(t) if self.slate_due is not None else \
            self.performer.performing(t)
        if pose is None and not self.receiving:
            return None
        return {"posture": 0.0, "waist": 0.0, **(pose or {})}


@dataclass
class AssistedVehicle:
    """One ROV under the assistant: its readers, its diver, what it knows of the map."""

    agent: Agent
    diver: SignallingDiver
    assistant: Assistant
    readers: SignalReaders
    section: AssistantSection
    camera_key: str | None
    sonar_key: str | None
    tools: dict[str, str]  # a command's tool name -> the workspace's object
    sites: tuple[str, ...]
    heard: list[RecognizedSignal] = field(default_factory=list)
    offered_since: float | None = None
    min_body_m: float = math.inf
    min_head_m: float = math.inf


class AssistanceStage:
    """The assistance stage (module docstring). ``record(kind, detail)`` logs an event,
    ``collisions()`` counts the run's collisions so far."""

    def __init__(self, source: ScenarioFile, scene: Scene, agents: dict[str, Agent],
                 team: TeamStage | None, contacts: SonarContacts,
                 record: Callable[[str, str], None], collisions: Callable[[], int]) -> None:
        self.source, self.scene, self.agents = source, scene, agents
        self.team, self.contacts, self.record = team, contacts, record
        self.collisions = collisions
        self.divers: dict[str, SignallingDiver] = {}
        self.vehicles: list[AssistedVehicle] = []
        for index, agent in enumerate(agents.values()):
            if agent.config.assistant is not None:
                self.vehicles.append(self._vehicle(index, agent))
        for name, diver in self.divers.items():
            self._add_slates(diver)
            if team is not None:
                team.arm_poses[name] = diver.signalling_pose
        for v in self.vehicles:  # its jaws work at the tool it fetches (docs/teamwork.md)
            self.team.tasks[v.agent.name] = lambda v=v: self._task_tools(v)  # type: ignore

    @property
    def body_names(self) -> frozenset[str]:
        """The slates' scene bodies (not obstacles to the agents)."""
        return frozenset(n for d in self.divers.values() for n in d.slates.values())

    # ------------------------------------------------------------------ building
    def _vehicle(self, index: int, agent: Agent) -> AssistedVehicle:
        section: AssistantSection = agent.config.assistant
        where = self.source.where("agents", index, "assistant")
        if self.team is None or agent.name not in self.team.grippers:
            raise ConfigError(f"{agent.name} has an assistant but no gripper (give it "
                              "'gripper:')", where)
        if agent.config.driver != "helm":
            raise ConfigError(f"{agent.name}'s assistant drives its helm: give it 'driver: "
                              "helm' (no 'helm' section: the shipped assistant.bhv)", where)
        config = AssistantConfig.from_mapping(
            section.params, f"{self.source.where('agents', index, 'assistant', 'params')} "
            f"agents[{index}].assistant.params")
        diver_name = section.diver or self._only_diver(where)
        if diver_name not in self.team.divers or self.team.divers[diver_name].executor is None:
            raise ConfigError(f"agents[{index}].assistant.diver: {diver_name!r} is no diver "
                              "with orders", where)
        markers = MarkerCommands.load() if not section.markers else MarkerCommands.from_mapping(
            {"commands": section.markers}, f"{where} agents[{index}].assistant.markers")
        diver = self.divers.setdefault(diver_name, SignallingDiver(
            self.agents[diver_name], SignalPerformer(markers=markers), watcher=agent))
        camera = self._sensor(agent, section.camera, "camera", where, index)
        sonar = self._sensor(agent, section.sonar or agent.config.perception_sonar, "sonar",
                             where, index)
        channels = set(section.channels)
        readers = SignalReaders(
            markers=MarkerReader(markers) if "marker" in channels and camera else None,
            gestures=GestureReader() if "gesture" in channels and camera else None,
            sonar=SonarWaveReader() if "sonar" in channels and sonar else None)
        if section.track == "sonar" and not any(o.agent is agent for o in
                                                self.contacts.observers):
            raise ConfigError(f"agents[{index}].assistant.track: sonar needs contacts.source: "
                              "sonar", where)
        return AssistedVehicle(agent, diver, Assistant(config), readers, section,
                               camera and sensor_key(agent.name, camera),
                               sonar and sensor_key(agent.name, sonar),
                               self._tools(section, index, where),
                               self._sites(section, index, where))

    @staticmethod
    def _task_tools(v: AssistedVehicle) -> tuple[str, ...]:
        """The world's tool the ROV's task names (the one ``bring_tool`` fetches), if any."""
        task = v.assistant.ctx.task
        tool = v.tools.get(task.argument) if task is not None and task.argument else None
        return () if tool is None else (tool,)

    def _only_diver(self, where: str) -> str:
        divers = [n for n, a in self.agents.items() if a.model.diver is not None]
        if len(divers) != 1:
            raise ConfigError(f"name the diver to assist (divers: {', '.join(divers) or 'none'})",
                              where)
        return divers[0]

    def _sensor(self, agent: Agent, name: str | None, kind: str, where: str,
                index: int) -> str | None:
        slots = agent.cameras if kind == "camera" else agent.sonars
        if name is None:
            return slots[0].name if slots else None
        if not any(s.name == name for s in slots):
            have = ", ".join(s.name for s in slots) or "none"
            raise ConfigError(f"agents[{index}].assistant.{kind}: {agent.name} has no {kind} "
                              f"{name!r} (have {have})", where)
        return name

    def _tools(self, section: AssistantSection, index: int, where: str) -> dict[str, str]:
        ws = self.team.workspace  # type: ignore[union-attr]
        if section.tools is None:
            known: dict[str, str] = {}
            for name in sorted(ws.tools):
                kind = ws.tools[name].kind
                if kind != "tool_basket":
                    known.setdefault(kind, name)
            return known
        for said, name in section.tools.items():
            if name not in ws.tools:
                raise ConfigError(f"agents[{index}].assistant.tools.{said}: no tool {name!r} "
                                  f"(have {', '.join(sorted(ws.tools)) or 'none'})", where)
        return dict(section.tools)

    def _sites(self, section: AssistantSection, index: int, where: str) -> tuple[str, ...]:
        ws = self.team.workspace  # type: ignore[union-attr]
        have = sorted({*ws.flanges, *ws.hatches, *ws.loads})
        if section.sites is None:
            return tuple(have)
        for name in section.sites:
            if name not in have:
                raise ConfigError(f"agents[{index}].assistant.sites: no work site {name!r} "
                                  f"(have {', '.join(have) or 'none'})", where)
        return section.sites

    def _add_slates(self, diver: SignallingDiver) -> None:
        """One slate body per marker id his orders will show."""
        executor = self.team.divers[diver.agent.name].executor  # type: ignore[union-attr]
        ids: set[int] = set()
        for order in executor.orders:
            if isinstance(order, od.Signal) and order.channel == "marker":
                ids.add(diver.performer.marker_id(Command.parse(order.name)))
        for marker_id in sorted(ids):
            slate = MarkerSlate(marker_id, diver.performer.markers.dictionary,
                                diver.performer.markers.marker_size_m)
            name = f"{diver.agent.name}/slate{marker_id}"
            self.scene.add_dynamic(name, slate.mesh(), "slate", slate.material(),
                                   SLATE_AWAY_NED, np.eye(3))
            diver.slates[marker_id] = name

    # ------------------------------------------------------------------ the tick
    def perform(self, t: float) -> None:
        """The divers start the signals their orders say, and hold up their slates."""
        for diver in self.divers.values():
            body = self.team.divers[diver.agent.name]  # type: ignore[union-attr]
            steps = body.executor.steps
            while diver.seen_steps < len(steps):
                step = steps[diver.seen_steps]
                diver.seen_steps += 1
                order = step.order
                if isinstance(order, od.Signal) and order.channel == "marker":
                    diver.slate_due = (step.started, Command.parse(order.name))
                elif isinstance(order, od.Signal) and order.channel is not None:
                    diver.performer.signal(step.started, Command.parse(order.name),
                                           order.channel)  # type: ignore[arg-type]
            if diver.slate_due is not None and (self._ready(diver) or
                                                t >= diver.slate_due[0] + SLATE_READY_S):
                diver.performer.signal(t, diver.slate_due[1], "marker")
                diver.slate_due = None
            nav = diver.agent.nav()
            if diver.watcher is not None and (diver.slate_due is not None
                                              or diver.performer.performing(t) is not None):
                self._face(diver, diver.watcher.nav().position_ned)
            held = diver.performer.slate_id(t)
            held = held if held in diver.slates else None
            if diver.shown is not None and diver.shown != held:  # put away (once)
                self.scene.set_pose(diver.slates[diver.shown], SLATE_AWAY_NED, np.eye(3))
            if held is not None:
                self.scene.set_pose(diver.slates[held],
                                    slate_position(nav.position_ned, nav.yaw), rot_z(nav.yaw))
            diver.shown = held

    def read(self, pings: Mapping[str, Any], images: Mapping[str, Any]) -> None:
        """Feed this tick's camera frames and pings to the readers."""
        for v in self.vehicles:
            frame = images.get(v.camera_key) if v.camera_key else None
            ping = pings.get(v.sonar_key) if v.sonar_key and v.readers.sonar else None
            if frame is None and ping is None:
                continue
            track = self._track(v, 0.0)
            if frame is not None:
                in_view = self._diver_in_view(track, frame)
                said = v.readers.camera(frame, self._slate_near(v, track), in_view)
                if said and not in_view:
                    for r in said:
                        self.record("assistant", f"{v.agent.name}: {r.command} ({r.channel}) "
                                    "ignored: the diver is not in the camera's view")
                else:
                    v.heard += said
            if ping is not None:
                v.heard += v.readers.ping(ping, *self._in_ping(v, track))

    @staticmethod
    def _slate_near(v: AssistedVehicle, track: DiverTrack | None
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Where the marker reader expects his slate, from the track the assistant uses
        (NED point, margin m north, east, down): held up ahead of his chest; on the
        sonar's track, which has neither his heading nor his depth, anywhere his arm
        holds it around him, ``SLATE_SEARCH_DEPTH_M`` up and down (None: no track)."""
        if track is None:
            return None
        if v.section.track == "truth":
            yaw = math.radians(track.heading_deg)
            return (slate_position(track.position_ned, yaw),
                    np.full(3, SEARCH_MARGIN_M))
        reach = SLATE_AHEAD_M + SEARCH_MARGIN_M + track.speed * track.age_s
        return track.position_ned, np.array([reach, reach, SLATE_SEARCH_DEPTH_M])

    @staticmethod
    def _diver_in_view(track: DiverTrack | None, frame: Any) -> bool:
        """Whether the diver's chest (on the track the assistant uses) is in the camera's
        field of view: a camera signal read with him out of view is someone else's, or
        the reader's mistake (it still counts as false in the metrics)."""
        if track is None:
            return False
        chest = track.position_ned - np.array([0.0, 0.0, CHEST_ABOVE_PELVIS_M])
        ahead, right, down = frame.rotation_ned_from_camera.T @ (chest - frame.position_ned)
        height, width = frame.rgb.shape[:2]
        return bool(ahead > 0.0
                    and abs(right) / ahead <= 0.5 * width / frame.K[0, 0]
                    and abs(down) / ahead <= 0.5 * height / frame.K[1, 1])

    @staticmethod
    def _in_ping(v: AssistedVehicle, track: DiverTrack | None
                 ) -> tuple[float | None, float | None]:
        """The diver's range (m) and bearing (rad, > 0 starboard) from the ROV, from the
        track the assistant uses (None when there is none)."""
        if track is None:
            return None, None
        nav = v.agent.nav()
        d = track.position_ned[:2] - nav.position_ned[:2]
        bearing = math.atan2(d[1], d[0]) - nav.yaw
        return float(np.hypot(*d)), math.atan2(math.sin(bearing), math.cos(bearing))

    def step(self, tick: int, t: float) -> None:
        """The assistant's tick of every ROV whose helm is due (before its helm)."""
        for v in self.vehicles:
            if tick % v.agent.driver_period == 0:
                self._assist(v, t)
            self._diver_takes(v, t)

    def _assist(self, v: AssistedVehicle, t: float) -> None:
        nav = v.agent.nav()
        track = self._track(v, t)
        rov = RovNav(nav.position_ned, float(heading_deg_from_yaw(nav.yaw)), float(nav.speed))
        heard, v.heard = tuple(v.heard), []
        out = v.assistant.step(AssistantInputs(t, rov, track, self._gripper(v), heard,
                                               self._tool_points(v), self._site_points(v)))
        community = v.agent.community
        for var, value in out.posts:
            community.post(var, value, t, "assistant")
        if out.gripper_command is not None:
            shared = bool(self._gripper(v).shared_with)
            command = "give" if out.gripper_command == "open" and shared else out.gripper_command
            community.post("GRIPPER", command, t, "assistant")
        for event in out.events:
            self.record("assistant", f"{v.agent.name}: {event}")
            if event.startswith("say again?"):
                self._say_again(v, t)
        truth = self._truth(v.diver)
        body, head = separations(nav.position_ned, truth)
        v.min_body_m, v.min_head_m = min(v.min_body_m, body), min(v.min_head_m, head)

    def _say_again(self, v: AssistedVehicle, t: float) -> None:
        """The diver's side of the ROV's "say again?": waiting for a tool from the ROV
        (his order a ``wait_until`` it is in his hand) and within ``CUE_SEEN_M`` of it,
        he makes his last signal again (its channel: he turns to the ROV, rises, shows
        the slate or makes the gesture), at most ``REPEATS_MAX`` times in one wait; each
        repeat is a signal issued (the metrics count it)."""
        diver = v.diver
        executor = self.team.divers[diver.agent.name].executor  # type: ignore[union-attr]
        steps = executor.steps
        gap = diver.agent.nav().position_ned - v.agent.nav().position_ned
        if not (diver.receiving and steps and float(np.linalg.norm(gap)) <= CUE_SEEN_M):
            return
        wait = len(steps) - 1
        done = diver.repeats[1] if diver.repeats[0] == wait else 0
        last = next((s.order for s in reversed(steps) if isinstance(s.order, od.Signal)
                     and s.order.channel is not None), None)
        if last is None or done >= REPEATS_MAX or diver.slate_due is not None or (
                diver.performer.performing(t) is not None):
            return
        command = Command.parse(last.name)
        if last.channel == "marker":
            diver.slate_due = (t, command)
        else:
            diver.performer.signal(t, command, last.channel)  # type: ignore[arg-type]
        diver.repeats, diver.repeated = (wait, done + 1), diver.repeated + 1
        self.record("teamwork", f"{diver.agent.name} repeats {command} ({last.channel}) on "
                    f"{v.agent.name}'s 'say again?'")

    def after_helm(self, agent: Agent, t: float) -> None:
        """After ``agent``'s helm has run this tick: while its assistant overrides the
        helm, its DESIRED_* again. A helm that is just parked posts DESIRED_* = 0 once
        (pHelmIvP's all-stop): heading north and depth 0 for a tick, which turned the
        backing ROV 50° off the diver; a pilot app posting after the helm wins, as the
        assistant's postings do here."""
        for v in self.vehicles:
            if v.agent is agent and v.assistant.trace:
                out = v.assistant.trace[-1]
                for var, value in out.posts:
                    if var.startswith("DESIRED_"):
                        agent.community.post(var, value, t, "assistant")

    def _truth(self, diver: SignallingDiver) -> DiverTrack:
        """The diver as the simulation has him: body centre, head, right hand."""
        agent = diver.agent
        nav = agent.nav()
        body = self.team.divers[agent.name]  # type: ignore[union-attr]
        pose = pose_matrix(nav.position_ned, nav.yaw)
        head_rest = np.array([0.0, 0.0, body.skeleton.body.head_centre_z, 1.0])
        head = pose @ body.skeleton.link_transforms(body.q)["head"] @ head_rest
        hand = pose @ np.append(body.skeleton.grip_point(body.q, "right"), 1.0)
        return DiverTrack(nav.position_ned, float(heading_deg_from_yaw(nav.yaw)),
                          float(nav.speed), 0.0, head[:3], hand[:3])

    def _track(self, v: AssistedVehicle, t: float) -> DiverTrack | None:
        if v.section.track == "truth":
            truth = self._truth(v.diver)
            return DiverTrack(truth.position_ned, truth.heading_deg, truth.speed, 0.0,
                              truth.head_ned)  # his hand: held out (DiverTrack's default)
        observer = next(o for o in self.contacts.observers if o.agent is v.agent)
        frame = observer.frame
        report = frame.diver_track if frame is not None else None
        if report is None:
            return None
        own = v.agent.nav().position_ned
        return DiverTrack(np.array([report.north, report.east, own[2]]), observer.heading,
                          float(report.speed), max(0.0, t - frame.t) + report.coast_s)

    def _gripper(self, v: AssistedVehicle) -> GripperStatus:
        ws = self.team.workspace  # type: ignore[union-attr]
        actor = f"{v.agent.name}/gripper"
        slot = self.team.grippers[v.agent.name]  # type: ignore[union-attr]
        held = ws.held_by(actor)
        said = {name: said for said, name in v.tools.items()}
        others = tuple(h for h in ws.holders_of(held) if h != actor) if held else ()
        return GripperStatus(slot.state.phase, said.get(held, held) if held else None, others)

    def _tool_points(self, v: AssistedVehicle) -> dict[str, NDArray[np.float64]]:
        """Grasp points of the tools no diver holds, by the commands' tool names."""
        ws = self.team.workspace  # type: ignore[union-attr]
        free = {}
        for said, name in v.tools.items():
            holders = ws.holders_of(name)
            if all(h == f"{v.agent.name}/gripper" for h in holders):
                free[said] = ws.grasp_point(name)
        return free

    def _site_points(self, v: AssistedVehicle) -> dict[str, NDArray[np.float64]]:
        ws = self.team.workspace  # type: ignore[union-attr]
        return {name: np.asarray(od.target_point(ws, name), dtype=float) for name in v.sites}

    def _diver_takes(self, v: AssistedVehicle, t: float) -> None:
        """The diver's side of a hand-over (module docstring)."""
        ws = self.team.workspace  # type: ignore[union-attr]
        name = v.diver.agent.name
        body = self.team.divers[name]  # type: ignore[union-attr]
        order = body.executor.current
        held = ws.held_by(f"{v.agent.name}/gripper")
        v.diver.receiving = (isinstance(order, od.WaitUntil)
                             and order.state.startswith(f"held_by:{name}/"))
        if not (v.diver.receiving and held == order.subject):
            v.offered_since = None
            return
        hand_name = order.state.removeprefix("held_by:")
        side = "left" if hand_name.endswith("left_hand") else "right"
        if ws.held_by(hand_name) is not None:
            return
        nav = v.diver.agent.nav()
        view = DiverView(name, False, body.skeleton, body.q,
                         pose_matrix(nav.position_ned, nav.yaw))
        hand = view.hand(side)
        near = float(np.linalg.norm(ws.grasp_point(held) - self._held_out(v.diver))) \
            <= TAKE_REACH_M
        if not near:
            v.offered_since = None
            return
        if v.offered_since is None:
            v.offered_since = t
        elif t - v.offered_since >= TAKE_AFTER_S:
            ws.take(hand_name, held, hand.grip_frame())
            self.record("teamwork", f"{name} takes {held} from {v.agent.name}'s gripper")

    def _ready(self, diver: SignallingDiver) -> bool:
        """Whether he can show the slate: turned to the ROV within ``SLATE_FACING_DEG``
        and risen from his working posture to within ``SLATE_UPRIGHT_DEG`` of upright —
        before that his own trunk hides the slate, or it faces away from the camera."""
        agent = diver.agent
        if diver.watcher is not None:
            nav = agent.nav()
            d = diver.watcher.nav().position_ned[:2] - nav.position_ned[:2]
            off = math.atan2(d[1], d[0]) - nav.yaw
            if abs(math.atan2(math.sin(off), math.cos(off))) > math.radians(SLATE_FACING_DEG):
                return False
        body = self.team.divers[agent.name]  # type: ignore[union-attr]
        trunk = [abs(float(body.q[body.skeleton.index(j)])) for j in ("posture", "waist")]
        return max(trunk) <= math.radians(SLATE_UPRIGHT_DEG)

    @staticmethod
    def _face(diver: SignallingDiver, point: NDArray[np.float64]) -> None:
        """He turns on the spot to face ``point`` (NED) while he signals: the teamwork
        stage's directive for his plant, replaced until its next tick."""
        agent = diver.agent
        nav = agent.nav()
        d = point[:2] - nav.position_ned[:2]
        error = math.atan2(d[1], d[0]) - nav.yaw
        error = math.atan2(math.sin(error), math.cos(error))
        agent.directed = agent.model.diver.directed_inputs(
            agent.plant, agent.state, 0.0, FACE_TURN_GAIN * error, float(nav.position_ned[2]))

    @staticmethod
    def _held_out(diver: SignallingDiver) -> NDArray[np.float64]:
        """Where the diver holds his hand out for a tool: DiverTrack's hand (NED, m)."""
        nav = diver.agent.nav()
        return DiverTrack(nav.position_ned, float(heading_deg_from_yaw(nav.yaw))).hand

    # ------------------------------------------------------------------ results
    def summary(self) -> dict[str, Any]:
        """metrics.json's ``assistant`` section, by assisted vehicle (docs/hri.md)."""
        collisions = self.collisions()
        out: dict[str, Any] = {}
        for v in self.vehicles:
            performer = v.diver.performer
            issued = [IssuedSignal(p.t, p.command, p.channel, p.duration_s)
                      for p in performer.issued]
            metrics = signal_metrics(issued, v.readers.said, v.assistant.trace)
            executor = self.team.divers[v.diver.agent.name].executor  # type: ignore[union-attr]
            steps = executor.steps
            done = executor.finished and not executor.failed
            now = v.assistant.trace[-1].t if v.assistant.trace else 0.0
            metrics |= {
                "diver": v.diver.agent.name,
                "diver_waiting_s": round(sum(
                    (s.ended if s.ended is not None else now) - s.started for s in steps
                    if isinstance(s.order, od.WaitUntil)), 3),
                "task_completion_s": round(steps[-1].ended, 3) if done and steps else None,
                "steps": {"done": sum(s.outcome == "done" for s in steps),
                          "failed": sum(s.outcome == "failed" for s in steps),
                          "orders": len(executor.orders)},
                "min_separation_m": {"body": round(v.min_body_m, 3),
                                     "head": round(v.min_head_m, 3),
                                     "body_guard": v.assistant.config.body_guard_m,
                                     "head_guard": v.assistant.config.head_guard_m},
                "collisions": collisions,
                "signals_repeated": v.diver.repeated,
            }
            out[v.agent.name] = metrics
        return {"assistant": out}
