"""Parsing of behavior parameter values (strings from ``.bhv`` files or YAML scalars).

Every value goes through one of these converters whether it comes from a ``.bhv`` line, a
scenario mapping or a run-time ``updates`` posting, so the three produce identical typed
parameters. Errors are :class:`ConfigError` naming the parameter and where it came from.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from uhrisim.autonomy.conditions import Value, literal
from uhrisim.core.errors import ConfigError

__all__ = [
    "NUMERIC_VARS",
    "Flag",
    "checked_value",
    "moos_value",
    "one_of",
    "parse_flag",
    "parse_updates",
    "setter",
    "to_bool",
    "to_decay",
    "to_float",
    "to_non_negative",
    "to_point",
    "to_point_or_present",
    "to_points",
    "to_positive",
    "to_priority",
    "to_str",
]

Flag = tuple[str, Value]


def moos_value(v: object, where: str | None = None) -> Value:
    """Normalise a Python scalar to a MOOS value: bool -> "true"/"false", numbers -> float.

    Anything else is a ConfigError at ``where`` (the variable or field it came from)."""
    if type(v) is float:  # the common case (NAV_*), without the ABC checks below
        return v
    if isinstance(v, bool | np.bool_):
        return "true" if v else "false"
    if isinstance(v, numbers.Real):
        return float(v)
    if isinstance(v, str):
        return literal(v)
    raise ConfigError(f"expected a string or number, got {type(v).__name__}", where)


NUMERIC_VARS = frozenset({"DESIRED_HEADING", "DESIRED_SPEED", "DESIRED_DEPTH"})


def checked_value(agent: str, var: str, value: Value) -> Value:
    """``value`` if it may be posted as ``var``; the controllers' inputs must be finite
    numbers (a ConfigError names the agent, variable and value otherwise)."""
    if var in NUMERIC_VARS:
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = math.nan
        if isinstance(value, bool) or not math.isfinite(number):
            raise ConfigError(f"{var} must be a finite number, got {value!r}", where=agent)
        return number
    return value


def to_float(v: object, key: str, where: str) -> float:
    if isinstance(v, bool):
        raise ConfigError(f"{key} must be a number, got {v!r}", where)
    try:
        x = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ConfigError(f"{key} must be a number, got {v!r}", where) from None
    if not math.isfinite(x):
        raise ConfigError(f"{key} must be finite, got {v!r}", where)
    return x


def to_positive(v: object, key: str, where: str) -> float:
    """A number > 0 (IvP refuses the parameter otherwise: a config error)."""
    x = to_float(v, key, where)
    if not x > 0.0:
        raise ConfigError(f"{key} must be > 0, got {v!r}", where)
    return x


def to_non_negative(v: object, key: str, where: str) -> float:
    """A number >= 0 (IvP refuses the parameter otherwise: a config error)."""
    x = to_float(v, key, where)
    if x < 0.0:
        raise ConfigError(f"{key} must be >= 0, got {v!r}", where)
    return x


#: The largest priority weight a behavior may have: pHelmIvP missions use 0 to a few
#: thousand, and the solver sums priority x objective (0-100) over the behaviors.
MAX_PRIORITY = 1.0e6


def to_priority(v: object, key: str, where: str) -> float:
    """A behavior's priority weight, in [0, :data:`MAX_PRIORITY`]."""
    x = to_non_negative(v, key, where)
    if x > MAX_PRIORITY:
        raise ConfigError(f"{key} must be <= {MAX_PRIORITY:g}, got {v!r}", where)
    return x


def to_summitdelta(v: object, key: str, where: str) -> float:
    """A ZAIC summit delta: a number, clipped to [0, 100] as IvP behaviors do."""
    return min(max(to_float(v, key, where), 0.0), 100.0)


def to_clipped_non_negative(v: object, key: str, where: str) -> float:
    """A number clipped at 0 (IvP's ``vclip_min(dval, 0)``: accepted, never refused)."""
    return max(to_float(v, key, where), 0.0)


def to_bool(v: object, key: str, where: str) -> bool:
    if isinstance(v, bool):
        return v
    s = str(v).strip().lower()
    if s in ("true", "1", "yes", "on"):
        return True
    if s in ("false", "0", "no", "off"):
        return False
    raise ConfigError(f"{key} must be true or false, got {v!r}", where)


def to_str(v: object, key: str, where: str) -> str:
    if isinstance(v, list | dict | tuple):
        raise ConfigError(f"{key} must be a single value, got {v!r}", where)
    s = str(v).strip()
    if len(s) >= 2 and s[0] == s[-1] and s[0] in "\"'":
        s = s[1:-1]
    return s


def one_of(*choices: str) -> Callable[[object, str, str], str]:
    """A converter accepting one of ``choices`` (lower-cased, quotes stripped), else a
    ConfigError "<key> must be a, b or c, got <value>"."""
    listed = " or ".join(filter(None, (", ".join(choices[:-1]), choices[-1])))

    def conv(v: object, key: str, where: str) -> str:
        s = to_str(v, key, where).lower()
        if s not in choices:
            raise ConfigError(f"{key} must be {listed}, got {v!r}", where)
        return s

    return conv


def to_decay(v: object, key: str, where: str) -> tuple[float, float]:
    """ "start,end" (or a 2-sequence) -> a contact's dead-reckoning decay window
    (start, end), s, with 0 <= start <= end (IvP ``decay``)."""
    parts = list(v) if isinstance(v, list | tuple) else str(v).split(",")
    if len(parts) != 2:
        raise ConfigError(f"{key} must read 'start,end' in seconds, got {v!r}", where)
    a, b = (to_float(p, key, where) for p in parts)
    if a < 0 or b < a:
        raise ConfigError(f"{key} needs 0 <= start <= end, got {v!r}", where)
    return (a, b)


def to_point(v: object, key: str, where: str) -> tuple[float, float]:
    """ "x,y" (or a 2-sequence) -> (x east, y north)."""
    parts = list(v) if isinstance(v, list | tuple) else str(v).replace("=", ",").split(",")
    parts = [p for p in (str(p).strip() for p in parts) if p and p not in ("x", "y")]
    if len(parts) != 2:
        raise ConfigError(f"{key} must be a point 'x,y', got {v!r}", where)
    return (to_float(parts[0], key, where), to_float(parts[1], key, where))


def to_point_or_present(v: object, key: str, where: str) -> tuple[float, float] | str:
    """ "x,y" (or a 2-sequence) -> (x east, y north); "present_position" (any case) is kept
    as that string, for the behavior to resolve to the vehicle's position."""
    s = to_str(v, key, where) if not isinstance(v, list | tuple) else v
    if isinstance(s, str) and s.lower() == "present_position":
        return "present_position"
    return to_point(s, key, where)


def to_points(v: object, key: str, where: str) -> tuple[tuple[float, float], ...]:
    """ "x1,y1 : x2,y2 : ..." or "pts={x1,y1:x2,y2}" (or a list of pairs) -> points."""
    if isinstance(v, list | tuple):
        return tuple(to_point(p, key, where) for p in v)
    s = str(v).strip()
    if s.lower().startswith("pts"):
        s = s.split("=", 1)[1].strip() if "=" in s else ""
    s = s.strip().strip("{}")
    pts = tuple(to_point(p, key, where) for p in s.split(":") if p.strip())
    if not pts:
        raise ConfigError(f"{key} has no points: {v!r}", where)
    return pts


def parse_flag(v: object, key: str, where: str) -> Flag:
    """ "VAR = value" -> (VAR, value) with the value as a MOOS string/number."""
    if isinstance(v, dict) and len(v) == 1:
        ((var, val),) = v.items()
        return (str(var).strip(), moos_value(val, where))
    s = str(v)
    if "=" not in s:
        raise ConfigError(f"{key} must read 'VARIABLE = value', got {v!r}", where)
    var, val = s.split("=", 1)
    var = var.strip()
    if not var or any(c.isspace() for c in var):
        raise ConfigError(f"{key} has a bad variable name {var!r}", where)
    return (var, literal(val))


def parse_updates(text: str) -> list[tuple[str, str]]:
    """An ``updates`` posting "param=value # param=value" -> [(param, value), ...]."""
    out = []
    for part in str(text).split("#"):
        if not part.strip():
            continue
        if "=" not in part:
            raise ConfigError(f"update {part.strip()!r} is not 'param=value'", "updates")
        k, val = part.split("=", 1)
        out.append((k.strip().lower(), val.strip()))
    return out


def setter(
    field: str, conv: Callable[[object, str, str], Any]
) -> Callable[[Any, object, str, str], Any]:
    """A parameter handler: (params, value, key, where) -> params with ``field`` replaced."""

    def apply(params: Any, value: object, key: str, where: str) -> Any:
        return replace(params, **{field: conv(value, key, where)})

    return apply
