"""A small kinematic world for the assistant's tests (written here, first principles).

The assistant (:class:`uhrisim.assistant.Assistant`) and the real helm (uhrisim's
pHelmIvP-style ``Helm`` reading the shipped ``assistant/data/assistant.bhv``) run at
4 Hz, exchanging MOOS mail exactly as the simulation will: the assistant's postings, the
ROV's NAV_* and the diver's NODE_REPORT (while he is seen) go to the helm; the helm's
DESIRED_* go to the ROV — or, while the assistant overrides, its own DESIRED_*.

* ROV: a point with a heading that turns toward DESIRED_HEADING at ``turn_rate`` (deg/s,
  the short way, in place too), a speed along the heading (negative astern) that relaxes
  first-order (time constant ``tau``) to DESIRED_SPEED, a depth moving toward
  DESIRED_DEPTH at ``dive_rate``; integrated at 20 Hz.
* Diver: scripted, ``script(t) -> DiverState``: a diver (pelvis position, heading,
  speed, how far his trunk leans forward from upright: 90° swimming prone), whether his
  hand is held out, whether the ROV sees him. His head (DiverTrack's 0.71 m from the
  pelvis, tilted by the lean) and hand follow DiverTrack's body geometry.
* Gripper: the VideoRay manipulator's assumed numbers (jaws 0.25 m ahead and 0.14 m
  below the centre, 1.5 s to close or open, an object taken when its grasp point is
  within 3 cm of the jaws as they close). A held tool moves with the jaws.
* The diver grips an object held out to him (if his script lets him) when his hand is
  out and the jaws are within 0.15 m of it for 1 s; when the gripper then opens, the
  object is his.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources

import numpy as np

from uhrisim.assistant import (
    HELM_DOMAIN,
    Assistant,
    AssistantConfig,
    AssistantInputs,
    DiverTrack,
    GripperStatus,
    RovNav,
)
from uhrisim.assistant.geometry import jaw_offset, separations
from uhrisim.autonomy import Helm, NodeReport, format_node_report, load_bhv, parse_domain
from uhrisim.autonomy.helm import as_mail
from uhrisim.perception.signals import Command, RecognizedSignal

DT = 0.05
HELM_EVERY = 5  # steps: 4 Hz
CLOSE_S = 1.5
CAPTURE_M = 0.03
DIVER_REACH_M = 0.15
DIVER_REACTION_S = 1.0


@dataclass(frozen=True)
class DiverState:
    position: tuple[float, float, float]
    heading: float
    speed: float = 0.0
    hand_out: bool = True
    seen: bool = True
    grips: bool = True  # takes what is held out to him
    lean_deg: float = 0.0  # his trunk's lean forward from upright (90: prone, swimming)

    def head(self) -> np.ndarray:
        """His head (NED, m): DiverTrack's height above the pelvis, leant forward."""
        lean, h = math.radians(self.lean_deg), math.radians(self.heading)
        tilt = np.array([math.sin(lean) * math.cos(h), math.sin(lean) * math.sin(h),
                         -math.cos(lean)])
        return np.array(self.position, dtype=float) + DiverTrack.HEAD_ABOVE_M * tilt


def hovering(position=(6.0, 0.0, 4.0), heading=180.0, **kw) -> Callable[[float], DiverState]:
    return lambda t: DiverState(position, heading, **kw)


@dataclass
class Rov:
    position: np.ndarray
    heading: float
    speed: float = 0.0
    turn_rate: float = 45.0
    tau: float = 1.0
    dive_rate: float = 0.3

    def step(self, desired: dict[str, float], dt: float) -> None:
        err = (desired.get("DESIRED_HEADING", self.heading) - self.heading + 180.0) % 360.0 - 180.0
        self.heading = (self.heading + float(np.clip(err, -self.turn_rate * dt,
                                                     self.turn_rate * dt))) % 360.0
        v = float(desired.get("DESIRED_SPEED", 0.0))
        self.speed += (v - self.speed) * (1.0 - math.exp(-dt / self.tau))
        dz = float(desired.get("DESIRED_DEPTH", self.position[2])) - self.position[2]
        self.position[2] += float(np.clip(dz, -self.dive_rate * dt, self.dive_rate * dt))
        h = math.radians(self.heading)
        self.position[:2] += self.speed * dt * np.array([math.cos(h), math.sin(h)])


@dataclass
class Record:
    t: float
    rov: np.ndarray
    speed: float
    desired_speed: float
    body: float  # separation from the diver's body segment (m)
    head: float  # ... from his head
    override: bool


@dataclass
class World:
    script: Callable[[float], DiverState]
    rov: Rov = field(default_factory=lambda: Rov(np.array([0.0, 0.0, 3.0]), 0.0))
    tools: dict[str, np.ndarray] = field(default_factory=dict)
    sites: dict[str, np.ndarray] = field(default_factory=dict)
    signals: dict[float, Command] = field(default_factory=dict)  # t -> command (gesture)
    #: the ROV's own readers, called every helm tick: (world, diver) -> signals read
    perceive: Callable[[World, DiverState], tuple[RecognizedSignal, ...]] | None = None
    config: AssistantConfig = field(default_factory=AssistantConfig)

    def __post_init__(self) -> None:
        self.assistant = Assistant(self.config)
        path = resources.files("uhrisim.assistant").joinpath("data/assistant.bhv")
        with resources.as_file(path) as bhv:
            self.helm = Helm(load_bhv(bhv, domain=parse_domain(list(HELM_DOMAIN))), "videoray")
        self.t = 0.0
        self.desired: dict[str, float] = {}
        self.override = False
        self.phase, self.travel = "open", 0.0
        self.holding: str | None = None
        self.diver_has: set[str] = set()
        self.diver_near_since: float | None = None
        self.shared = False
        self.track: DiverTrack | None = None
        self.records: list[Record] = []
        self.helm_outputs: list = []

    # -------------------------------------------------------------------- pieces
    def diver_track(self, d: DiverState) -> DiverTrack | None:
        if d.seen:
            up = np.array([0.0, 0.0, -1.0])
            h = math.radians(d.heading)
            fwd = np.array([math.cos(h), math.sin(h), 0.0])
            pos = np.array(d.position, dtype=float)
            hand = (pos + DiverTrack.HAND_AHEAD_M * fwd + DiverTrack.HAND_ABOVE_M * up
                    if d.hand_out else pos + 0.25 * np.cross(fwd, -up) + 0.1 * up)
            self.track = DiverTrack(pos, d.heading, d.speed, 0.0, d.head(), hand)
        elif self.track is not None:  # the last track, ageing
            old = self.track
            self.track = DiverTrack(old.position_ned, old.heading_deg, old.speed,
                                    old.age_s + DT * HELM_EVERY, old.head_ned, old.hand_ned)
        return self.track

    def jaws(self) -> np.ndarray:
        return self.rov.position + jaw_offset(self.rov.heading, self.config)

    def gripper(self, command: str | None, d: DiverState) -> None:
        if command == "close" and self.phase in ("open", "opening"):
            self.phase = "closing"
        elif command == "open" and self.phase in ("closed", "closing"):
            self.phase = "opening"

    def advance_gripper(self, d: DiverState) -> None:
        if self.phase == "closing":
            self.travel = min(1.0, self.travel + DT / CLOSE_S)
            if self.travel >= 1.0:
                self.phase = "closed"
                free = [n for n, p in self.tools.items()
                        if n not in self.diver_has and np.linalg.norm(p - self.jaws()) <= CAPTURE_M]
                self.holding = free[0] if free else None
        elif self.phase == "opening":
            self.travel = max(0.0, self.travel - DT / CLOSE_S)
            if self.travel <= 0.0:
                self.phase = "open"
                if self.holding is not None and self.shared:
                    self.diver_has.add(self.holding)
                self.holding, self.shared = None, False
        if self.holding is not None:
            self.tools[self.holding] = self.jaws()
            track = self.track
            near = (d.seen and d.hand_out and d.grips and track is not None
                    and np.linalg.norm(self.jaws() - track.hand) <= DIVER_REACH_M)
            if not near:
                self.diver_near_since = None
            elif self.diver_near_since is None:
                self.diver_near_since = self.t
            elif self.t - self.diver_near_since >= DIVER_REACTION_S:
                self.shared = True

    # -------------------------------------------------------------------- loop
    def run(self, t_end: float, until: Callable[[World], bool] | None = None) -> World:
        steps = round((t_end - self.t) / DT)
        for _ in range(steps):
            d = self.script(self.t)
            k = round(self.t / DT)
            if k % HELM_EVERY == 0:
                self.tick(d)
            self.rov.step(self.desired, DT)
            self.advance_gripper(d)
            self.t = round(self.t + DT, 9)
            self.record(self.script(self.t))
            if until is not None and until(self):
                break
        return self

    def tick(self, d: DiverState) -> None:
        track = self.diver_track(d)
        due = [c for t, c in self.signals.items() if self.t - DT * HELM_EVERY < t <= self.t]
        signals = tuple(RecognizedSignal(c, "gesture", 0.9, self.t) for c in due)
        if self.perceive is not None:
            signals += self.perceive(self, d)
        status = GripperStatus(self.phase, self.holding, ("diver",) if self.shared else ())
        out = self.assistant.step(AssistantInputs(
            self.t, RovNav(self.rov.position.copy(), self.rov.heading, self.rov.speed), track,
            status, signals, dict(self.tools), dict(self.sites)))
        self.gripper(out.gripper_command, d)
        posts = dict(out.posts)
        if "MOOS_MANUAL_OVERRIDE" in posts:
            self.override = posts["MOOS_MANUAL_OVERRIDE"] == "true"
        nav = {"NAV_X": self.rov.position[1], "NAV_Y": self.rov.position[0],
               "NAV_HEADING": self.rov.heading, "NAV_SPEED": self.rov.speed,
               "NAV_DEPTH": self.rov.position[2]}
        if d.seen:
            nav["NODE_REPORT"] = format_node_report(NodeReport(
                "diver", d.position[1], d.position[0], d.speed, d.heading, d.position[2],
                time=self.t))
        helm_out = self.helm.step(self.t, as_mail(
            [(v, x) for v, x in out.posts if not v.startswith("DESIRED_")], base=nav))
        self.helm_outputs.append(helm_out)
        self.desired.update({v: float(x) for v, x in helm_out.posts if v.startswith("DESIRED_")})
        if self.override:  # the assistant's own DESIRED_* win
            self.desired.update({v: float(x) for v, x in out.posts if v.startswith("DESIRED_")})

    def record(self, d: DiverState) -> None:
        body, head = (math.inf, math.inf)
        if self.track is not None or d.seen:
            truth = DiverTrack(np.array(d.position, dtype=float), d.heading,
                               head_ned=d.head())
            body, head = separations(self.rov.position, truth)
        self.records.append(Record(self.t, self.rov.position.copy(), self.rov.speed,
                                   self.desired.get("DESIRED_SPEED", 0.0), body, head,
                                   self.override))

    # -------------------------------------------------------------------- views
    @property
    def trace(self):
        return self.assistant.trace

    def events(self) -> list[str]:
        return [e for out in self.trace for e in out.events]

    def actives(self) -> list[str]:
        """The distinct active paths in order (consecutive repeats collapsed)."""
        out: list[str] = []
        for o in self.trace:
            if not out or out[-1] != o.active:
                out.append(o.active)
        return out

    def min_separation(self) -> tuple[float, float]:
        return (min(r.body for r in self.records), min(r.head for r in self.records))
