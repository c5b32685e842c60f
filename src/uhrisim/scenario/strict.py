"""The base of every scenario section: frozen, strict, unknown keys refused with a hint.

A section may also name keys it used to have (``legacy_keys``): each is read as its new
name with a warning, so older scenario files keep working while the names settle on the
parts' own (docs/settings.md).
"""

from __future__ import annotations

import difflib
from types import UnionType
from typing import Annotated, Any, ClassVar, Union, get_args, get_origin

from pydantic import BaseModel, ConfigDict, model_validator
from pydantic_core import PydanticCustomError

from uhrisim.core.errors import warn_user


def _kinds(annotation: Any) -> set[Any]:
    """The types an annotation allows, unwrapped of ``Annotated`` and ``None``."""
    kinds = set(get_args(annotation)) if get_origin(annotation) in (Union, UnionType) else {
        annotation}
    kinds = {get_args(k)[0] if get_origin(k) is Annotated else k for k in kinds}
    kinds.discard(type(None))
    return kinds


def _numeric(kinds: set[Any]) -> bool:
    return bool(kinds) and kinds <= {float, int}


def _numeric_only(field: Any) -> bool:
    """Whether a field takes numbers and never a boolean (float/int, constrained or not,
    optional or not)."""
    return _numeric(_kinds(field.annotation))


def _numbers_only(field: Any) -> bool:
    """Whether a field takes a list of numbers (a tuple of float/int) and no booleans."""
    tuples = [k for k in _kinds(field.annotation) if get_origin(k) is tuple]
    return len(tuples) == 1 and all(
        _numeric(_kinds(item)) for item in get_args(tuples[0]) if item is not Ellipsis)


class Strict(BaseModel):
    """Base of every scenario section: frozen, and unknown keys are errors with a hint.

    ``legacy_keys`` maps a key the section used to have to its name now: ``"max_range":
    "range_max_m"``; ``"mount.tilt_deg": "tilt_deg"`` reads a key of a nested mapping
    ``mount`` (which then goes), ``"image.*": "*"`` every key of ``image``."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True,
                              allow_inf_nan=False)
    legacy_keys: ClassVar[dict[str, str]] = {}

    @model_validator(mode="before")
    @classmethod
    def _reject_unknown_keys(cls, data: Any) -> Any:
        if isinstance(data, dict) and cls.legacy_keys:
            data = _renamed(cls.__name__, cls.legacy_keys, data)
        if isinstance(data, dict):
            known = set(cls.model_fields)
            known |= {f.alias for f in cls.model_fields.values() if f.alias}
            for key in data:
                if key not in known:
                    close = difflib.get_close_matches(str(key), sorted(known), n=1)
                    hint = (f"did you mean {close[0]!r}?" if close
                            else f"known keys: {', '.join(sorted(known))}")
                    raise PydanticCustomError("unknown_key", "unknown key '{key}'; {hint}",
                                              {"key": key, "hint": hint})
                field = cls.model_fields.get(key) or next(
                    f for f in cls.model_fields.values() if f.alias == key)
                if isinstance(data[key], bool) and _numeric_only(field):
                    # YAML reads yes/no/on/off as booleans: "duration: yes" is not 1 s
                    raise PydanticCustomError("bool_for_number", "must be a number, got {value}",
                                              {"key": key, "value": str(data[key])})
                if (isinstance(data[key], list | tuple) and _numbers_only(field)
                        and any(isinstance(item, bool) for item in data[key])):
                    raise PydanticCustomError(
                        "bool_for_number", "must be numbers, got {value}",
                        {"key": key, "value": str([*data[key]])})
        return data




def _renamed(section: str, legacy: dict[str, str], data: dict[str, Any]) -> dict[str, Any]:
    """``data`` with its legacy keys under their new names (each with a warning); a new
    name given beside its old one is an error."""
    out = dict(data)
    for old, new in legacy.items():
        group, _, key = old.rpartition(".")
        if group:
            nested = out.get(group)
            if not isinstance(nested, dict):
                continue
            moved = dict(nested) if key == "*" else (
                {key: nested[key]} if key in nested else {})
            for name, value in moved.items():
                _move(section, out, f"{group}.{name}", new.replace("*", name), value)
                nested = {k: v for k, v in nested.items() if k != name}
            out[group] = nested
            if not nested:
                del out[group]
        elif old in out:
            _move(section, out, old, new, out.pop(old))
    return out


def _move(section: str, out: dict[str, Any], old: str, new: str, value: Any) -> None:
    if new in out:
        raise PydanticCustomError("legacy_key", "give '{new}' only (it was '{old}')",
                                  {"key": new, "new": new, "old": old})
    warn_user(f"scenario key '{old}' of a {section} is now '{new}' (the part's own name, "
              "docs/settings.md); please rename it", stacklevel=5)
    out[new] = value
