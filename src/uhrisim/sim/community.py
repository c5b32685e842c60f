"""A MOOS-like community: one variable store per agent, with per-reader mailboxes.

Every component of an agent (helm, controller, contact manager, bridges, recorder) reads
and writes variables here in the MOOS vocabulary (NAV_X east, NAV_Y north, NAV_HEADING
compass degrees, DESIRED_*, NODE_REPORT, mode variables such as DEPLOY).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

Value = str | float

__all__ = ["Mailbox", "Post", "Value"]


class Post(NamedTuple):
    """One posting: variable, value, simulation time (s), and who posted it (immutable;
    a named tuple: every post is logged, and a tuple is made several times faster than a
    frozen dataclass)."""

    community: str
    var: str
    value: Value
    t: float
    source: str


#: Variables whose every posting matters (one per contact): mailboxes keep them all, in
#: order, as a list; for every other variable the latest value wins.
ACCUMULATED_VARS = frozenset({"NODE_REPORT"})


class Mailbox:
    """Variables changed since the reader last drained."""

    def __init__(self) -> None:
        self._pending: dict[str, Value | list[Value]] = {}

    def deliver(self, var: str, value: Value) -> None:
        if var in ACCUMULATED_VARS:
            self._pending.setdefault(var, []).append(value)  # type: ignore[union-attr]
        else:
            self._pending[var] = value

    def drain(self) -> dict[str, Value | list[Value]]:
        mail, self._pending = self._pending, {}
        return mail


def _normalised(value: Value | bool | int) -> Value:
    """A posted value as the store keeps it: a bool as MOOS's "true"/"false", an int as a
    float, a str or float as given."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return float(value)
    return value


class Community:
    """Variable store of one agent. ``post`` reaches every mailbox and the post log."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._values: dict[str, Value] = {}
        self._mailboxes: list[Mailbox] = []
        self._log: list[Post] = []

    def mailbox(self) -> Mailbox:
        """A new reader that will see every later post (and the current values)."""
        box = Mailbox()
        for var, value in self._values.items():
            box.deliver(var, value)
        self._mailboxes.append(box)
        return box

    def post(self, var: str, value: Value | bool | int, t: float, source: str) -> None:
        value = _normalised(value)
        self._values[var] = value
        for box in self._mailboxes:
            box.deliver(var, value)
        self._log.append(Post(self.name, var, value, t, source))

    def post_many(self, posts: Iterable[tuple[str, Value | bool | int]], t: float,
                  source: str) -> None:
        """:meth:`post` each (variable, value) of ``posts`` in order, in one call (the
        same values, deliveries and log: a tick's NAV_* and a helm's posts)."""
        values, boxes, log, name = self._values, self._mailboxes, self._log, self.name
        for var, value in posts:
            value = _normalised(value)
            values[var] = value
            for box in boxes:
                box.deliver(var, value)
            log.append(Post(name, var, value, t, source))

    def get(self, var: str, default: Value | None = None) -> Value | None:
        return self._values.get(var, default)

    def values(self) -> dict[str, Value]:
        """A copy of every variable's latest value."""
        return dict(self._values)

    def take_log(self) -> list[Post]:
        """Posts since the last call (for hooks that record or forward them)."""
        log, self._log = self._log, []
        return log
