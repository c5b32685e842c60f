"""Hierarchical mode declarations (pHelmIvP ``set MODE = VALUE { conditions } ELSEVALUE``).

Example (the authors' ``meta_vehicle.bhv``)::

    set MODE = ACTIVE {
      DEPLOY = true
    } INACTIVE

    set MODE = TRAILING {
      MODE = ACTIVE
      TRAIL = true
    } LOITERING

Entries are evaluated in file order every helm tick, building each mode variable afresh.
An entry's conditions on its own mode variable are its *parent gate* (IvP's mode prefix);
like every condition they compare with the value built so far this tick - ``MODE =
ACTIVE`` is exact, so it holds for "ACTIVE" but no longer once a sibling made it
"ACTIVE:RETURNING": the first matching sibling wins (IvP ``ModeSet::evaluate``). If all
conditions hold the value is set, prefixed by the parent ("ACTIVE:TRAILING"); if only the
gate holds the else-value is (also prefixed); an entry with no gate sets the value
outright. Behavior conditions then usually test the mode with ``==``, IvP's field match
(``MODE == TRAILING`` holds for "ACTIVE:TRAILING", see :mod:`conditions`); inside a mode
declaration ``==`` is refused, as pHelmIvP refuses it. A mode variable that no entry sets
this tick keeps its value (the helm does not post it: ModeSet.cpp:66).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property

from uhrisim.autonomy.conditions import Condition, Value, parse_condition, values_read
from uhrisim.core.errors import ConfigError

__all__ = ["ModeEntry", "ModeEvaluator", "evaluate_modes", "parse_mode_entry"]

_ENTRY = re.compile(
    r"^\s*(?:set\s+)?(?P<var>[A-Za-z_][\w\-]*)\s*=\s*(?P<val>[^\s{}]+)\s*"
    r"(?:\{(?P<body>[^{}]*)\}\s*(?P<else>[^\s{}]*)\s*)?$",
    re.IGNORECASE | re.DOTALL,
)


@dataclass(frozen=True)
class ModeEntry:
    """One ``set VAR = VALUE { conditions } ELSEVALUE`` declaration."""

    var: str
    value: str
    conditions: tuple[Condition, ...] = ()
    else_value: str | None = None
    where: str = field(default="", compare=False)

    def variables(self) -> set[str]:
        return set().union(*(c.variables() for c in self.conditions)) if self.conditions else set()

    @cached_property
    def _split(self) -> tuple[tuple[Condition, ...], tuple[Condition, ...], tuple[str, ...]]:
        """(parent-gate conditions, the others, other variables they read) - fixed per entry."""
        gate = tuple(c for c in self.conditions if self.var in c.variables())
        rest = tuple(c for c in self.conditions if self.var not in c.variables())
        return gate, rest, tuple(sorted(self.variables() - {self.var}))


def parse_mode_entry(text: str, where: str = "modes") -> ModeEntry:
    """Parse one mode declaration; conditions in braces are separated by newlines or ';'."""
    m = _ENTRY.match(str(text))
    if not m:
        raise ConfigError(f"cannot read mode declaration {' '.join(str(text).split())!r}", where)
    body = m.group("body") or ""
    if "==" in body:  # pHelmIvP refuses it (ModeEntry.cpp:121-125: MALCONFIG)
        raise ConfigError("'==' is not allowed in a mode declaration: use '='", where)
    conds = tuple(parse_condition(c, where) for c in re.split(r"[;\n]", body) if c.strip())
    return ModeEntry(m.group("var"), m.group("val"), conds, m.group("else") or None, where)


def evaluate_modes(entries: tuple[ModeEntry, ...], info: Mapping[str, Value]) -> dict[str, str]:
    """Mode variable values for this tick (see module docstring)."""
    built: dict[str, str] = {}
    for e in entries:
        gate, rest, reads = e._split
        # the conditions read only their own variables: the env holds just those (info's
        # values, except that the mode variables built so far this tick replace them)
        env = {k: info[k] for k in reads if k in info and k not in built}
        env.update(built)
        if gate and e.var not in built:
            continue
        if not all(c.evaluate(env) for c in gate):
            continue
        value = e.value if all(c.evaluate(env) for c in rest) else e.else_value
        if value is None:
            continue
        built[e.var] = f"{built[e.var]}:{value}" if gate else value
    return built


class ModeEvaluator:
    """:func:`evaluate_modes` of fixed ``entries``, redone only when a variable they read
    changed (the values are a function of those variables alone); the returned dict is
    shared between calls: read it, do not change it."""

    def __init__(self, entries: tuple[ModeEntry, ...]) -> None:
        self.entries = entries
        self._reads = tuple(sorted({v for e in entries for v in e._split[2]}))
        self._read: tuple[object, ...] | None = None
        self._built: dict[str, str] = {}

    def __call__(self, info: Mapping[str, Value]) -> dict[str, str]:
        read = values_read(info, self._reads)
        if read != self._read:
            self._built, self._read = evaluate_modes(self.entries, info), read
        return self._built
