"""Saying, loudly, when an agent's outside helm is not driving it (MOOS-IvP or ROS 2).

An agent with ``driver: external`` moves only when something outside sends it commands: a
real pHelmIvP over the MOOS bridge, a user's ROS 2 node. When that helm never drives - a
behavior file pHelmIvP rejected, a helm left parked, an all-stop, a node that never
started - the vehicle sits still and a run would otherwise end as if nothing were wrong.
One :class:`OutsideHelmWatch` per such agent watches what arrives and, in simulated time:

* ``IVPHELM_STATE = MALCONFIG``: said at once (pHelmIvP never recovers from it);
* ``IVPHELM_STATE`` PARK, STANDBY or DISABLED for ``silence_s`` (or while no command came
  for that long), or ``IVPHELM_ALLSTOP`` other than ``clear`` for ``silence_s``: said,
  naming the variable and its value (pHelmIvP all-stops for one iteration at start-up and
  while modes change; only a lasting one is news);
* no command for ``silence_s`` (from the start, or since the last one): said;
* for MOOS, no connection to the MOOSDB for ``silence_s``: said, with the client's status.

A problem is said once when it appears and again at most every ``repeat_s`` while it
lasts (``say``: the hook logs the line and records it as a ``bridge`` event). With
``required`` set, the first one ends the run instead: :class:`HelmSilentError`, which the
command line reports in one line with exit status 2 (the recording and metrics.json are
written, ``completed: false``). pHelmIvP's values: MOOS-IvP pHelmIvP/HelmIvP.cpp
(``postHelmStatus``, ``postAllStop``); docs/bridges-moos.md, docs/bridges-ros2.md.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from uhrisim.core.errors import BridgeError
from uhrisim.scenario.schema import HelmWatchSection

__all__ = ["HELM_STATUS_VARS", "HelmSilentError", "OutsideHelmWatch", "driven_from_outside",
           "say_loudly"]

#: What pHelmIvP posts about itself, watched in a MOOS community.
HELM_STATUS_VARS = ("IVPHELM_STATE", "IVPHELM_ALLSTOP", "BHV_ERROR", "BHV_WARNING")

#: Distinct BHV_ERROR / BHV_WARNING texts kept for metrics.json.
_KEEP_MESSAGES = 10


class HelmSilentError(BridgeError):
    """An outside helm did not drive its agent, and the run was asked to require it."""


def driven_from_outside(agent: Any) -> bool:
    """Whether a simulated agent moves only on outside commands (``driver: external`` or
    ``none``): the agents a bridge that takes commands for it watches."""
    return agent.config.driver in ("external", "none")


def say_loudly(sim: Any, logger: logging.Logger) -> Callable[[str], None]:
    """How a watch says a line: a warning of ``logger`` (the console) and a ``bridge``
    event of the simulation ``sim`` (the recording)."""

    def say(line: str) -> None:
        logger.warning("%s", line)
        sim.record_event("bridge", line)

    return say


class OutsideHelmWatch:
    """Watches one externally driven agent (module docstring). Times are simulated s.

    ``who`` opens every line (``MOOS community 'videoray'``); ``commands`` names what is
    awaited (``DESIRED_*``); ``hint(state)`` adds what to check when nothing arrives
    (``state``: the last IVPHELM_STATE, or None).
    """

    def __init__(self, who: str, commands: str, settings: HelmWatchSection,
                 say: Callable[[str], None],
                 hint: Callable[[str | None], str] = lambda state: "") -> None:
        self.who = who
        self.commands = commands
        self.settings = settings
        self._say = say
        self._hint = hint
        self._start: float | None = None
        self._gap_start = 0.0  # last command, or the start
        self._silent_s = 0.0  # gaps longer than silence_s, closed so far
        self.first_command_s: float | None = None
        self.n_commands = 0
        self._values: dict[str, tuple[str, float]] = {}  # status var -> (value, since)
        self.states_seen: dict[str, float] = {}  # IVPHELM_STATE value -> first seen
        self.allstops: dict[str, int] = {}  # IVPHELM_ALLSTOP value -> postings
        self.messages: list[str] = []  # distinct BHV_ERROR / BHV_WARNING texts
        self._link: tuple[bool, float, str] = (True, 0.0, "")  # (up, since, status)
        self._said: tuple[str, float] | None = None  # (kind, when) of the last line said
        self.n_warnings = 0
        self.last_warning: str | None = None

    # -- what arrives ---------------------------------------------------------------------
    def start(self, t: float) -> None:
        """The bridge is up at ``t``: from now on, commands are awaited."""
        self._start = self._gap_start = t
        self._link = (self._link[0], t, self._link[2])

    def command(self, t: float) -> None:
        """A command for the agent arrived at ``t``."""
        if t - self._gap_start >= self.settings.silence_s:
            self._silent_s += t - self._gap_start
        self._gap_start = t
        self.n_commands += 1
        if self.first_command_s is None:
            self.first_command_s = t

    def connection(self, up: bool, t: float, status: str) -> None:
        """The link to the outside peer is ``up`` (or not) as of ``t``."""
        if up != self._link[0]:
            self._link = (up, t, status)
        else:
            self._link = (up, self._link[1], status)

    def helm_status(self, var: str, value: object, t: float) -> None:
        """One of :data:`HELM_STATUS_VARS` posted by the helm at ``t``."""
        text = str(value).strip()
        if var in ("BHV_ERROR", "BHV_WARNING"):
            line = f"{var}={text}"
            if line not in self.messages and len(self.messages) < _KEEP_MESSAGES:
                self.messages.append(line)
        if var == "IVPHELM_STATE":
            self.states_seen.setdefault(text, t)
        elif var == "IVPHELM_ALLSTOP":
            self.allstops[text] = self.allstops.get(text, 0) + 1
        previous = self._values.get(var)
        if previous is None or previous[0] != text:
            self._values[var] = (text, t)

    # -- judging ------------------------------------------------------------------------
    def check(self, t: float) -> str | None:
        """The problem at ``t``, if there is one (said as the module docstring says)."""
        if self._start is None:
            return None
        found = self._problem(t)
        if found is None:
            self._said = None
            return None
        kind, line = found
        said = self._said
        if said is None or said[0] != kind or t - said[1] >= self.settings.repeat_s:
            self._said = (kind, t)
            self.n_warnings += 1
            self.last_warning = line
            if self.settings.required:
                raise HelmSilentError(f"{line} (the run requires its outside helm to drive)")
            self._say(line)
        return line

    def _problem(self, t: float) -> tuple[str, str] | None:
        silence = self.settings.silence_s
        up, since, status = self._link
        if not up and t - since >= silence:
            return "link", f"{self.who}: not connected for {t - since:.0f} s ({status})"
        state = self._values.get("IVPHELM_STATE")
        error = self._values.get("BHV_ERROR")
        detail = f" (BHV_ERROR={error[0]})" if error else ""
        if state is not None and state[0] == "MALCONFIG":
            return "state", (f"{self.who}: IVPHELM_STATE=MALCONFIG — pHelmIvP rejected its "
                             f"configuration (its behavior file, domain or settings); see its "
                             f"console{detail}")
        gap = t - self._gap_start
        if state is not None and state[0].rstrip("+") != "DRIVE" and (
                t - state[1] >= silence or gap >= silence):
            why = ("the helm is parked: deploy it with MOOS_MANUAL_OVERRIDE=false (uPokeDB, "
                   "pMarineViewer's DEPLOY)" if state[0].rstrip("+") == "PARK"
                   else "pHelmIvP is not driving")
            return "state", (f"{self.who}: IVPHELM_STATE={state[0]} for {t - state[1]:.0f} s "
                             f"— {why}")
        stop = self._values.get("IVPHELM_ALLSTOP")
        if stop is not None and stop[0].lower() != "clear" and t - stop[1] >= silence:
            return "allstop", (f"{self.who}: IVPHELM_ALLSTOP={stop[0]} for {t - stop[1]:.0f} s "
                               f"— pHelmIvP drives but decides nothing{detail}")
        if gap >= silence:
            since = ("since the start" if self.first_command_s is None
                     else f"since t={self._gap_start:.1f} s")
            hint = self._hint(None if state is None else state[0])  # a new hint: said anew
            return f"silence{hint}", f"{self.who}: no {self.commands} {since} ({gap:.0f} s){hint}"
        return None

    def summary(self, t: float) -> dict[str, Any]:
        """What was seen, for metrics.json (``t``: the end of the run, s)."""
        gap = t - self._gap_start if self._start is not None else 0.0
        silent = self._silent_s + (gap if gap >= self.settings.silence_s else 0.0)
        state = self._values.get("IVPHELM_STATE")
        return {"commands": self.n_commands, "first_command_s": self.first_command_s,
                "seconds_without_commands": silent,
                "helm_state": None if state is None else state[0],
                "helm_states_seen": dict(self.states_seen), "allstops": dict(self.allstops),
                "helm_messages": list(self.messages), "warnings": self.n_warnings,
                "last_warning": self.last_warning}
