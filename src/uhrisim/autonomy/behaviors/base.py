"""Behavior base class, common IvP parameters, and the per-tick context behaviors read.

Common parameters (IvP ``IvPBehavior::setParam``): ``name``, ``pwt``/``priority``
(default 100), ``condition`` (repeatable, AND-ed), ``endflag``, ``runflag``, ``idleflag``,
``activeflag``, ``inactiveflag`` (repeatable ``VAR = value``), ``updates`` (variable whose
"param=value # ..." postings update the behavior at run time), ``duration`` (s, -1 = none),
``duration_idle_decay`` (default true: the clock runs while idle too), ``perpetual``
(default false: completion ends the behavior for good), ``templating = spawn``.
``duration = no-time-limit`` means -1. Display-only parameters (``visual_hints``,
``bearing_line_config``, ``bearing_lines``) are kept in ``display`` and do not affect
decisions. Flag values may use ``$[CONTACT]``, ``$[OWNSHIP]``, ``$[BHVNAME]``.

States (IvP): *idle* (conditions false), *running* (conditions true), *active* (running and
producing an objective), *completed*.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

from uhrisim.autonomy.conditions import Condition, Value, parse_condition
from uhrisim.autonomy.domain import Domain, Objective
from uhrisim.autonomy.extrapolator import Extrapolated, LinearExtrapolator
from uhrisim.autonomy.params import Flag, parse_flag, to_bool, to_float, to_str
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned

__all__ = [
    "COMMON_HANDLERS",
    "Behavior",
    "BehaviorContext",
    "CommonParams",
    "ContactInfo",
    "OwnNav",
]


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
    s = to_str(v, key, where).lower()
    if s not in ("spawn", "", "disallowed"):
        raise ConfigError(f"templating must be 'spawn', got {v!r}", where)
    return "spawn" if s == "spawn" else ""


def _duration(v: object, key: str, where: str) -> float:
    if isinstance(v, str) and v.strip().lower() == "no-time-limit":
        return -1.0
    return to_float(v, key, where)


def _display(p: CommonParams, v: object, key: str, where: str) -> CommonParams:
    vals = v if isinstance(v, list | tuple) else [v]
    return replace(p, display=p.display + tuple((key, to_str(x, key, where)) for x in vals))


def _cond(v: object, key: str, where: str) -> Condition:
    return parse_condition(str(v), where)


def _name(v: object, key: str, where: str) -> str:
    s = to_str(v, key, where)
    if not s or any(c.isspace() for c in s):
        raise ConfigError(f"behavior name must be one word, got {v!r}", where)
    return s


COMMON_HANDLERS: dict[str, Callable] = {
    "name": _set("name", _name),
    "pwt": _set("priority", to_float),
    "priority": _set("priority", to_float),
    "condition": _append("conditions", _cond),
    "endflag": _append("endflags", parse_flag),
    "runflag": _append("runflags", parse_flag),
    "idleflag": _append("idleflags", parse_flag),
    "activeflag": _append("activeflags", parse_flag),
    "inactiveflag": _append("inactiveflags", parse_flag),
    "updates": _set("updates", to_str),
    "duration": _set("duration", _duration),
    "duration_idle_decay": _set("duration_idle_decay", to_bool),
    "perpetual": _set("perpetual", to_bool),
    "templating": _set("templating", _templating),
    # display-only (pMarineViewer rendering): kept in the config, no effect on decisions
    "visual_hints": _display,
    "bearing_line_config": _display,
    "bearing_lines": _display,
}


@dataclass(frozen=True)
class OwnNav:
    """Own ship in MOOS terms: x east, y north (m), heading compass deg, speed m/s, depth m."""

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


@dataclass(frozen=True)
class ContactInfo:
    """A contact as the helm's info buffer holds it (``<NAME>_NAV_*`` from NODE_REPORTs)."""

    name: str
    x: float
    y: float
    heading: float
    speed: float
    depth: float
    t_report: float

    def extrapolate(self, extrapolator: LinearExtrapolator | None, t: float) -> Extrapolated:
        """Dead-reckoned position at ``t`` (the raw report when ``extrapolator`` is None)."""
        if extrapolator is None:
            return Extrapolated(self.x, self.y, 0.0, False)
        return extrapolator.extrapolate(self.x, self.y, self.heading, self.speed, self.t_report, t)


def _num(v: object) -> float | None:
    try:
        x = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


@dataclass
class BehaviorContext:
    """What a behavior sees in one helm tick: time, domain, info buffer, own nav; its posts."""

    t: float
    domain: Domain
    info: Mapping[str, Value]
    own: OwnNav | None
    posts: list[tuple[str, Value]] = field(default_factory=list)

    def post(self, var: str, value: Value) -> None:
        self.posts.append((var, value))

    def contact(self, name: str) -> ContactInfo | None:
        """Contact ``name`` from ``<NAME>_NAV_X/_Y/_HEADING/_SPEED/_DEPTH/_UTC``, else None."""
        key = name.upper()
        x, y = _num(self.info.get(f"{key}_NAV_X")), _num(self.info.get(f"{key}_NAV_Y"))
        if x is None or y is None:
            return None
        g = self.info.get
        return ContactInfo(
            name,
            x,
            y,
            _num(g(f"{key}_NAV_HEADING")) or 0.0,
            _num(g(f"{key}_NAV_SPEED")) or 0.0,
            _num(g(f"{key}_NAV_DEPTH")) or 0.0,
            _num(g(f"{key}_NAV_UTC")) if _num(g(f"{key}_NAV_UTC")) is not None else self.t,
        )


class Behavior:
    """Base of all behaviors. Subclasses set ``KIND``, ``Params`` and ``HANDLERS``.

    ``on_run`` returns an :class:`Objective` normalised to 0..100 (or None: nothing to say);
    it may scale its priority for this tick through ``self.priority_scale`` (AvoidCollision's
    relevance) and call :meth:`complete`.
    """

    KIND: ClassVar[str] = ""
    Params: ClassVar[type] = object
    HANDLERS: ClassVar[dict[str, Callable]] = {}
    REQUIRED: ClassVar[tuple[str, ...]] = ()
    CONTACT_BASED: ClassVar[bool] = False

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
        k = key.strip().lower()
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
        """Hook: transition idle -> running."""

    def on_idle(self, ctx: BehaviorContext) -> None:
        """Hook: called each tick the behavior is idle."""

    def on_run(self, ctx: BehaviorContext) -> Objective | None:
        raise NotImplementedError
