"""Contact reports from simulation truth (as in the paper), optionally degraded.

Each observing agent receives, at its contacts rate, a NODE_REPORT of every other agent
(MOOS frame: x east, y north, compass heading), with Gaussian position noise, a fixed
latency and random dropout drawn from the observer's own random stream. Observers whose
``contacts.source`` is ``sonar`` get theirs from their own sonar instead
(:mod:`uhrisim.sim.sonar_contacts`).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from uhrisim.autonomy.contacts import node_report_text
from uhrisim.core.clock import ticks_for_rate
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned
from uhrisim.sim.state import Agent


def node_report_of(agent: Agent, t: float, position_noise: np.ndarray | None = None) -> str:
    """The NODE_REPORT string of ``agent`` at time ``t`` (truth plus optional noise, m);
    its parsed report is remembered for the helm that reads it."""
    nav = agent.nav()
    north, east = nav.position_ned[0], nav.position_ned[1]
    if position_noise is not None:
        north, east = north + position_noise[0], east + position_noise[1]
    x_east, y_north = moos_xy_from_ned(north, east)
    cfg = agent.config
    return node_report_text(
        agent.name, round(float(x_east), 3), round(float(y_north), 3), round(nav.speed, 3),
        round(float(heading_deg_from_yaw(nav.yaw)), 2), round(float(nav.position_ned[2]), 3),
        time=round(t, 3), type=cfg.vehicle_type or agent.model.vehicle_type,
        mode=str(agent.community.get("MODE", "")), length=cfg.length or agent.model.length,
        remember=True)  # the observer's helm reads it in this process


@dataclass(order=True)
class _Queued:
    deliver_at: float
    sequence: int
    observer: str
    report: str


class TruthContacts:
    """Delivers truth NODE_REPORTs to every helm-driven agent.

    ``agents``: the simulation's agents by name (read on every step); ``dt``: the
    physics step (s); ``rng(name)``: the named random stream of a component (each
    observer's noise and dropout come from ``"<observer>/contacts"``).
    """

    def __init__(self, agents: Mapping[str, Agent], dt: float,
                 rng: Callable[[str], np.random.Generator]) -> None:
        self._agents = agents
        observers = [a for a in agents.values()
                     if a.config.driver == "helm" and a.config.contacts.source == "truth"]
        #: per observer: its report period (ticks), contacts settings, random stream and
        #: whether its reports are degraded by dropout or noise (else the stream, its own,
        #: is not drawn from: nothing would change)
        self._observers = [
            (a, ticks_for_rate(a.config.contacts.rate_hz, dt,
                               f"agents.{a.name}.contacts.rate_hz"),
             a.config.contacts, rng(f"{a.name}/contacts"),
             a.config.contacts.dropout > 0.0 or a.config.contacts.position_noise_std > 0.0)
            for a in observers]
        self._queue: list[_Queued] = []
        self._sequence = 0
        self._dt = dt

    def next_due(self, tick: int) -> int:
        """A tick after ``tick`` no later than the first at which :meth:`step` has work
        (a report to send or to deliver); a tick or so early for a queued report."""
        due = math.inf
        for _, period, _, _, _ in self._observers:
            due = min(due, (tick // period + 1) * period)
        if self._queue:
            due = min(due, max(tick + 1, math.floor(self._queue[0].deliver_at / self._dt) - 1))
        return due

    def step(self, tick: int, t: float) -> None:
        """Send the reports due at ``tick`` (time ``t``, s) and deliver those whose
        latency has passed."""
        for observer, period, cfg, rng, degraded in self._observers:
            if tick % period:
                continue
            for target in self._agents.values():
                if target is observer:
                    continue
                noise = None
                if degraded:
                    dropped = rng.random() < cfg.dropout
                    noise = rng.normal(0.0, cfg.position_noise_std, 2)
                    if dropped:
                        continue
                report = node_report_of(target, t, noise if cfg.position_noise_std else None)
                self._sequence += 1
                heapq.heappush(self._queue, _Queued(t + cfg.latency, self._sequence,
                                                    observer.name, report))
        while self._queue and self._queue[0].deliver_at <= t + 1e-9:
            item = heapq.heappop(self._queue)
            self._agents[item.observer].community.post("NODE_REPORT", item.report, t,
                                                       "contacts")
