"""Safe YAML loading that remembers the line of every key, for error messages.

``load_with_lines(text, source)`` returns the plain data and a map from a key path
(a tuple of keys/indices, as pydantic reports ``loc``) to its 1-based line number.
"""

from __future__ import annotations

from typing import Any

import yaml

from uhrisim.core.errors import ConfigError

LineMap = dict[tuple[Any, ...], int]


class _LineLoader(yaml.SafeLoader):
    """SafeLoader that keeps each node's start line (no arbitrary object construction)."""


def _walk(node: yaml.Node, path: tuple[Any, ...], lines: LineMap) -> None:
    lines[path] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        for key_node, value_node in node.value:
            key = key_node.value
            lines[(*path, key)] = key_node.start_mark.line + 1
            _walk(value_node, (*path, key), lines)
            lines[(*path, key)] = key_node.start_mark.line + 1
    elif isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            _walk(item, (*path, index), lines)


def load_with_lines(text: str, source: str) -> tuple[Any, LineMap]:
    """Parse YAML ``text``; syntax errors become ``ConfigError`` naming ``source:line``."""
    try:
        node = yaml.compose(text, Loader=_LineLoader)
        data = yaml.load(text, Loader=_LineLoader)  # a SafeLoader subclass
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{source}:{mark.line + 1}" if mark is not None else source
        problem = getattr(error, "problem", None) or str(error)
        raise ConfigError(f"YAML syntax error: {problem}", where=where) from None
    lines: LineMap = {}
    if node is not None:
        _walk(node, (), lines)
    return data, lines


def line_of(lines: LineMap, path: tuple[Any, ...]) -> int | None:
    """Line of ``path`` or of its nearest ancestor that has one."""
    for end in range(len(path), -1, -1):
        if path[:end] in lines:
            return lines[path[:end]]
    return None
