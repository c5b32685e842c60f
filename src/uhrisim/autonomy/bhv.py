"""Loader for MOOS-IvP ``.bhv`` behavior files.

Understood: ``initialize VAR = value [, VAR = value]`` (and ``initialize_``), ``set VAR =
VALUE { conditions } ELSEVALUE`` mode blocks (multi-line), ``Behavior = BHV_X { key =
value ... }`` blocks, ``//`` comments. ``$(MACRO)`` substitution is not supported (it is
an nsplug feature, not the helm's). Anything else is a ConfigError naming ``file:line`` -
nothing is silently dropped.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from uhrisim.autonomy.config import HelmConfig, build_behavior_spec
from uhrisim.autonomy.domain import Domain
from uhrisim.autonomy.modes import parse_mode_entry
from uhrisim.autonomy.params import parse_flag
from uhrisim.core.errors import AssetError, ConfigError

__all__ = ["load_bhv", "parse_bhv"]


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


def parse_bhv(
    text: str,
    filename: str = "<bhv>",
    known_vars: Iterable[str] = (),
    domain: Domain | None = None,
) -> HelmConfig:
    """Parse ``.bhv`` text into a validated :class:`HelmConfig`."""
    lines = [_strip_comment(s) for s in text.splitlines()]
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
    path: str | Path, known_vars: Iterable[str] = (), domain: Domain | None = None
) -> HelmConfig:
    """Read and parse a ``.bhv`` file; errors name ``path:line``."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise AssetError(f"{p}: cannot read behavior file ({e.strerror})") from e
    return parse_bhv(text, str(p), known_vars, domain)
