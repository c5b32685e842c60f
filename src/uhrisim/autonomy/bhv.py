"""Loader for MOOS-IvP ``.bhv`` behavior files.

Understood: ``initialize VAR = value [, VAR = value]`` (and ``initialize_``), ``set VAR =
VALUE { conditions } ELSEVALUE`` mode blocks (multi-line), ``Behavior = BHV_X { key =
value ... }`` blocks, ``//`` comments. Anything else is a ConfigError naming
``file:line`` - nothing is silently dropped.

Mission files are usually run through nsplug first; uhrisim's own helm applies the subset
missions use (``nsplug=True``, the default for a scenario's ``bhv_file``): ``$(NAME)``
substitution, ``#ifdef NAME [value]``, ``#ifndef NAME``, ``#else``, ``#endif``, ``#define
NAME value``. An undefined ``$(NAME)`` or an unbalanced directive is a ConfigError at its
line; ``#include`` is not supported (ConfigError).

pHelmIvP itself does not run nsplug: it reads its files as they are
(lib_helmivp/Populator_BehaviorSet.cpp), rejects a line such as ``#ifdef X`` ("Problem with
line N in the BehaviorSet file", then IVPHELM_STATE = MALCONFIG) and takes ``$(NAME)``
literally. A file read for a ``.moos`` helm (``nsplug=False``) is held to that:
:func:`refuse_nsplug` names the first such line.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from uhrisim.autonomy.conditions import Value
from uhrisim.autonomy.config import BehaviorSpec, HelmConfig, build_behavior_spec, default_domain
from uhrisim.autonomy.domain import Domain
from uhrisim.autonomy.modes import ModeEntry, parse_mode_entry
from uhrisim.autonomy.params import parse_flag
from uhrisim.core.errors import ConfigError
from uhrisim.core.files import read_text_file

__all__ = [
    "BhvContent",
    "expand_nsplug",
    "load_bhv",
    "nsplug_lines",
    "parse_bhv",
    "parse_bhv_content",
    "preprocess",
    "read_bhv_file",
    "refuse_nsplug",
    "strip_comment",
]


def strip_comment(line: str) -> str:
    """``line`` without its ``//`` comment (outside quotes), stripped."""
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


def nsplug_lines(lines: list[str], macros: Mapping[str, object], filename: str
                 ) -> list[str | None]:
    """The nsplug subset (module docstring), line by line: each line with its macros
    expanded, or None where nsplug drops it (a directive, or a branch not taken)."""
    defs = {str(k): str(v) for k, v in macros.items()}
    out: list[str | None] = []
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
            out.append(None)
            continue
        if not active():
            out.append(None)
            continue

        def sub(m: re.Match, where: str = where) -> str:
            if m.group(1) not in defs:
                raise ConfigError(f"macro $({m.group(1)}) is not defined", where)
            return defs[m.group(1)]

        out.append(_MACRO.sub(sub, raw))
    if stack:
        raise ConfigError("#ifdef never closed with #endif", f"{filename}:{stack[-1][2]}")
    return out


def preprocess(lines: list[str], macros: Mapping[str, object], filename: str) -> list[str]:
    """The nsplug subset, keeping line numbers: dropped lines become ""."""
    return [line or "" for line in nsplug_lines(lines, macros, filename)]


def expand_nsplug(text: str, macros: Mapping[str, object], filename: str = "<bhv>") -> str:
    """``text`` as ``nsplug`` writes it (MOOS-IvP app_nsplug/Expander.cpp: directive
    lines and branches not taken are left out, every other line is written as it is,
    its macros expanded, each ended by a newline - the empty "line" after a final newline
    too), within the subset of the module docstring."""
    kept = nsplug_lines(text.split("\n"), macros, filename)
    return "".join(f"{line}\n" for line in kept if line is not None)


def refuse_nsplug(lines: list[str], filename: str, reader: str = "pHelmIvP",
                  fate: str = "rejects the line (IVPHELM_STATE = MALCONFIG)") -> None:
    """A ConfigError at the first line ``reader`` would not read as meant: an nsplug
    directive (``#...``, of which ``reader`` ``fate``) or an unexpanded ``$(NAME)``
    (``lines``: comments stripped)."""
    for i, line in enumerate(lines):
        s = line.strip()
        where = f"{filename}:{i + 1}"
        if s.startswith("#"):
            raise ConfigError(
                f"{s.split()[0]!r} is an nsplug directive: {reader} reads this file as it "
                f"is and {fate}; expand the file with nsplug first (docs/bridges-moos.md)",
                where)
        macro = _MACRO.search(s)
        if macro:
            raise ConfigError(
                f"{macro.group(0)} is an nsplug macro left unexpanded: {reader} would take "
                "it literally; expand the file with nsplug first (docs/bridges-moos.md)",
                where)


@dataclass(frozen=True)
class BhvContent:
    """What a ``.bhv`` file declares: behaviors, mode entries, initial values, in order."""

    behaviors: tuple[BehaviorSpec, ...]
    modes: tuple[ModeEntry, ...]
    initialize: tuple[tuple[str, Value], ...]
    initialize_deferred: tuple[tuple[str, Value], ...]
    source: str


def parse_bhv_content(
    text: str,
    filename: str = "<bhv>",
    macros: Mapping[str, object] | None = None,
    *,
    nsplug: bool = True,
) -> BhvContent:
    """The declarations of ``.bhv`` text, not yet validated. ``nsplug``: apply the nsplug
    subset with ``macros`` (uhrisim's helm); otherwise read the text as pHelmIvP does and
    refuse what it would not read as meant (module docstring)."""
    raw_lines = [strip_comment(s) for s in text.splitlines()]
    if nsplug:
        lines = preprocess(raw_lines, macros or {}, filename)
    else:
        if macros:
            raise ConfigError("macros need nsplug: pHelmIvP reads the file as it is", filename)
        refuse_nsplug(raw_lines, filename)
        lines = raw_lines
    init, deferred, modes, specs = [], [], [], []
    i, n = 0, len(lines)
    while i < n:
        line, lineno = lines[i], i + 1
        where = f"{filename}:{lineno}"
        low = line.lower()
        if not line:
            i += 1
        elif re.match(r"^initialize_?\s", low):
            word, body = line.split(None, 1)
            into = deferred if word.endswith("_") else init
            for part in body.split(","):
                if part.strip():
                    into.append(parse_flag(part, word.lower(), where))
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
            specs.append(build_behavior_spec(kind, items, where, exact_kind=True))
            i = j + 1
        else:
            raise ConfigError(f"cannot read line {line!r}", where)
    return BhvContent(tuple(specs), tuple(modes), tuple(init), tuple(deferred), filename)


def parse_bhv(
    text: str,
    filename: str = "<bhv>",
    known_vars: Iterable[str] = (),
    domain: Domain | None = None,
    macros: Mapping[str, object] | None = None,
) -> HelmConfig:
    """Parse ``.bhv`` text into a validated :class:`HelmConfig` (``macros``: nsplug subset).

    A ``.bhv`` file carries no decision domain (pHelmIvP takes it from the ``.moos``
    file): without ``domain`` the paper's is used, with a warning."""
    return _validated(parse_bhv_content(text, filename, macros), known_vars, domain)


def _validated(
    content: BhvContent, known_vars: Iterable[str], domain: Domain | None
) -> HelmConfig:
    cfg = HelmConfig(
        content.behaviors,
        content.modes,
        content.initialize,
        domain or default_domain(content.source),
        initialize_deferred=content.initialize_deferred,
        source=content.source,
    )
    return cfg.validate(known_vars)


def read_bhv_file(
    path: str | Path, macros: Mapping[str, object] | None = None, *, nsplug: bool = True
) -> BhvContent:
    """Read a ``.bhv`` file's declarations (``nsplug``: see :func:`parse_bhv_content`); a
    missing or unreadable file is an AssetError."""
    return parse_bhv_content(read_text_file(path, "behavior file"), str(path), macros,
                             nsplug=nsplug)


def load_bhv(
    path: str | Path,
    known_vars: Iterable[str] = (),
    domain: Domain | None = None,
    macros: Mapping[str, object] | None = None,
) -> HelmConfig:
    """Read and parse a ``.bhv`` file; errors name ``path:line``."""
    return _validated(read_bhv_file(path, macros), known_vars, domain)
