"""Logic conditions of MOOS-IvP behaviors and mode entries (IvP ``LogicCondition``).

Grammar::

    expr     := and_expr (("or" | "||") and_expr)*
    and_expr := not_expr (("and" | "&&") not_expr)*
    not_expr := ("!" | "not") not_expr | "(" expr ")" | relation
    relation := VARIABLE op VALUE            op in  = == != < > <= >=

A VALUE is a number, a quoted string, a bare word (``true``, ``STATION-KEEPING``) or
``$(OTHER_VARIABLE)``. (IvP insists on parentheses around ``and``/``or`` operands; we
accept them without.) Evaluation against an info buffer (variable -> str | float)
follows IvP's ``ParseNode``:

* a relation on a variable nobody has posted is false (whatever the operator);
* number vs number compares numerically (``=`` and ``==`` alike);
* a string vs a number compares numerically if the string reads as a number, else the
  relation is false (``!=`` included);
* string vs string is case-sensitive: ``=`` is exact equality, ``==`` is a *field match*
  (one side equals a ``:``-separated run of components of the other, so
  ``MODE == TRAILING`` holds for "ACTIVE:TRAILING" while ``MODE = TRAILING`` does not),
  ``!=`` is exact inequality, ``< > <= >=`` compare lexically.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from uhrisim.core.errors import ConfigError

__all__ = [
    "And",
    "Condition",
    "HeldMemo",
    "Not",
    "Or",
    "Relation",
    "VarRef",
    "field_match",
    "literal",
    "parse_condition",
    "values_read",
]

Value = str | float


def literal(text: str) -> Value:
    """A MOOS value from text: float when numeric, else the string with quotes removed."""
    s = text.strip()
    if len(s) >= 2 and s[0] == s[-1] and s[0] in "\"'":
        return s[1:-1]
    try:
        return float(s)
    except ValueError:
        return s


def _as_number(v: object) -> float | None:
    if isinstance(v, bool):
        return None
    if isinstance(v, int | float):
        return float(v)
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            return None
    return None


@dataclass(frozen=True)
class VarRef:
    """A ``$(VARIABLE)`` on the right-hand side of a relation."""

    name: str


def field_match(a: str, b: str) -> bool:
    """IvP ``strFieldMatch``: the shorter ``:``-list is a contiguous run of the longer."""
    if a == b:
        return True
    if ":" not in a and ":" not in b:  # two one-field lists
        return False
    fa, fb = a.split(":"), b.split(":")
    short, long_ = (fa, fb) if len(fa) <= len(fb) else (fb, fa)
    n = len(short)
    return any(long_[i : i + n] == short for i in range(len(long_) - n + 1))


@dataclass(frozen=True)
class Relation:
    var: str
    op: str
    value: Value | VarRef

    def evaluate(self, info: Mapping[str, object]) -> bool:
        if self.var not in info:
            return False
        left = info[self.var]
        right: object = self.value
        if isinstance(right, VarRef):
            if right.name not in info:
                return False
            right = info[right.name]
        if type(left) is str and type(right) is str:  # the common case: no numbers involved
            if self.op == "=":
                return left == right
            if self.op == "==":
                return field_match(left, right)
            return _OPS[self.op](left, right)
        l_is_num = isinstance(left, (int, float)) and not isinstance(left, bool)
        r_is_num = isinstance(right, (int, float)) and not isinstance(right, bool)
        if l_is_num or r_is_num:
            ln, rn = _as_number(left), _as_number(right)
            if ln is None or rn is None:
                return False
            return _OPS["==" if self.op == "=" else self.op](ln, rn)
        ls, rs = str(left), str(right)
        if self.op == "=":
            return ls == rs
        if self.op == "==":
            return field_match(ls, rs)
        return _OPS[self.op](ls, rs)

    def variables(self) -> set[str]:
        return {self.var} | ({self.value.name} if isinstance(self.value, VarRef) else set())


@dataclass(frozen=True)
class And:
    items: tuple[Condition, ...]

    def evaluate(self, info: Mapping[str, object]) -> bool:
        return all(c.evaluate(info) for c in self.items)

    def variables(self) -> set[str]:
        return set().union(*(c.variables() for c in self.items))


@dataclass(frozen=True)
class Or:
    items: tuple[Condition, ...]

    def evaluate(self, info: Mapping[str, object]) -> bool:
        return any(c.evaluate(info) for c in self.items)

    def variables(self) -> set[str]:
        return set().union(*(c.variables() for c in self.items))


@dataclass(frozen=True)
class Not:
    item: Condition

    def evaluate(self, info: Mapping[str, object]) -> bool:
        return not self.item.evaluate(info)

    def variables(self) -> set[str]:
        return self.item.variables()


Condition = Relation | And | Or | Not

_UNSET = object()  # a variable not in the info buffer


def values_read(info: Mapping[str, object], names: tuple[str, ...]) -> tuple[object, ...]:
    """The values of ``names`` in ``info`` and their types: conditions on those variables
    give the same answer while this is equal (types too: 1.0 == True, but a relation
    tells them apart)."""
    values = tuple([info.get(name, _UNSET) for name in names])
    return values, tuple(map(type, values))


class HeldMemo:
    """Whether all ``conditions`` hold, evaluated again only when a variable they read
    changed (a behavior's run conditions, evaluated every helm iteration)."""

    def __init__(self, conditions: tuple[Condition, ...]) -> None:
        self.conditions = conditions
        self._reads = tuple(sorted(set().union(*(c.variables() for c in conditions))))
        self._read: tuple[object, ...] | None = None
        self._holds = True

    def __call__(self, info: Mapping[str, object]) -> bool:
        if not self.conditions:  # none: they hold
            return True
        read = values_read(info, self._reads)
        if read != self._read:
            self._holds, self._read = all(c.evaluate(info) for c in self.conditions), read
        return self._holds

_OPS: dict[str, Callable[[object, object], bool]] = {
    "==": lambda a, b: a == b,
    "!=": lambda a, b: a != b,
    "<": lambda a, b: a < b,  # type: ignore[operator]
    ">": lambda a, b: a > b,  # type: ignore[operator]
    "<=": lambda a, b: a <= b,  # type: ignore[operator]
    ">=": lambda a, b: a >= b,  # type: ignore[operator]
}

_TOKEN = re.compile(
    r"""\s*(?:
        (?P<var>\$\([A-Za-z_][A-Za-z0-9_]*\))
      | (?P<str>"[^"]*"|'[^']*')
      | (?P<op>==|!=|<=|>=|=|<|>)
      | (?P<lp>\()|(?P<rp>\))
      | (?P<andop>&&)|(?P<orop>\|\|)|(?P<bang>!)
      | (?P<word>[^\s()=!<>"']+)
    )""",
    re.VERBOSE,
)


@dataclass
class _Parser:
    text: str
    where: str
    tokens: list[tuple[str, str]] = field(default_factory=list)
    pos: int = 0

    def __post_init__(self) -> None:
        i, s = 0, self.text
        while i < len(s):
            if s[i:].strip() == "":
                break
            m = _TOKEN.match(s, i)
            if not m or m.end() == i:
                raise ConfigError(f"cannot read condition {s!r} at {s[i:]!r}", self.where)
            kind = m.lastgroup or ""
            tok = m.group(kind)
            if kind == "word" and tok.lower() in ("and", "or", "not"):
                kind = {"and": "andop", "or": "orop", "not": "bang"}[tok.lower()]
            self.tokens.append((kind, tok))
            i = m.end()

    def peek(self) -> str | None:
        return self.tokens[self.pos][0] if self.pos < len(self.tokens) else None

    def take(self) -> tuple[str, str]:
        if self.pos >= len(self.tokens):
            raise ConfigError(f"condition {self.text!r} ends too early", self.where)
        tok = self.tokens[self.pos]
        self.pos += 1
        return tok

    def expr(self) -> Condition:
        items = [self.and_expr()]
        while self.peek() == "orop":
            self.take()
            items.append(self.and_expr())
        return items[0] if len(items) == 1 else Or(tuple(items))

    def and_expr(self) -> Condition:
        items = [self.not_expr()]
        while self.peek() == "andop":
            self.take()
            items.append(self.not_expr())
        return items[0] if len(items) == 1 else And(tuple(items))

    def not_expr(self) -> Condition:
        kind = self.peek()
        if kind == "bang":
            self.take()
            return Not(self.not_expr())
        if kind == "lp":
            self.take()
            inner = self.expr()
            if self.take()[0] != "rp":
                raise ConfigError(f"missing ')' in condition {self.text!r}", self.where)
            return inner
        return self.relation()

    def relation(self) -> Relation:
        kind, var = self.take()
        if kind != "word":
            raise ConfigError(f"expected a variable in condition {self.text!r}", self.where)
        kind, op = self.take()
        if kind != "op":
            raise ConfigError(
                f"expected a comparison after {var!r} in condition {self.text!r}", self.where
            )
        kind, lit = self.take()
        if kind == "var":
            return Relation(var, op, VarRef(lit[2:-1]))
        if kind not in ("word", "str"):
            raise ConfigError(f"expected a value after {var}{op} in {self.text!r}", self.where)
        return Relation(var, op, literal(lit))


def parse_condition(text: str, where: str = "condition") -> Condition:
    """Parse one condition line into a frozen, comparable expression tree."""
    p = _Parser(str(text), where)
    if not p.tokens:
        raise ConfigError("empty condition", where)
    cond = p.expr()
    if p.pos != len(p.tokens):
        raise ConfigError(f"unexpected {p.tokens[p.pos][1]!r} in condition {text!r}", where)
    return cond
