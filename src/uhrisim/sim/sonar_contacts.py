"""Contact reports from an agent's own sonar (``contacts.source: sonar``).

Every ping of the observer's sonar (``contacts.sonar.sensor``, default its first) goes
through its :class:`SonarPerception` (detect → blobs → track → classify). At the contacts
rate the track taken for the diver becomes a
NODE_REPORT for the observer's contact manager, as pHelmIvP would get it from a
sonar-tracking process: ``NAME=<name>,X,Y`` (MOOS x east, y north, from the track),
``SPD``/``HDG`` from the track's velocity (the heading is held while the speed is below
0.1 m/s, where it means nothing), ``DEP`` = own depth (an imaging sonar measures no
elevation; the 20° beam saw the diver, so it is near own depth), ``TYPE``, ``TIME``, and
``SOURCE=sonar,TRACK=<id>``. While the track coasts (no detection) its reported speed
decays linearly to 0 over ``max_coast`` s, so the trail slows down rather than running
on.

Losing and finding the diver (what a MOOS-IvP user scripts with conditions): when the
diver track is dropped (or no ping has come for ``max_coast`` s), no more reports are
sent (the helm keeps the last one until its ledger lets it go), ``<lost_var> = true`` is
posted with ``<search_var> = points=<x>,<y>`` — the last track position, for a reacquire
behavior (e.g. a BHV_Waypoint with ``updates = DIVER_SEARCH_UPDATES`` and ``condition =
DIVER_LOST = true`` that turns toward it); when a diver track is held again,
``<lost_var> = false``. Each of these, a damaged ping (non-finite cells), a diver track
leaving the fan and a long silence (no detection for ``silence_warn`` s) is a logged
simulation event.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from uhrisim.autonomy.contacts import node_report_text
from uhrisim.core.clock import ticks_for_rate
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned
from uhrisim.scenario.load import ScenarioFile
from uhrisim.scenario.schema import SonarContactsConfig
from uhrisim.sim.hooks import sensor_key
from uhrisim.sim.state import Agent

if TYPE_CHECKING:  # perception (OpenCV) is imported where an agent has sonar contacts
    from uhrisim.perception.pipeline import PerceptionFrame, PerceptionParams, SonarPerception
    from uhrisim.sensors.sonar.ping import SonarPing

MIN_HEADING_SPEED = 0.1  # m/s: below it a track's heading is noise; the last one is held


def perception_params(cfg: SonarContactsConfig, source: ScenarioFile, where: str
                      ) -> PerceptionParams:
    """The perception settings a scenario's ``contacts.sonar`` section asks for."""
    from uhrisim.perception.blobs import BlobParams
    from uhrisim.perception.classify import DiverClassifier
    from uhrisim.perception.detect import DetectorParams
    from uhrisim.perception.pipeline import PerceptionParams
    from uhrisim.perception.tracker import TrackerParams

    def given(**values: object) -> dict[str, object]:
        """The settings the scenario gives (the others keep the perception's defaults)."""
        return {k: v for k, v in values.items() if v is not None}

    confirm = cfg.confirm or (None, None)
    top: dict[str, object] = given(diver_probability=cfg.diver_probability)
    if cfg.diver_probability is not None:
        top["keep_probability"] = min(PerceptionParams.keep_probability,
                                      cfg.diver_probability)
    if cfg.classifier is not None:
        top["classifier"] = DiverClassifier.load(source.resolve(cfg.classifier))
    try:
        return PerceptionParams(
            detector=DetectorParams(**given(k_sigma=cfg.k_sigma, min_contrast=cfg.min_contrast,
                                            min_level=cfg.min_level,
                                            min_range_m=cfg.min_range)),
            blobs=BlobParams(**given(min_cells=cfg.min_cells,
                                     merge_radius_m=cfg.merge_radius)),
            tracker=TrackerParams(**given(confirm_m=confirm[0], confirm_n=confirm[1],
                                          max_coast_s=cfg.max_coast,
                                          accel_std=cfg.accel_std)),
            **top)
    except ConfigError as error:
        raise ConfigError(str(error), where) from None


@dataclass
class _Observer:
    """Perception and reporting state of one observing agent."""

    agent: Agent
    config: SonarContactsConfig
    perception: SonarPerception
    period: int
    key: str  # the sensor key of the sonar it reads ("<agent>/<sensor>")
    frame: PerceptionFrame | None = None
    held: bool = False
    last_xy: tuple[float, float] | None = None
    heading: float = 0.0
    last_detection_t: float = 0.0
    silent: bool = False
    outside: bool = False


class SonarContacts:
    """Runs perception on the observers' pings and posts their sonar contacts.

    ``record_event(kind, detail)``: the simulation's event log.
    """

    def __init__(self, agents: Mapping[str, Agent], dt: float, source: ScenarioFile,
                 record_event: Callable[[str, str], None]) -> None:
        self._record = record_event
        self.observers: list[_Observer] = []
        for index, agent in enumerate(agents.values()):
            cfg = agent.config.contacts
            if agent.config.driver != "helm" or cfg.source != "sonar":
                continue
            where = source.where("agents", index, "contacts")
            if not agent.sonars:
                raise ConfigError(
                    f"agent {agent.name!r} takes its contacts from its sonar, but it has no "
                    "sonar (add one under 'sensors', and do not switch sonars off)", where)
            params = perception_params(cfg.sonar, source, where)
            from uhrisim.perception.pipeline import SonarPerception  # (OpenCV: only here)
            sonar = agent.config.perception_sonar
            self.observers.append(_Observer(
                agent, cfg.sonar, SonarPerception(params),
                ticks_for_rate(cfg.rate_hz, dt, f"agents.{agent.name}.contacts.rate_hz"),
                sensor_key(agent.name, str(sonar))))

    def step(self, tick: int, t: float, pings: Mapping[str, SonarPing]
             ) -> dict[str, PerceptionFrame]:
        """Process this tick's pings (time ``t``, s; by sensor key) and post the reports
        that are due; returns the perception frames of this tick by the key of the ping."""
        frames: dict[str, PerceptionFrame] = {}
        for obs in self.observers:
            ping = pings.get(obs.key)
            if ping is not None:
                obs.frame = frames[obs.key] = self._perceive(obs, ping, t)
            if tick % obs.period == 0 and obs.frame is not None:
                self._report(obs, t)
        return frames

    def _perceive(self, obs: _Observer, ping: SonarPing, t: float) -> PerceptionFrame:
        frame = obs.perception.process(ping)
        name = obs.agent.name
        if frame.bad_cells:
            self._record("perception", f"{name}: ping at t={ping.t:.2f} s had "
                         f"{frame.bad_cells} non-finite cells (read as no echo)")
        if frame.blobs.blobs:
            obs.last_detection_t, obs.silent = t, False
        elif not obs.silent and t - obs.last_detection_t >= obs.config.silence_warn:
            obs.silent = True
            self._record("perception", f"{name}: no sonar detection for "
                         f"{t - obs.last_detection_t:.0f} s")
        return frame

    def _report(self, obs: _Observer, t: float) -> None:
        assert obs.frame is not None
        cfg, agent = obs.config, obs.agent
        community = agent.community
        # No ping for longer than a track may coast (the sonar stopped): the track is gone.
        fresh = t - obs.frame.t <= obs.perception.params.tracker.max_coast_s
        track = obs.frame.diver_track if fresh else None
        if track is None:
            if obs.held:
                obs.held = False
                x, y = obs.last_xy if obs.last_xy is not None else (0.0, 0.0)
                community.post(cfg.lost_var, "true", t, "sonar")
                community.post(cfg.search_var, f"points={x:.2f},{y:.2f}", t, "sonar")
                self._record("perception", f"{agent.name}: diver track lost; last seen at "
                             f"x={x:.2f}, y={y:.2f} (MOOS x east, y north)")
            return
        if not obs.held:
            obs.held = True
            community.post(cfg.lost_var, "false", t, "sonar")
            self._record("perception", f"{agent.name}: diver held by sonar track {track.id}")
        if not track.visible and not obs.outside:
            self._record("perception", f"{agent.name}: diver track {track.id} left the "
                         "sonar fan; coasting")
        obs.outside = not track.visible
        if track.speed >= MIN_HEADING_SPEED:
            obs.heading = float(heading_deg_from_yaw(math.atan2(track.v_east, track.v_north)))
        max_coast = obs.perception.params.tracker.max_coast_s
        speed = track.speed * max(0.0, 1.0 - track.coast_s / max_coast)
        x, y = moos_xy_from_ned(track.north, track.east)
        obs.last_xy = (float(x), float(y))
        nav = agent.nav()
        community.post("NODE_REPORT", node_report_text(
            cfg.name, round(float(x), 3), round(float(y), 3), round(speed, 3),
            round(obs.heading, 2), round(float(nav.position_ned[2]), 3),
            type=cfg.vehicle_type, time=round(t, 3),
            extra=(("SOURCE", "sonar"), ("TRACK", str(track.id)))), t, "sonar")
