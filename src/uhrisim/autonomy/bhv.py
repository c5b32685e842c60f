"""Loader for MOOS-IvP ``.bhv`` behavior files.

Understood: ``initialize VAR = value [, VAR = value]`` (and ``initialize_``), ``set VAR =
VALUE { conditions } ELSEVALUE`` mode blocks (multi-line), ``Behavior = BHV_X { key =
value ... }`` blocks, ``//`` comments. Anything else is a ConfigError naming
``file:line`` - nothing is silently dropped.

Mission files are usually run through nsplug first; the subset missions use is applied
when ``macros`` are given (or the file uses them): ``$(NAME)`` substitution, ``#ifdef NAME
[value]``, ``#ifndef NAME``, ``#else``, ``#endif``, ``#define NAME value``. An undefined
``$(NAME)`` or an unbalanced directive is a ConfigError at its line; ``#include`` is not
supported (ConfigError).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from pathlib import Path

from uhrisim.autonomy.config import HelmConfig, build_behavior_spec
from uhrisim.autonomy.domain import Domain
from uhrisim.autonomy.modes import parse_mode_entry
from uhrisim.autonomy.params import parse_flag
from uhrisim.core.errors import AssetError, ConfigError

__all__ = ["load_bhv", "parse_bhv", "preprocess"]


def _strip_comment(line: str) -> str:
    out, quote = [], ""
    i = 0
    while i < len(line):
        ch = line[i]
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif line.startswith("//", i):
            break
        out.append(ch)
        i += 1
    return "".join(out).strip()


_MACRO = re.compile(r"\$\(([A-Za-z_][A-Za-z0-9_]*)\)")


def preprocess(lines: list[str], macros: Mapping[str, object], filename: str) -> list[str]:
    """nsplug subset (module docstring); keeps line numbers (dropped lines become "")."""
    defs = {str(k): str(v) for k, v in macros.items()}
    out: list[str] = []
    stack: list[tuple[bool, bool, int]] = []  # (this branch on, parent on, line)

    def active() -> bool:
        return all(on for on, _, _ in stack)

    for i, raw in enumerate(lines):
        where = f"{filename}:{i + 1}"
        s = raw.strip()
        if s.startswith("#"):
            parts = s.split(None, 2)
            d = parts[0].lower()
            if d in ("#ifdef", "#ifndef"):
                if len(parts) < 2:
                    raise ConfigError(f"{d} needs a macro name", where)
                name = parts[1]
                hit = name in defs and (len(parts) < 3 or defs[name] == parts[2].strip())
                stack.append((hit if d == "#ifdef" else not hit, active(), i + 1))
            elif d == "#else":
                if not stack:
                    raise ConfigError("#else without #ifdef", where)
                on, parent, ln = stack.pop()
                stack.append((not on, parent, ln))
            elif d == "#endif":
                if not stack:
                    raise ConfigError("#endif without #ifdef", where)
                stack.pop()
            elif d == "#define":
                if active():
                    if len(parts) < 2:
                        raise ConfigError("#define needs a macro name", where)
                    defs[parts[1]] = parts[2].strip() if len(parts) > 2 else ""
            else:
                raise ConfigError(f"unsupported directive {parts[0]!r}", where)
            out.append("")
            continue
        if not active():
            out.append("")
            continue

        def sub(m: re.Match, where: str = where) -> str:
            if m.group(1) not in defs:
                raise ConfigError(f"macro $({m.group(1)}) is not defined", where)
            return defs[m.group(1)]

        out.append(_MACRO.sub(sub, raw))
    if stack:
        raise ConfigError("#ifdef never closed with #endif", f"{filename}:{stack[-1][2]}")
    return out


def parse_bhv(
    text: str,
    filename: str = "<bhv>",
    known_vars: Iterable[str] = (),
    domain: Domain | None = None,
    macros: Mapping[str, object] | None = None,
) -> HelmConfig:
    """Parse ``.bhv`` text into a validated :class:`HelmConfig` (``macros``: nsplug subset)."""
    raw_lines = [_strip_comment(s) for s in text.splitlines()]
    lines = preprocess(raw_lines, macros or {}, filename)
    init, modes, specs = [], [], []
    i, n = 0, len(lines)
    while i < n:
        line, lineno = lines[i], i + 1
        where = f"{filename}:{lineno}"
        low = line.lower()
        if not line:
            i += 1
        elif re.match(r"^initialize_?\s", low):
            body = line.split(None, 1)[1]
            for part in body.split(","):
                if part.strip():
                    init.append(parse_flag(part, "initialize", where))
            i += 1
        elif re.match(r"^set\s", low):
            chunk, j = [line], i
            if "{" not in line and j + 1 < n and lines[j + 1].startswith("{"):
                j += 1
                chunk.append(lines[j])
            if "{" in "".join(chunk):
                while "}" not in "".join(chunk):
                    j += 1
                    if j >= n:
                        raise ConfigError("mode declaration never closed with '}'", where)
                    chunk.append(lines[j])
            modes.append(parse_mode_entry("\n".join(chunk), where))
            i = j + 1
        elif re.match(r"^behavior\s*=", low):
            kind = line.split("=", 1)[1].strip()
            opened = kind.endswith("{")
            kind = kind.rstrip("{").strip()
            j = i + 1
            if not opened:
                while j < n and not lines[j]:
                    j += 1
                if j >= n or lines[j] != "{":
                    raise ConfigError(f"expected '{{' after Behavior = {kind}", where)
                j += 1
            items = []
            while True:
                if j >= n:
                    raise ConfigError(f"behavior block {kind} never closed with '}}'", where)
                s = lines[j]
                if s == "}":
                    break
                if s:
                    if "=" not in s:
                        raise ConfigError(
                            f"expected 'parameter = value', got {s!r}", f"{filename}:{j + 1}"
                        )
                    k, v = s.split("=", 1)
                    items.append((k.strip(), v.strip(), f"{filename}:{j + 1}"))
                j += 1
            specs.append(build_behavior_spec(kind, items, where))
            i = j + 1
        else:
            raise ConfigError(f"cannot read line {line!r}", where)
    cfg = HelmConfig(
        tuple(specs), tuple(modes), tuple(init), domain or Domain.paper(), source=filename
    )
    return cfg.validate(known_vars)


def load_bhv(
    path: str | Path,
    known_vars: Iterable[str] = (),
    domain: Domain | None = None,
    macros: Mapping[str, object] | None = None,
) -> HelmConfig:
    """Read and parse a ``.bhv`` file; errors name ``path:line``."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise AssetError(f"{p}: cannot read behavior file ({e.strerror})") from e
    return parse_bhv(text, str(p), known_vars, domain, macros)
