"""Parameters of sweeps and datasets: random draws, and dotted paths into a scenario.

A dotted path names one value of a scenario file: ``duration``,
``agents.videoray.controller.heading`` (a list item by its ``name``, an object by its
``label``, or by index: ``agents.1`` or ``agents[1]``), ``world.water.temperature_c``.
:func:`check_path` holds a path to the scenario schema (an unknown key is an error with a
did-you-mean, before anything runs); :func:`apply_path` sets the value in the parsed
YAML, creating the sections the file leaves at their defaults.
"""

from __future__ import annotations

import difflib
import math
import re
from pathlib import Path
from types import UnionType
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import numpy as np
from pydantic import BaseModel, model_validator

from uhrisim.core.errors import ConfigError
from uhrisim.core.files import regular_file_text
from uhrisim.scenario.schema import Scenario, Strict
from uhrisim.scenario.yaml_lines import LineMap, load_with_lines

#: Keys that name an item of a list in a scenario (agents by name, objects by label).
ITEM_KEYS = ("name", "label")


class Draw(Strict):
    """One random value: exactly one of ``uniform: [low, high]``, ``log_uniform: [low,
    high]`` (both > 0), ``integers: [low, high]`` (both included) or ``choice: [...]``."""

    uniform: tuple[float, float] | None = None
    log_uniform: tuple[float, float] | None = None
    integers: tuple[int, int] | None = None
    choice: tuple[Any, ...] | None = None

    @model_validator(mode="after")
    def _exactly_one(self) -> Draw:
        given = [k for k, v in self if v is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of uniform, log_uniform, integers, choice")
        low_high = self.uniform or self.log_uniform or self.integers
        if low_high is not None and not low_high[0] <= low_high[1]:
            raise ValueError(f"{given[0]}: low {low_high[0]} is above high {low_high[1]}")
        if self.log_uniform is not None and self.log_uniform[0] <= 0.0:
            raise ValueError("log_uniform: both bounds must be > 0")
        if self.choice is not None and not self.choice:
            raise ValueError("choice: the list is empty")
        return self

    def sample(self, rng: np.random.Generator) -> Any:
        """One value drawn from ``rng`` (Python types: float, int, or a choice's item)."""
        if self.uniform is not None:
            return float(rng.uniform(*self.uniform))
        if self.log_uniform is not None:
            low, high = self.log_uniform
            return float(math.exp(rng.uniform(math.log(low), math.log(high))))
        if self.integers is not None:
            return int(rng.integers(self.integers[0], self.integers[1], endpoint=True))
        return self.choice[int(rng.integers(len(self.choice)))]


def read_yaml(path: Path, kind: str) -> tuple[Any, LineMap]:
    """The parsed YAML of a ``kind`` file ("sweep", "scenario", "dataset") and the line of
    each key; a missing or unreadable file is a one-line ConfigError."""
    try:
        text = regular_file_text(path)
    except FileNotFoundError:
        raise ConfigError(f"{kind} file not found", where=str(path)) from None
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"cannot read {kind} file: {error}", where=str(path)) from None
    return load_with_lines(text, str(path))


def split_path(path: str) -> list[str | int]:
    """``"agents[1].start.depth"`` -> ``["agents", 1, "start", "depth"]``."""
    parts: list[str | int] = []
    for token in re.sub(r"\[(\d+)\]", r".\1", path).split("."):
        if not token:
            raise ConfigError(f"{path!r} is not a dotted path (an empty part)")
        parts.append(int(token) if token.isdigit() else token)
    return parts


def _unwrap(annotation: Any) -> list[Any]:
    """The concrete types an annotation allows (Optional, Annotated and unions opened)."""
    if get_origin(annotation) is Annotated:
        return _unwrap(get_args(annotation)[0])
    if get_origin(annotation) in (Union, UnionType):
        return [t for arg in get_args(annotation) for t in _unwrap(arg)]
    return [annotation]


def _item_index(items: list[Any], key: str | int, path: str) -> int:
    if isinstance(key, int):
        if key >= len(items):
            raise ConfigError(f"{path}: index {key} is past the {len(items)} items there")
        return key
    named = [i for i, item in enumerate(items)
             if isinstance(item, dict) and any(item.get(k) == key for k in ITEM_KEYS)]
    if not named:
        names = [str(item.get(k)) for item in items if isinstance(item, dict)
                 for k in ITEM_KEYS if k in item]
        close = difflib.get_close_matches(key, names, n=1)
        hint = f"did you mean {close[0]!r}?" if close else f"have: {', '.join(names) or 'none'}"
        raise ConfigError(f"{path}: no item named {key!r}; {hint}")
    return named[0]


def check_path(path: str, data: dict[str, Any], model: type[BaseModel] = Scenario) -> None:
    """ConfigError unless ``path`` names a value the scenario schema knows, given the
    scenario's parsed ``data`` (which picks list items and object types)."""
    types: list[Any] = [model]
    node: Any = data
    for part in split_path(path):
        models = [t for t in types if isinstance(t, type) and issubclass(t, BaseModel)]
        if isinstance(node, dict) and "type" in node and len(models) > 1:
            models = [m for m in models if _literal_of(m, "type") == node["type"]] or models
        if models:
            fields = {name: f for m in models for name, f in m.model_fields.items()}
            fields |= {f.alias: f for m in models for f in m.model_fields.values() if f.alias}
            if part not in fields:
                close = difflib.get_close_matches(str(part), sorted(fields), n=1)
                hint = f"did you mean {close[0]!r}?" if close else \
                    f"known keys: {', '.join(sorted(fields))}"
                raise ConfigError(f"{path}: unknown key {part!r}; {hint}")
            types = _unwrap(fields[part].annotation)
            node = node.get(part) if isinstance(node, dict) else None
            continue
        sequences = [t for t in types if get_origin(t) in (tuple, list)]
        if sequences:
            items = node if isinstance(node, list) else []
            node = items[_item_index(items, part, path)]
            types = [t for s in sequences for t in _unwrap(get_args(s)[0])]
            continue
        if any(get_origin(t) is dict or t is Any for t in types):
            return  # free-form mapping (helm behaviors, macros): checked when a run loads
        raise ConfigError(f"{path}: {part!r} goes inside a value that has no keys")


def _literal_of(model: type[BaseModel], name: str) -> Any:
    field = model.model_fields.get(name)
    if field is not None and get_origin(field.annotation) is Literal:
        return get_args(field.annotation)[0]
    return None


def apply_path(data: dict[str, Any], path: str, value: Any) -> None:
    """Set ``path`` to ``value`` in the parsed scenario ``data`` (in place), creating the
    mappings on the way that the file leaves out."""
    parts = split_path(path)
    node: Any = data
    for i, part in enumerate(parts[:-1]):
        if isinstance(node, list):
            node = node[_item_index(node, part, path)]
            continue
        if not isinstance(node.get(part), dict | list):
            node[part] = [] if isinstance(parts[i + 1], int) else {}
        node = node[part]
    last = parts[-1]
    if isinstance(node, list):
        node[_item_index(node, last, path)] = value
    else:
        node[last] = value
