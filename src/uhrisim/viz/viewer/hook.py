"""A simulation hook that drives the web viewer: frames out, page commands in.

``ViewerHook`` implements the simulation's hook protocol (``on_start(sim)``,
``on_tick(tick_frame)``, ``on_end(sim, error)``; see ``uhrisim.sim.simulation``). Each tick,
in the simulation thread, it:

1. applies the page's commands (``ViewerServer.drain_commands``): ``post`` →
   ``sim.post(agent, var, value, source="viewer")``; ``pause`` / ``resume`` / ``step`` /
   ``speed`` act on the run itself;
2. publishes a frame (``FrameBuilder``) at most ``server.max_fps`` times per wall second
   (the others are only observed, so no overlay posting or ping is lost);
3. paces simulated time to ``speed`` × wall time (``math.inf``: as fast as possible);
4. while paused, holds the simulation thread inside ``on_tick`` (re-publishing the
   paused frame and reading commands ``idle_hz`` times a second) until ``resume``, or
   lets exactly ``n`` ticks through on ``step n``.

Observing is read-only: the only ways this hook changes the run are the documented
command path (``Simulation.post``) and time (pausing and pacing). The clock and sleep
functions are injectable so the pacing logic is testable without wall-clock asserts.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import Any

from uhrisim.core.errors import ConfigError, UhrisimError
from uhrisim.sim.pacing import Pacer
from uhrisim.vehicles import MODELS
from uhrisim.viz.viewer.adapt import FrameBuilder
from uhrisim.viz.viewer.protocol import Command
from uhrisim.viz.viewer.team import TeamView

log = logging.getLogger(__name__)

#: Lag (s of wall time) beyond which pacing gives up catching up and re-anchors.
MAX_PACING_LAG_S = 0.25


class ViewerHook:
    """Publish the run to a ``ViewerServer`` and obey its page (see module docstring).

    Parameters
    ----------
    server:
        A started ``ViewerServer``.
    builder:
        Frame builder (overlay circles, kinds); default ``FrameBuilder()``.
    speed:
        Initial real-time factor (1 = real time; ``math.inf`` = as fast as possible).
    paused:
        Start paused (the page shows the first frame and waits for Resume or Step).
    idle_hz:
        How often a paused run re-publishes its frame and reads commands.
    rtf_window_s:
        Wall-time window over which the achieved real-time factor is measured.
    clock, sleep:
        Wall clock (s) and sleep function; injectable for tests.
    """

    def __init__(
        self,
        server: Any,
        builder: FrameBuilder | None = None,
        *,
        speed: float = 1.0,
        paused: bool = False,
        idle_hz: float = 20.0,
        rtf_window_s: float = 0.5,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not speed > 0:
            raise ConfigError(f"speed must be > 0 (math.inf: flat out), got {speed!r}",
                              "ViewerHook speed")
        self.server = server
        self.builder = builder if builder is not None else FrameBuilder()
        self.speed = float(speed)
        self.paused = bool(paused)
        self.selected: str | None = None
        self.rtf: float | None = None
        self._idle = 1.0 / idle_hz
        self._rtf_window = rtf_window_s
        self._clock = clock
        self._sleep = sleep
        self._period = 1.0 / float(getattr(server, "max_fps", 20.0))
        self._sim: Any = None
        self._steps = 0
        self._pacer = self._new_pacer()
        self._next_publish = -math.inf
        self._rtf_mark: tuple[float, float] | None = None
        self._ended = False

    # ------------------------------------------------------------------ hook protocol
    def on_start(self, sim: Any) -> None:
        self._sim = sim
        self._ended = False
        team = getattr(sim, "team", None)
        if team is not None and team.active and self.builder.team is None:
            self.builder.team = TeamView(team)

    def on_tick(self, frame: Any) -> None:
        if self._steps > 0:
            self._steps -= 1
        self._apply(self.server.drain_commands())
        now = self._clock()
        self._measure_rtf(now, frame.t)
        holding = self.paused and self._steps == 0
        if holding or now >= self._next_publish:
            self._publish(frame)
            self._next_publish = max(self._next_publish + self._period, now)
        else:
            self.builder.observe(frame)
        if not holding or self._released():
            self._pace(frame.t)
            return
        while self.paused and self._steps == 0 and not self._released():
            self._sleep(self._idle)
            self._apply(self.server.drain_commands())
            self._publish(frame)
        self._pacer = self._new_pacer()  # resume pacing from here, not catching up the pause
        self._rtf_mark = None

    def on_end(self, sim: Any, error: BaseException | None) -> None:
        self._ended = True

    def release(self) -> None:
        """Let a paused run go on without pausing again (thread-safe; e.g. on Ctrl-C)."""
        self._ended = True

    def _released(self) -> bool:
        return self._ended or getattr(self.server, "url", "") is None

    # ------------------------------------------------------------------ internals
    def _publish(self, frame: Any) -> None:
        self.server.publish(self.builder.build(
            frame, paused=self.paused and self._steps == 0, speed_factor=self.speed,
            rtf=0.0 if self.paused else self.rtf,
        ))

    def _apply(self, commands: list[Command]) -> None:
        for c in commands:
            if c.kind == "pause":
                self.paused = True
            elif c.kind == "resume":
                self.paused = False
                self._steps = 0
            elif c.kind == "step":
                if self.paused:
                    self._steps += int(c.value) if isinstance(c.value, float) else 1
            elif c.kind == "speed":
                if isinstance(c.value, float) and c.value > 0:
                    self.speed = c.value
                    self._pacer = self._new_pacer()
            elif c.kind == "select":
                self.selected = c.agent
            elif c.kind == "post":
                if self._sim is None:
                    log.warning("viewer: %s=%s for %s before the run started (dropped)",
                                c.name, c.value, c.agent)
                    continue
                try:
                    self._sim.post(c.agent, c.name, c.value, source="viewer")
                except UhrisimError as e:
                    log.warning("viewer button: %s", e)

    def _new_pacer(self) -> Pacer:
        """A pacer at the current speed (``math.inf`` runs free), anchored at its first tick."""
        return Pacer(self.speed, max_lag_s=MAX_PACING_LAG_S, clock=self._clock,
                     sleep=self._sleep)

    def _pace(self, t: float) -> None:
        """Sleep so that simulated time advances at ``speed`` × wall time."""
        self._pacer.wait(t)

    def _measure_rtf(self, now: float, t: float) -> None:
        if self._rtf_mark is None:
            self._rtf_mark = (now, t)
            return
        w0, t0 = self._rtf_mark
        if now - w0 >= self._rtf_window:
            self.rtf = (t - t0) / (now - w0)
            self._rtf_mark = (now, t)




def attach_viewer(
    sim: Any,
    *,
    host: str = "127.0.0.1",
    port: int = 8765,
    max_fps: float = 20.0,
    speed: float = 1.0,
    paused: bool = False,
) -> tuple[Any, ViewerHook]:
    """Serve ``sim`` (a ``Simulation``) in the viewer: start a server, attach a hook.

    Reads from the simulation's scenario: the scene (:func:`scene_from_world`), the
    buttons (``scenario.buttons``), the agents' kinds (``model``) and, as map circles,
    every contact-manager alert range (``agents[].contacts.alerts[].alert_range``, m).
    Returns ``(server, hook)``; ``server.url`` is the page; call ``server.close()`` after
    the run (and ``hook.release()`` first from another thread to end a paused run).
    """
    from uhrisim.viz.viewer.adapt import scene_from_world
    from uhrisim.viz.viewer.server import ViewerServer

    scenario = sim.scenario
    buttons = [{"label": b.label, "agent": b.agent, "var": b.var, "value": b.value}
               for b in getattr(scenario, "buttons", ())]
    circles: list[dict[str, Any]] = []
    kinds: dict[str, str] = {}
    for a in getattr(scenario, "agents", ()):
        model = MODELS.get(getattr(a, "model", ""))
        kinds[a.name] = model.viewer_kind if model is not None else "vehicle"
        seen: set[float] = set()
        for alert in getattr(getattr(a, "contacts", None), "alerts", ()):
            r = float(alert.alert_range)
            if r not in seen:
                seen.add(r)
                circles.append({"agent": a.name, "label": f"{alert.var} {r:g} m", "radius": r})
    server = ViewerServer(scene_from_world(sim.scene), buttons, host=host, port=port,
                          max_fps=max_fps)
    server.start()
    hook = ViewerHook(server, FrameBuilder(circles=circles, kinds=kinds), speed=speed,
                      paused=paused)
    sim.hooks.append(hook)
    if getattr(sim, "_started", False):
        hook.on_start(sim)
    log.info("viewer at %s", server.url)
    return server, hook
