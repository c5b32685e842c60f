"""Load a scenario file into a validated, frozen :class:`Scenario`.

Errors name the file, the line and the field path: ``track.yaml:12: agents[0].start.depth:
Input should be greater than or equal to 0``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from uhrisim.core.errors import ConfigError
from uhrisim.core.files import regular_file_text
from uhrisim.scenario.schema import Scenario
from uhrisim.scenario.yaml_lines import LineMap, line_of, load_with_lines


@dataclass(frozen=True)
class ScenarioFile:
    """A validated scenario and where it came from (relative paths resolve beside it)."""

    scenario: Scenario
    path: Path | None = None
    lines: LineMap = field(default_factory=dict, repr=False)

    def resolve(self, relative: str) -> Path:
        candidate = Path(relative).expanduser()
        if candidate.is_absolute() or self.path is None:
            return candidate
        return self.path.parent / candidate

    def where(self, *path: Any) -> str:
        """``file:line`` of a key path, for messages raised while building."""
        name = str(self.path) if self.path else "<scenario>"
        line = line_of(self.lines, tuple(path))
        return f"{name}:{line}" if line else name


def _format_loc(loc: tuple[Any, ...]) -> str:
    text = ""
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
        else:
            text += f".{part}" if text else str(part)
    return text


def _data_path(loc: tuple[Any, ...], data: Any) -> tuple[Any, ...]:
    """Keep only the parts of ``loc`` that really index the YAML data (skip union tags)."""
    path: list[Any] = []
    node = data
    for part in loc:
        in_mapping = isinstance(node, dict) and part in node
        in_sequence = isinstance(node, list) and isinstance(part, int) and part < len(node)
        if in_mapping or in_sequence:
            node = node[part]
            path.append(part)
    return tuple(path)


def validate_data(data: Any, source: str, lines: LineMap | None = None,
                  model: type[BaseModel] = Scenario, kind: str = "scenario") -> Any:
    """Validate parsed data as ``model`` (a scenario unless told; ``kind`` names the file
    in messages); the first problem becomes a one-line ``ConfigError``."""
    if not isinstance(data, dict):
        raise ConfigError(f"a {kind} file must be a mapping of keys to values", where=source)
    try:
        return model.model_validate(data)
    except ValidationError as error:
        first = error.errors()[0]
        loc = _data_path(tuple(first["loc"]), data)
        message = first["msg"]
        if first["type"] in ("unknown_key", "bool_for_number"):  # raised for the mapping
            loc = (*loc, first["ctx"]["key"])
        elif first["type"] == "at_path":  # a check of the whole that names one field
            loc = _data_path(tuple(first["ctx"]["path"]), data)
        elif first["type"] == "missing":
            message = f"missing required key {first['loc'][-1]!r}"
        message = message.removeprefix("Value error, ")
        line = line_of(lines or {}, loc)
        where = f"{source}:{line}" if line else source
        field_path = _format_loc(loc)
        raise ConfigError(f"{field_path}: {message}" if field_path else message,
                          where=where) from None


def load_scenario(path: str | Path) -> ScenarioFile:
    """Read, parse (safe YAML) and validate a scenario file."""
    path = Path(path)
    try:
        text = regular_file_text(path)
    except FileNotFoundError:
        raise ConfigError("scenario file not found", where=str(path)) from None
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"cannot read scenario file: {error}", where=str(path)) from None
    data, lines = load_with_lines(text, str(path))
    return ScenarioFile(validate_data(data, str(path), lines), path, lines)
