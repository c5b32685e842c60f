"""Safe YAML loading that remembers the line of every key, for error messages.

``load_with_lines(text, source)`` returns the plain data and a map from a key path
(a tuple of keys/indices, as pydantic reports ``loc``) to its 1-based line number.
"""

from __future__ import annotations

import re
from typing import Any

import yaml

from uhrisim.core.errors import ConfigError

LineMap = dict[tuple[Any, ...], int]


class _LineLoader(yaml.SafeLoader):
    """SafeLoader that keeps each node's start line (no arbitrary object construction)."""


#: Bounds on what a scenario file may make the loader build: a YAML alias can repeat a
#: whole subtree, so a few hundred bytes can expand to gigabytes ("billion laughs").
MAX_TEXT_CHARS = 10_000_000
MAX_VALUES = 200_000
MAX_DEPTH = 64


def _walk(root: yaml.Node, source: str) -> LineMap:
    """Lines of every key path; refuses a key that is not a plain value, duplicate keys
    (naming both lines), a document that expands past MAX_VALUES values, or one nested
    deeper than MAX_DEPTH."""
    lines: LineMap = {}
    stack: list[tuple[yaml.Node, tuple[Any, ...]]] = [(root, ())]
    values = 0
    while stack:
        node, path = stack.pop()
        values += 1
        line = node.start_mark.line + 1
        if values > MAX_VALUES:
            raise ConfigError(f"the document expands to more than {MAX_VALUES} values "
                              "(YAML aliases repeating whole sections?)", f"{source}:{line}")
        if len(path) > MAX_DEPTH:
            raise ConfigError(f"values nested deeper than {MAX_DEPTH} levels",
                              f"{source}:{line}")
        lines.setdefault(path, line)
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, int] = {}
            for key_node, value_node in node.value:
                key_line = key_node.start_mark.line + 1
                if not isinstance(key_node, yaml.ScalarNode):
                    kind = "a list" if isinstance(key_node, yaml.SequenceNode) else "a mapping"
                    raise ConfigError(f"a key must be a name, not {kind} ('? ...' keys)",
                                      f"{source}:{key_line}")
                key = key_node.value
                if isinstance(key, str) and key != "<<":
                    if key in seen:
                        raise ConfigError(f"duplicate key {key!r} (first at line {seen[key]})",
                                          f"{source}:{key_line}")
                    seen[key] = key_line
                lines[(*path, key)] = key_line
                stack.append((value_node, (*path, key)))
        elif isinstance(node, yaml.SequenceNode):
            stack.extend((item, (*path, i)) for i, item in enumerate(node.value))
    return lines


#: A line that opens a block mapping key or a block list entry (a comment, a flow
#: collection's or a block scalar's continuation line does not).
_BLOCK_ENTRY = re.compile(r"^( *)(?:-(?: |$)|[^\s#-][^\n]*?:(?: |$))", re.MULTILINE)


def _too_deep(text: str) -> int | None:
    """Line of the first collection nested deeper than MAX_DEPTH, by brackets (flow) or by
    indentation (block), else None. PyYAML's composer recurses once a level: a few
    thousand levels would overflow it, and block levels take it seconds to reach first."""
    return _indented_too_deep(text) or _bracketed_too_deep(text)


def _indented_too_deep(text: str) -> int | None:
    """Line of the first block key or list entry indented under more than MAX_DEPTH
    others, else None (compact nesting such as ``- - x`` is left to the composer)."""
    indents = [-1]
    for entry in _BLOCK_ENTRY.finditer(text):
        indent = len(entry[1])
        while indent <= indents[-1]:
            indents.pop()
        indents.append(indent)
        if len(indents) - 1 > MAX_DEPTH:
            return text.count("\n", 0, entry.start()) + 1
    return None


def _bracketed_too_deep(text: str) -> int | None:
    """Line of the first flow collection nested deeper than MAX_DEPTH, else None."""
    depth, line, quote = 0, 1, ""
    for ch in text:
        if ch == "\n":
            line += 1
        elif quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                return line
        elif ch in "]}":
            depth = max(depth - 1, 0)
    return None


def load_with_lines(text: str, source: str) -> tuple[Any, LineMap]:
    """Parse YAML ``text``; syntax errors, duplicate keys and documents too big or too deep
    become a ``ConfigError`` naming ``source:line``."""
    if len(text) > MAX_TEXT_CHARS:
        raise ConfigError(f"the file has {len(text)} characters, more than {MAX_TEXT_CHARS}",
                          where=source)
    deep = _too_deep(text)
    if deep is not None:
        raise ConfigError(f"values nested deeper than {MAX_DEPTH} levels", f"{source}:{deep}")
    try:
        node = yaml.compose(text, Loader=_LineLoader)
        lines = _walk(node, source) if node is not None else {}
        data = yaml.load(text, Loader=_LineLoader)  # a SafeLoader subclass
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{source}:{mark.line + 1}" if mark is not None else source
        problem = getattr(error, "problem", None) or str(error)
        raise ConfigError(f"YAML syntax error: {problem}", where=where) from None
    except RecursionError:  # block-style (indented) nesting thousands of levels deep
        raise ConfigError(f"values nested deeper than {MAX_DEPTH} levels", where=source) from None
    return data, lines


def line_of(lines: LineMap, path: tuple[Any, ...]) -> int | None:
    """Line of ``path`` or of its nearest ancestor that has one."""
    for end in range(len(path), -1, -1):
        if path[:end] in lines:
            return lines[path[:end]]
    return None
