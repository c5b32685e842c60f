"""Behavior base class, common IvP parameters, and the per-tick context behaviors read.

Common parameters (IvP ``IvPBehavior::setParam``, IvPBehavior.cpp:178-324; a leading
``_`` is ignored, case does not matter): ``name`` (alias ``descriptor``; letters, digits
and ``_-[]()#@+``), ``pwt``/``priwt``/``priority`` (0 to 10^6, default 100), ``condition``
(repeatable, AND-ed), ``endflag``, ``runflag``, ``idleflag``, ``activeflag``,
``inactiveflag``, ``spawnflag`` (repeatable ``VAR = value``; also spelt ``end_flag``...),
``updates`` (variable whose "param=value # ..." postings update the behavior at run time),
``duration`` (s >= 0, or -1 / ``no-time-limit`` for none; 0 completes the behavior at its
first running iteration; default none, but 0 for ConstantDepth as in pHelmIvP),
``duration_idle_decay`` (default true: the clock runs while idle too), ``perpetual``
(default false: completion ends the behavior for good), ``templating`` (exactly ``spawn``
or ``clone``: a template; ``disallow`` or anything else: not), ``max_spawnings`` (a
template's limit, 0 = none). Display-only parameters (``visual_hints``,
``bearing_line_config``, ``bearing_lines``) are kept in ``display`` and do not affect
decisions. Flag values may use ``$[CONTACT]``, ``$[OWNSHIP]``, ``$[BHVNAME]``.

States (IvP): *idle* (conditions false), *running* (conditions true), *active* (running and
producing an objective), *completed*.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar, NamedTuple

from uhrisim.autonomy.conditions import Condition, Value, parse_condition
from uhrisim.autonomy.domain import Domain, Objective
from uhrisim.autonomy.params import (
    Flag,
    parse_flag,
    to_bool,
    to_float,
    to_priority,
    to_str,
)
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned

__all__ = [
    "COMMON_HANDLERS",
    "NAME_CHARS",
    "Behavior",
    "BehaviorContext",
    "CommonParams",
    "ContactInfo",
    "OwnNav",
    "common_key",
    "valid_name",
]

log = logging.getLogger(__name__)


def common_key(key: str) -> str:
    """A parameter name as IvP matches it: lower case, a leading ``_`` dropped."""
    k = str(key).strip().lower()
    return k[1:] if k.startswith("_") else k


@dataclass(frozen=True)
class CommonParams:
    """Parameters every IvP behavior accepts (see module docstring)."""

    name: str = ""
    priority: float = 100.0
    conditions: tuple[Condition, ...] = ()
    endflags: tuple[Flag, ...] = ()
    runflags: tuple[Flag, ...] = ()
    idleflags: tuple[Flag, ...] = ()
    activeflags: tuple[Flag, ...] = ()
    inactiveflags: tuple[Flag, ...] = ()
    updates: str = ""
    duration: float = -1.0
    duration_idle_decay: bool = True
    perpetual: bool = False
    templating: str = ""
    max_spawnings: int = 0
    spawnflags: tuple[Flag, ...] = ()
    display: tuple[tuple[str, str], ...] = ()


def _append(field_name: str, conv: Callable[[object, str, str], Any]) -> Callable:
    def apply(p: CommonParams, v: object, key: str, where: str) -> CommonParams:
        vals = v if isinstance(v, list | tuple) else [v]
        new = tuple(conv(x, key, where) for x in vals)
        return replace(p, **{field_name: getattr(p, field_name) + new})

    return apply


def _set(field_name: str, conv: Callable[[object, str, str], Any]) -> Callable:
    def apply(p: CommonParams, v: object, key: str, where: str) -> CommonParams:
        return replace(p, **{field_name: conv(v, key, where)})

    return apply


def _templating(v: object, key: str, where: str) -> str:
    """``spawn`` and ``clone`` (exactly so) make a template, anything else an ordinary
    behavior, as pHelmIvP (BehaviorSpec.cpp:122-135 ignores other words, with a warning)."""
    s = to_str(v, key, where)
    if s in ("spawn", "clone"):
        return "spawn"
    if s != "disallow":
        log.warning("%s: templating = %s is not spawn/clone/disallow: pHelmIvP ignores it, "
                    "the behavior is not a template", where, s)
    return ""


def _duration(v: object, key: str, where: str) -> float:
    """Seconds >= 0, or -1 / ``no-time-limit`` for none (IvPBehavior.cpp:285-296)."""
    if isinstance(v, str) and v.strip() in ("no-time-limit", "-1"):
        return -1.0
    x = to_float(v, key, where)
    if x < 0 and x != -1.0:
        raise ConfigError(f"{key} must be >= 0, -1 or no-time-limit, got {v!r}", where)
    return x


def _max_spawnings(v: object, key: str, where: str) -> int:
    x = to_float(v, key, where)
    if x < 0 or x != int(x):
        raise ConfigError(f"{key} must be a whole number >= 0, got {v!r}", where)
    return int(x)


def _display(p: CommonParams, v: object, key: str, where: str) -> CommonParams:
    vals = v if isinstance(v, list | tuple) else [v]
    return replace(p, display=p.display + tuple((key, to_str(x, key, where)) for x in vals))


def _cond(v: object, key: str, where: str) -> Condition:
    return parse_condition(str(v), where)


NAME_CHARS = frozenset("_-[]()#@+")
"""Besides letters and digits, what a behavior name may hold (IvPBehavior.cpp:136-144)."""


def valid_name(s: str) -> bool:
    return bool(s) and all(c.isalnum() or c in NAME_CHARS for c in s)


def _name(v: object, key: str, where: str) -> str:
    s = to_str(v, key, where)
    if not valid_name(s):
        raise ConfigError(
            f"behavior name must be letters, digits and {''.join(sorted(NAME_CHARS))}, "
            f"got {v!r}", where,
        )
    return s


_FLAGS = {
    "endflag": "endflags",
    "runflag": "runflags",
    "idleflag": "idleflags",
    "activeflag": "activeflags",
    "inactiveflag": "inactiveflags",
    "spawnflag": "spawnflags",
}

COMMON_HANDLERS: dict[str, Callable] = {
    "name": _set("name", _name),
    "descriptor": _set("name", _name),
    **{k: _set("priority", to_priority) for k in ("pwt", "priwt", "priority")},
    "condition": _append("conditions", _cond),
    **{k: _append(f, parse_flag) for k, f in _FLAGS.items()},
    **{k.replace("flag", "_flag"): _append(f, parse_flag) for k, f in _FLAGS.items()},
    "updates": _set("updates", to_str),
    "duration": _set("duration", _duration),
    "duration_idle_decay": _set("duration_idle_decay", to_bool),
    "perpetual": _set("perpetual", to_bool),
    "templating": _set("templating", _templating),
    "max_spawnings": _set("max_spawnings", _max_spawnings),
    # display-only (pMarineViewer rendering): kept in the config, no effect on decisions
    "visual_hints": _display,
    "bearing_line_config": _display,
    "bearing_lines": _display,
}


class OwnNav(NamedTuple):
    """Own ship in MOOS terms: x east, y north (m), heading compass deg, speed m/s, depth m.
    (A named tuple: made at every helm iteration, it costs a fifth of a frozen
    dataclass.)"""

    x: float
    y: float
    heading: float
    speed: float
    depth: float = 0.0

    @classmethod
    def from_ned(
        cls, north: float, east: float, down: float, yaw_rad: float, speed: float
    ) -> OwnNav:
        """From the simulator's NED state (docs/conventions.md): yaw is the compass heading."""
        x, y = moos_xy_from_ned(north, east)
        return cls(float(x), float(y), float(heading_deg_from_yaw(yaw_rad)), speed, down)

    def mail(self) -> dict[str, float]:
        """The NAV_* variables a helm reads."""
        return {
            "NAV_X": self.x,
            "NAV_Y": self.y,
            "NAV_HEADING": self.heading,
            "NAV_SPEED": self.speed,
            "NAV_DEPTH": self.depth,
        }


class ContactInfo(NamedTuple):
    """A contact as the helm's ledger holds it: its last NODE_REPORT (x east, y north m,
    heading compass deg, speed m/s, depth m, ``t_report`` the report's TIME, s). (A named
    tuple, as :class:`OwnNav`: one is made for every report.)"""

    name: str
    x: float
    y: float
    heading: float
    speed: float
    depth: float
    t_report: float


@dataclass
class BehaviorContext:
    """What a behavior sees in one helm tick: time, domain, info buffer, own nav, the
    helm's contact ledger (contacts by NODE_REPORT name, exact case); its posts."""

    t: float
    domain: Domain
    info: Mapping[str, Value]
    own: OwnNav | None
    contacts: Mapping[str, ContactInfo] = field(default_factory=dict)
    posts: list[tuple[str, Value]] = field(default_factory=list)

    def post(self, var: str, value: Value) -> None:
        self.posts.append((var, value))

    def contact(self, name: str) -> ContactInfo | None:
        """Contact ``name`` as last reported (exact case, as pHelmIvP's ledger), else None."""
        return self.contacts.get(name)


class Behavior:
    """Base of all behaviors. Subclasses set ``KIND``, ``Params`` and ``HANDLERS``.

    ``on_run`` returns an :class:`Objective` normalised to 0..100 (or None: nothing to say);
    it may scale its priority for this tick through ``self.priority_scale`` (AvoidCollision's
    relevance) and call :meth:`complete`.
    """

    KIND: ClassVar[str] = ""
    Params: ClassVar[type] = object
    HANDLERS: ClassVar[dict[str, Callable]] = {}
    CONTACT_BASED: ClassVar[bool] = False
    DEFAULT_DURATION: ClassVar[float] = -1.0  # s; -1 = no limit (IvPBehavior.cpp:69)

    def __init__(self, common: CommonParams, params: Any) -> None:
        self.common = common
        self.params = params
        self.priority_scale = 1.0
        self.complete_requested = False
        self.reset()

    @property
    def name(self) -> str:
        return self.common.name

    def reset(self) -> None:
        """Reset run-time state (construction, and after a perpetual behavior completes)."""

    def complete(self) -> None:
        self.complete_requested = True

    def set_param(self, key: str, value: object, where: str) -> None:
        """Apply one parameter (load time or an ``updates`` posting); unknown -> ConfigError."""
        k = common_key(key)
        if k in COMMON_HANDLERS:
            self.common = COMMON_HANDLERS[k](self.common, value, k, where)
        elif k in self.HANDLERS:
            self.params = self.HANDLERS[k](self.params, value, k, where)
            self.on_params_changed(k)
        else:
            raise ConfigError(f"{self.KIND} has no parameter {key!r}", where)

    def on_params_changed(self, key: str) -> None:
        """Hook: a parameter changed at run time."""

    def on_run_start(self, ctx: BehaviorContext) -> None:
        """Hook: transition idle -> running (not a behavior running from the helm's first
        iteration: pHelmIvP's onIdleToRunState)."""

    def on_idle(self, ctx: BehaviorContext) -> None:
        """Hook: called each tick the behavior is idle."""

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        raise NotImplementedError
