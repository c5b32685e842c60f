"""A simulation hook that attaches agents to MOOS communities (``uhrisim run FILE --moos``).

Each tick the hook (a read-only observer, like the recorder) posts the linked agents'
navigation to their MOOS community at ``nav_rate_hz`` (simulated time) and feeds what the
community posts back (DESIRED_*, mode variables, ...) into the agent's own community
through :meth:`Simulation.post` - the typed input path every outside command uses, applied
at the start of the next tick. Connection changes are recorded as ``bridge`` events.

An agent whose contacts come from its sonar (``contacts.source: sonar``) also has what
its perception posts forwarded to its community, as a sonar-tracking MOOS process would
post it: the diver's NODE_REPORT (``SOURCE=sonar``, its TIME on the MOOS clock),
``DIVER_LOST`` and the search updates (docs/perception.md).

An agent the community drives (``driver: external`` or ``none``, its link taking DESIRED_*)
is watched: the bridge also takes pHelmIvP's IVPHELM_STATE, IVPHELM_ALLSTOP, BHV_ERROR and
BHV_WARNING, and an :class:`~uhrisim.bridges.helm_watch.OutsideHelmWatch` says, in a
warning line and a ``bridge`` event, when that helm does not drive (MALCONFIG, parked, an
all-stop, no DESIRED_*, no connection); metrics.json's ``moos`` section has what it saw.

The hook does not pace the loop: to run in step with a live community, pace the
simulation at MOOSTimeWarp x real time (e.g. ``uhrisim.sim.pacing.Pacer``), and
switch off the agent's built-in helm so that the MOOS helm's DESIRED_* are obeyed.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from uhrisim.autonomy.contacts import format_node_report, parse_node_report
from uhrisim.bridges.helm_watch import (
    HELM_STATUS_VARS,
    OutsideHelmWatch,
    driven_from_outside,
    say_loudly,
)
from uhrisim.bridges.moos.bridge import MoosAgentBridge
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw
from uhrisim.scenario.schema import HelmWatchSection
from uhrisim.sim.hooks import TickFrame
from uhrisim.sim.simulation import BaseHook, Simulation

__all__ = ["MoosAgentLink", "MoosBridgeHook"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MoosAgentLink:
    """How one simulated agent meets its MOOS community.

    ``nav_rate_hz``: NAV_*/NODE_REPORT posting rate in simulated time (uSimMarine posts
    every AppTick, typically 10 Hz). ``subscribe``/``extra_vars``: variables taken back
    and posted into the agent's community (``subscribe`` ones must be finite numbers;
    anything else is dropped with a warning so a stray post cannot crash the run).
    ``vehicle_type``/``length``: NODE_REPORT TYPE and LENGTH (m). ``node_report_var``:
    the variable the report goes to (``NODE_REPORT_LOCAL``, pNodeReporter's name, when
    pShare forwards it to other communities as their NODE_REPORT).
    """

    agent: str
    port: int = 9000
    host: str = "127.0.0.1"
    community: str | None = None
    nav_rate_hz: float = 10.0
    subscribe: tuple[str, ...] = ("DESIRED_HEADING", "DESIRED_SPEED", "DESIRED_DEPTH")
    extra_vars: tuple[str, ...] = ()
    vehicle_type: str = "UUV"
    length: float = 1.0
    node_report_var: str = "NODE_REPORT"


class MoosBridgeHook(BaseHook):
    """One :class:`MoosAgentBridge` per link, driven by the simulation's ticks.

    ``lat_origin``/``long_origin`` default to the scenario's. ``strict=True`` makes an
    unreachable MOOSDB an error at start; otherwise the bridges keep retrying.
    Connection changes are noted (``bridge`` events) at the nav rate; incoming mail is
    read every tick. ``helm_watch``: how an outside helm that does not drive is reported
    (module docstring; default: the scenario schema's defaults).
    """

    def __init__(
        self,
        links: Sequence[MoosAgentLink],
        *,
        lat_origin: float | None = None,
        long_origin: float | None = None,
        time_warp: float = 1.0,
        time_source: str = "moos",
        strict: bool = False,
        helm_watch: HelmWatchSection | None = None,
        bridge_factory: Callable[..., MoosAgentBridge] = MoosAgentBridge,
    ) -> None:
        names = [link.agent for link in links]
        if len(set(names)) != len(names):
            raise ConfigError(f"MOOS links: an agent is linked twice: {names}")
        self.links = tuple(links)
        self._origin = (lat_origin, long_origin)
        self._time_warp = time_warp
        self._time_source = time_source
        self._strict = strict
        self._factory = bridge_factory
        self._watch_settings = helm_watch or HelmWatchSection()
        self.watches: dict[str, OutsideHelmWatch] = {}
        self.bridges: dict[str, MoosAgentBridge] = {}
        self._rows: list[tuple[MoosAgentLink, MoosAgentBridge, int]] = []
        self._was_connected: dict[str, bool] = {}
        self._sim: Simulation | None = None
        self.n_in = 0
        self.n_rejected = 0

    def on_start(self, sim: Simulation) -> None:
        self._sim = sim
        lat0 = self._origin[0] if self._origin[0] is not None else sim.scenario.lat_origin
        lon0 = self._origin[1] if self._origin[1] is not None else sim.scenario.long_origin
        for link in self.links:
            if link.agent not in sim.agents:
                raise ConfigError(f"MOOS link names unknown agent {link.agent!r}; agents: "
                                  f"{', '.join(sim.agents)}")
            if link.nav_rate_hz <= 0:
                raise ConfigError(f"MOOS link {link.agent!r}: nav_rate_hz must be > 0")
            period = max(1, round(1.0 / (link.nav_rate_hz * sim.dt)))  # ticks
            watched = driven_from_outside(sim.agents[link.agent]) and any(
                v.startswith("DESIRED_") for v in link.subscribe)
            extra = (*link.extra_vars, *HELM_STATUS_VARS) if watched else link.extra_vars
            self.bridges[link.agent] = self._factory(
                link.agent, link.host, link.port, link.community, lat0, lon0,
                self._time_warp, link.subscribe, extra,
                time_source=self._time_source, strict=self._strict,
                node_report_var=link.node_report_var)
            if watched:
                self.watches[link.agent] = self._watch(sim, link)
            self._was_connected[link.agent] = False
            self._rows.append((link, self.bridges[link.agent], period))

    def _watch(self, sim: Simulation, link: MoosAgentLink) -> OutsideHelmWatch:
        """The watch of an agent the community drives, started now."""
        where = f"community {link.community!r}" if link.community else "the community"
        address = f"{link.host}:{link.port}"

        def hint(state: str | None) -> str:
            return "" if state is not None else (
                f" and no IVPHELM_STATE either: is pHelmIvP running in {where} at {address}?")

        watch = OutsideHelmWatch(f"MOOS {where}" if link.community else
                                 f"MOOS link of {link.agent!r}", "DESIRED_*",
                                 self._watch_settings, say_loudly(sim, log), hint)
        watch.start(sim.t)
        return watch

    def on_tick(self, frame: TickFrame) -> None:
        sim = self._sim
        if sim is None:
            return
        tick = frame.tick
        for link, bridge, period in self._rows:
            if bridge.client.has_mail:  # usually not: nothing came in
                self._take_mail(sim, link, bridge, frame.t)
            for post in frame.posts:
                if post.source == "sonar" and post.community == link.agent:
                    self._forward_sonar(bridge, post.var, post.value, post.t)
            if tick % period:
                continue
            name = link.agent  # a nav tick: post (the snapshot is taken only now) ...
            snap = frame.agents[name]
            nav = snap.nav
            north, east, down = nav.position_ned.tolist()
            bridge.publish_nav(frame.t, north, east, down,
                               float(heading_deg_from_yaw(nav.yaw)), nav.speed,
                               link.vehicle_type, link.length, _mode(snap.mode))
            up = bridge.connected  # ... and note a connection that came or went
            if up != self._was_connected[name]:
                self._was_connected[name] = up
                sim.record_event("bridge", f"moos {name}: {bridge.status}")
            watch = self.watches.get(name)
            if watch is not None:
                watch.connection(up, frame.t, bridge.status)
                watch.check(frame.t)

    @staticmethod
    def _forward_sonar(bridge: MoosAgentBridge, var: str, value: Any, t: float) -> None:
        """Post one of the sonar contacts' postings to the community (a NODE_REPORT with
        its TIME moved from simulation time to the MOOS clock)."""
        if var == "NODE_REPORT":
            report = parse_node_report(str(value))
            value = format_node_report(replace(report, time=bridge.moos_time(t)))
        bridge.publish_var(var, value, t)

    def _take_mail(self, sim: Simulation, link: MoosAgentLink, bridge: MoosAgentBridge,
                   t: float) -> None:
        """Post what the community sent into the agent's community (typed input path);
        the watch (if any) hears of commands and of the helm's state at ``t`` (s)."""
        name = link.agent
        watch = self.watches.get(name)
        for var, value, _t in bridge.poll():
            if watch is not None:
                if var in HELM_STATUS_VARS:
                    watch.helm_status(var, value, t)
                elif var.startswith("DESIRED_") and var in link.subscribe:
                    watch.command(t)
            accepted = _accept(value, numeric=var in link.subscribe)
            if accepted is None:
                self.n_rejected += 1
                log.warning("MOOS %s: ignoring %s = %r (not a finite number)", name, var, value)
                continue
            sim.post(name, var, accepted, source="moos")
            self.n_in += 1

    def on_end(self, sim: Simulation, error: BaseException | None) -> None:
        del sim, error
        for bridge in self.bridges.values():
            bridge.close()

    def summary(self) -> dict[str, Any]:
        t = self._sim.t if self._sim is not None else 0.0
        out: dict[str, Any] = {}
        for name, b in self.bridges.items():
            client = b.client
            out[name] = {"connected": b.connected, "status": b.status, "sent": client.n_sent,
                         "received": client.n_received,
                         "connection_attempts": client.n_attempts,
                         "refusals": client.n_refusals,
                         "reconnects": max(0, client.n_connects - 1)}
            if name in self.watches:
                out[name]["helm"] = self.watches[name].summary(t)
        return {"moos": out}


def _accept(value: float | str | bytes, numeric: bool) -> float | str | None:
    """What may enter the community store: the subscribed DESIRED_* must be finite numbers
    (a string that parses as one is accepted, as MOOS apps do); binary data never enters."""
    if isinstance(value, bytes):
        return None
    if not numeric:
        return value
    try:
        number = float(value)
    except ValueError:
        return None
    return number if math.isfinite(number) else None


def _mode(mode: str) -> str:
    """A helm mode as a NODE_REPORT MODE value (no ',' or '=')."""
    text = str(mode).replace(",", ";").replace("=", ":")
    return text or "NONE"
