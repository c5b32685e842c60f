"""MOOS mission files (``.moos``) and the pHelmIvP configuration in them.

A MOOS-IvP user's mission is a ``.moos`` file: global lines (``ServerPort = 9000``,
``Community = videoray``, ``LatOrigin = ...``) and one ``ProcessConfig = NAME { ... }``
block per application. :func:`load_helm_from_moos` reads the pHelmIvP block, the
``.bhv`` file(s) it names and its decision domain into a :class:`HelmConfig`, so a
simulation runs the user's own helm configuration, checked as pHelmIvP checks it.

Reading follows MOOS's own reader (MOOS_Jul2724 libMOOS/Utils: MOOSFileReader.cpp,
ProcessConfigReader.cpp): ``//`` starts a comment anywhere on a line; a block is found by
``ProcessConfig = NAME`` compared without blanks and without regard to case (the first
such block counts), and opens with a line that starts with ``{``; inside a block every
blank is removed from a line (``Behaviors = my file.bhv`` names ``myfile.bhv``), a line
with nothing after ``=`` is skipped, and the block ends at a line starting with ``}``;
a line without ``=`` is skipped (with a warning here).
``${NAME}`` is replaced by a ``define: NAME = value`` line of the file (MOOS would also look
in the shell environment; here an unknown name is an error, so a run does not depend on
the shell). Neither MOOS nor pHelmIvP runs nsplug: MOOS skips a ``#ifdef`` line (it has no
``=``), so every branch would apply, and keeps ``$(NAME)`` literally; such lines, in the
``.moos`` file or in the ``.bhv`` files its pHelmIvP block names, are ConfigErrors at
``file:line`` (:func:`uhrisim.autonomy.bhv.refuse_nsplug`): expand a meta file with nsplug
first, as MOOS-IvP missions' launch scripts do.

pHelmIvP's block (pHelmIvP/HelmIvP.cpp:1279-1333): ``Behaviors`` (repeatable; a file
named twice is refused), ``Domain`` (repeatable: ``name:low:high:npts[:optional]`` or
``name:low:high:delta=d``), ``ok_skew``, ``start_engaged`` (aliases ``start_in_drive``,
``active_start``), ``contact_max_age`` (10..1800 s), ``verbose`` and the other keys it
knows; ``AppTick``, ``CommsTick``, ``MaxAppTick`` belong to every MOOS app. pHelmIvP
refuses to run (MALCONFIG) on any line it does not handle, and so does this loader: a
ConfigError naming ``file:line``. Relative ``.bhv`` paths are taken from the ``.moos``
file's folder (pHelmIvP opens them from its working directory, which is the mission
folder when a mission is launched as usual).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from uhrisim.autonomy.bhv import read_bhv_file, refuse_nsplug, strip_comment
from uhrisim.autonomy.config import HelmConfig, HelmSettings, axis_from
from uhrisim.autonomy.domain import Domain, DomainAxis
from uhrisim.autonomy.params import to_bool, to_float
from uhrisim.core.errors import ConfigError
from uhrisim.core.files import read_text_file

__all__ = [
    "MoosFile",
    "MoosLine",
    "helm_domain",
    "load_helm_from_moos",
    "load_moos",
    "parse_moos",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MoosLine:
    """One ``key = value`` line: key as written, value as MOOS hands it over, and where."""

    key: str
    value: str
    where: str


@dataclass(frozen=True)
class MoosFile:
    """A parsed ``.moos`` file: its global lines and its ProcessConfig blocks by name."""

    path: str
    global_lines: tuple[MoosLine, ...]
    blocks: Mapping[str, tuple[MoosLine, ...]] = field(default_factory=dict)
    block_wheres: Mapping[str, str] = field(default_factory=dict)

    def global_value(self, key: str) -> str | None:
        """The first global line with this key (any case), else None."""
        for line in self.global_lines:
            if line.key.lower() == key.lower():
                return line.value
        return None

    def block(self, name: str) -> tuple[MoosLine, ...]:
        """The lines of ``ProcessConfig = name`` (name compared without regard to case)."""
        for found, lines in self.blocks.items():
            if found.lower() == name.lower():
                return lines
        known = ", ".join(self.blocks) or "none"
        raise ConfigError(f"no ProcessConfig = {name} block (blocks: {known})", self.path)


_DEFINE = re.compile(r"^define\s*:\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.*)$", re.IGNORECASE)
_EXPAND = re.compile(r"\$\{([^}]*)\}")


def parse_moos(text: str, filename: str = "<moos>") -> MoosFile:
    """Parse ``.moos`` text (module docstring); errors are ConfigErrors at ``file:line``."""
    lines = [strip_comment(s) for s in text.splitlines()]
    refuse_nsplug(lines, filename, "MOOS", "skips the line, so every branch would apply")
    defines: dict[str, str] = {}
    global_lines: list[MoosLine] = []
    blocks: dict[str, tuple[MoosLine, ...]] = {}
    block_wheres: dict[str, str] = {}
    header: tuple[str, str] | None = None  # (block name, where) of the block being read
    current: list[MoosLine] | None = None  # its lines, once its '{' is seen

    def expand(s: str, where: str) -> str:
        def sub(m: re.Match) -> str:
            if m.group(1) not in defines:
                raise ConfigError(f"${{{m.group(1)}}} is not defined in the file", where)
            return defines[m.group(1)]

        return _EXPAND.sub(sub, s)

    for i, raw in enumerate(lines):
        where = f"{filename}:{i + 1}"
        line = raw.strip()
        if not line:
            continue
        if header is not None and current is None:  # the line after ProcessConfig = X
            if not line.startswith("{"):
                raise ConfigError(f"ProcessConfig = {header[0]} must open with '{{'", where)
            current = []
            line = line[1:].strip()
            if not line:
                continue
        if header is not None and current is not None:
            if line.startswith("}"):
                if header[0] not in blocks:  # the first block of a name counts (MOOS GoTo)
                    blocks[header[0]], block_wheres[header[0]] = tuple(current), header[1]
                header, current = None, None
                continue
            if line.startswith("{"):
                raise ConfigError("'{' inside a ProcessConfig block (missing '}'?)", where)
            compact = re.sub(r"[ \t\r]", "", expand(line, where))
            key, eq, value = compact.partition("=")
            if not eq:  # MOOS skips it (MOOSFileReader.cpp:192-211): say so
                log.warning("%s: %r has no '=': MOOS ignores the line", where, line)
                continue
            if value:
                current.append(MoosLine(key, value, where))
            continue
        m = _DEFINE.match(line)
        if m:
            defines[m.group(1)] = expand(m.group(2).strip(), where)
            continue
        key, eq, value = line.partition("=")
        if not eq:
            log.warning("%s: %r has no '=': MOOS ignores the line", where, line)
            continue
        key, value = key.strip(), expand(value.strip(), where)
        if key.lower() == "processconfig":
            name = re.sub(r"\s", "", value)
            if not name:
                raise ConfigError("ProcessConfig needs a name", where)
            if "{" in name:  # "ProcessConfig = pHelmIvP {": MOOS finds no block there
                raise ConfigError("put the '{' of a ProcessConfig block on its own line", where)
            header = (name, where)
            continue
        global_lines.append(MoosLine(key, value, where))
    if header is not None:
        raise ConfigError(f"ProcessConfig = {header[0]} is never closed with '}}'", header[1])
    return MoosFile(filename, tuple(global_lines), blocks, block_wheres)


def load_moos(path: str | Path) -> MoosFile:
    """Read and parse a ``.moos`` file; errors name ``path:line``."""
    return parse_moos(read_text_file(path, "MOOS file"), str(path))


def _domain_axis(value: str, where: str) -> DomainAxis:
    """One ``Domain = name:low:high:npts[:optional]`` line (``,`` may stand for ``:``)."""
    name, _, rest = value.replace(",", ":").partition(":")
    if not name or rest.count(":") not in (2, 3):
        raise ConfigError(f"Domain must read name:low:high:npts[:optional], got {value!r}", where)
    return axis_from(name, rest, where)


def helm_domain(lines: Iterable[MoosLine]) -> Domain | None:
    """The decision domain of a pHelmIvP block's ``Domain`` lines (None if it has none)."""
    axes: list[DomainAxis] = []
    for line in lines:
        if line.key.lower() == "domain":
            axis = _domain_axis(line.value, line.where)
            if any(a.name == axis.name for a in axes):
                raise ConfigError(f"Domain {axis.name} is given twice", line.where)
            axes.append(axis)
    return Domain(tuple(axes)) if axes else None


# pHelmIvP's own keys (HelmIvP.cpp:1279-1325) and every MOOS app's (AppCastingMOOSInstrument
# .cpp:471-474); the ones the simulated helm has no use for are accepted and ignored
_IGNORED_KEYS = frozenset({
    "apptick", "commstick", "maxapptick", "term_report_interval", "max_appcast_events",
    "verbose", "seed_random", "goals_mandatory", "helm_alias", "standby", "allow_park",
    "park_on_allstop", "node_skew", "helm_prefix", "hold_on_app", "hold_on_apps",
    "nav_grace", "bhv_dir_not_found_ok", "bhv_dirs_not_found_ok", "ivp_behavior_dir",
    "ivp_behavior_dirs", "pmgen", "other_override_var", "app_logging", "deprecated_ok",
})  # fmt: skip
_ENGAGE_KEYS = frozenset({"start_engaged", "start_indrive", "start_in_drive", "active_start"})


def _settings(lines: Iterable[MoosLine]) -> HelmSettings:
    settings = HelmSettings(start_engaged=False)  # pHelmIvP starts parked (m_has_control)
    for line in lines:
        k = line.key.lower()
        if k in _ENGAGE_KEYS:
            settings = replace(settings, start_engaged=to_bool(line.value, line.key, line.where))
        elif k == "ok_skew":
            any_skew = line.value.lower() == "any"
            skew = None if any_skew else to_float(line.value, line.key, line.where)
            if skew is not None and skew < 0:
                raise ConfigError(f"ok_skew must be >= 0 or 'any', got {line.value!r}", line.where)
            settings = replace(settings, ok_skew=skew)
        elif k == "contact_max_age":
            age = to_float(line.value, line.key, line.where)
            if not 10.0 <= age <= 1800.0:
                raise ConfigError(
                    f"contact_max_age must be in [10, 1800] s, got {age:g}", line.where
                )
            settings = replace(settings, contact_max_age=age)
    return settings


def load_helm_from_moos(path: str | Path, process: str = "pHelmIvP") -> HelmConfig:
    """The :class:`HelmConfig` of a ``.moos`` file's ``ProcessConfig = <process>`` block:
    its behavior file(s), domain and settings, validated as pHelmIvP would (module
    docstring). Condition variables are not required to have a known poster: in a MOOS
    community any app may post them (pHelmIvP does not check either)."""
    moos = load_moos(path)
    for key in ("Community", "LatOrigin", "LongOrigin"):  # HelmIvP.cpp:1251-1262
        if moos.global_value(key) is None:
            raise ConfigError(f"no {key} = ... line: pHelmIvP would not start (MALCONFIG)",
                              moos.path)
    lines = moos.block(process)
    block_where = moos.block_wheres.get(process, moos.path)
    folder = Path(moos.path).parent
    known = {"behaviors", "domain", "ok_skew", "contact_max_age"} | _ENGAGE_KEYS | _IGNORED_KEYS
    bhv_files: dict[str, Path] = {}
    for line in lines:
        k = line.key.lower()
        if k not in known:
            raise ConfigError(
                f"{process} does not handle {line.key!r} (pHelmIvP would not start: "
                "MALCONFIG)", line.where,
            )
        if k == "behaviors":
            if line.value in bhv_files:  # HelmIvP::addBehaviorFile refuses a repeat
                raise ConfigError(f"Behaviors file {line.value} is named twice", line.where)
            bhv_files[line.value] = folder / line.value
    if not bhv_files:
        raise ConfigError(f"{process} names no Behaviors file", block_where)
    domain = helm_domain(lines)
    if domain is None:
        raise ConfigError(
            f"{process} has no Domain lines: pHelmIvP would run with an empty decision "
            "domain and every behavior idle (give e.g. Domain = course:0:359:360)",
            block_where,
        )
    settings = _settings(lines)
    # pHelmIvP reads its files in the order of a sorted set (Populator_BehaviorSet::populate)
    parts = [read_bhv_file(bhv_files[name], nsplug=False) for name in sorted(bhv_files)]
    cfg = HelmConfig(
        behaviors=tuple(b for part in parts for b in part.behaviors),
        modes=tuple(m for part in parts for m in part.modes),
        initialize=tuple(v for part in parts for v in part.initialize),
        domain=domain,
        initialize_deferred=tuple(v for part in parts for v in part.initialize_deferred),
        settings=settings,
        source=moos.path,
    )
    return cfg.validate(None)
