"""Events: every change of an object's or a site's state, and every act, with its reason.

Work sites (:mod:`uhrisim.world.worksites`), the workspace and the acts of
:mod:`uhrisim.teamwork` return lists of :class:`WorldEvent`; the simulation records them
(the recording's events topic) and the metrics count them (grasp attempts and successes,
objects dropped, task steps).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

_LINE = re.compile(r"^t=(?P<t>\S+) s (?:(?P<actor>\S+): )?(?P<failed>FAILED )?"
                   r"(?P<kind>\S+) (?P<subject>\S+)(?: \((?P<reason>.*)\))?$")


@dataclass(frozen=True)
class WorldEvent:
    """One thing that happened.

    Attributes:
        t: simulation time (s).
        kind: what happened, a fixed word (``"bolt_loosened"``, ``"grasp"``, ...).
        subject: the object or site it happened to.
        actor: who did it (``"diver1/right_hand"``, ``"rov/gripper"``), "" for physics.
        ok: False for an act that failed.
        reason: why it failed, or a short note; one line.
        detail: numbers or names that go with it (progress, distances, holders).
    """

    t: float
    kind: str
    subject: str
    actor: str = ""
    ok: bool = True
    reason: str = ""
    detail: Mapping[str, float | str] = field(default_factory=dict)

    def line(self) -> str:
        """One human-readable line (logs, the viewer's event list)."""
        who = f"{self.actor}: " if self.actor else ""
        status = "" if self.ok else "FAILED "
        why = f" ({self.reason})" if self.reason else ""
        return f"t={self.t:.2f} s {who}{status}{self.kind} {self.subject}{why}"


def parse_line(text: str) -> WorldEvent | None:
    """The event a :meth:`WorldEvent.line` text tells (None if it is not one): time (to
    10 ms), kind, subject, actor, whether it failed and the reason; the details are not
    in the line."""
    m = _LINE.match(text)
    if m is None:
        return None
    return WorldEvent(float(m["t"]), m["kind"], m["subject"], m["actor"] or "",
                      m["failed"] is None, m["reason"] or "")
