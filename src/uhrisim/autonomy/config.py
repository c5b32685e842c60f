"""Helm configuration: frozen, comparable, built from a ``.bhv`` file or a plain mapping.

The mapping form (scenario YAML)::

    initialize: {DEPLOY: false, RETURN: false}        # or ["DEPLOY = false", ...]
    modes:
      - "MODE = ACTIVE { DEPLOY = true } INACTIVE"     # or {var, value, conditions, else}
    behaviors:
      - {type: Loiter, name: loiter, priority: 100, condition: "MODE==LOITERING",
         polygon: "format=radial, x=10, y=-20, radius=20, pts=8", speed: 0.5}
    domain: {course: [0, 359, 360], speed: [0, 5, 26], depth: [0, 100, 101, optional]}

Every value goes through the same converters as ``.bhv`` lines, so a ``.bhv`` file and its
YAML twin give EQUAL :class:`HelmConfig` objects (source locations are not compared).
Files are read above this module: :mod:`uhrisim.autonomy.bhv` (``.bhv``) and
:mod:`uhrisim.autonomy.moos_file` (a ``.moos`` mission's pHelmIvP block).
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from uhrisim.autonomy.behaviors import REGISTRY, Behavior, behavior_class
from uhrisim.autonomy.behaviors.base import COMMON_HANDLERS, CommonParams, common_key
from uhrisim.autonomy.conditions import Value
from uhrisim.autonomy.domain import Domain, DomainAxis
from uhrisim.autonomy.modes import ModeEntry, parse_mode_entry
from uhrisim.autonomy.params import moos_value, parse_flag, to_float
from uhrisim.core.errors import ConfigError, warn_user

__all__ = [
    "HELM_POSTED_VARS",
    "NAV_VARS",
    "BehaviorSpec",
    "HelmConfig",
    "HelmSettings",
    "build_behavior_spec",
    "default_domain",
    "parse_domain",
]


@dataclass(frozen=True)
class HelmSettings:
    """Settings of the helm process itself (pHelmIvP's ProcessConfig block).

    ``start_engaged``: drive from the first iteration (pHelmIvP's ``start_engaged``; it
    defaults to false there, and a ``.moos`` file's helm keeps that default; a helm given
    by a ``.bhv`` file or a scenario mapping is the simulation's own and starts engaged).
    While parked the helm waits for ``MOOS_MANUAL_OVERRIDE = false``.
    ``ok_skew`` (s, None = "any"): mail posted more than this before or after the helm's
    time is ignored (default 60, HelmIvP.cpp:65, 220-233).
    ``contact_max_age`` (s): a contact whose last report is older leaves the contact
    ledger - twice as old while a behavior uses it (default 45, HelmIvP.cpp:1268, 386).
    """

    start_engaged: bool = True
    ok_skew: float | None = 60.0
    contact_max_age: float = 45.0


def default_domain(where: str) -> Domain:
    """The paper's domain, used when none is given - with a warning naming ``where``."""
    domain = Domain.paper()
    msg = (f"{where}: no decision domain given; using the paper's course:0:359:360, "
           "speed:0:5:26, depth:0:100:101:optional")
    warn_user(msg, stacklevel=3)
    return domain

NAV_VARS = frozenset(
    {"NAV_X", "NAV_Y", "NAV_HEADING", "NAV_SPEED", "NAV_DEPTH", "NAV_LAT", "NAV_LONG", "NAV_YAW"}
)
HELM_POSTED_VARS = frozenset(
    {
        "DESIRED_HEADING",
        "DESIRED_SPEED",
        "DESIRED_DEPTH",
        "IVPHELM_STATE",
        "IVPHELM_ALLSTOP",
        "IVPHELM_BHV_ACTIVE",
        "IVPHELM_BHV_RUNNING",
        "IVPHELM_BHV_IDLE",
        "IVPHELM_BHV_COMPLETED",
        "BHV_ERROR",
        "BHV_WARNING",
        "LOITER_INDEX",
        "LOITER_ACQUIRE",
        "WPT_INDEX",
        "VIEW_POLYGON",
        "PSKEEP_MODE",
        "VIEW_SEGLIST",
        "VIEW_POINT",
        "MOOS_MANUAL_OVERRIDE",
        "NODE_REPORT",
    }
)
_CONTACT_VAR = re.compile(r"^[A-Za-z0-9_\-]+_NAV_(GROUP|TYPE)$")  # from NODE_REPORTs
REPEATABLE = frozenset(
    {
        "condition",
        "endflag",
        "runflag",
        "idleflag",
        "activeflag",
        "inactiveflag",
        "wptflag",
        "cycleflag",
    }
)


@dataclass(frozen=True)
class BehaviorSpec:
    """One behavior declaration: kind (``BHV_Loiter``), common and typed own parameters."""

    kind: str
    common: CommonParams
    params: Any
    where: str = field(default="", compare=False)
    condition_wheres: tuple[str, ...] = field(default=(), compare=False)

    @property
    def name(self) -> str:
        return self.common.name

    @property
    def is_template(self) -> bool:
        return self.common.templating == "spawn"

    def instantiate(self, name: str | None = None) -> Behavior:
        """A fresh behavior instance (a spawned copy gets ``name`` and loses templating)."""
        common = self.common
        if name is not None:
            common = replace(common, name=name, templating="")
        return REGISTRY[self.kind](common, self.params)

    def posted_vars(self) -> set[str]:
        c = self.common
        flags = c.endflags + c.runflags + c.idleflags + c.activeflags + c.inactiveflags
        flags += getattr(self.params, "wptflags", ()) + getattr(self.params, "cycleflags", ())
        return {v for v, _ in flags}


def build_behavior_spec(
    kind: str, items: Iterable[tuple[str, object, str]], where: str, exact_kind: bool = False
) -> BehaviorSpec:
    """Typed spec from ``(key, value, where)`` items; unknown key or bad value -> ConfigError
    (pHelmIvP refuses to start on either: MALCONFIG, BehaviorSet.cpp:311-327, 392-416).

    ``exact_kind``: the kind must be spelt as pHelmIvP knows it (``BHV_Loiter``), as in a
    ``.bhv`` file; a scenario mapping may say ``Loiter`` or ``loiter``."""
    cls = behavior_class(kind, where, exact=exact_kind)
    common, params = CommonParams(duration=cls.DEFAULT_DURATION), cls.Params()
    cond_wheres: list[str] = []
    duration_given = False
    for key, value, w in items:
        k = common_key(key)
        if k in COMMON_HANDLERS:
            common = COMMON_HANDLERS[k](common, value, k, w)
            duration_given |= k == "duration"
            if k == "condition":
                cond_wheres.extend([w] * (len(value) if isinstance(value, list | tuple) else 1))
        elif k in cls.HANDLERS:
            params = cls.HANDLERS[k](params, value, k, w)
        else:
            known = sorted([*COMMON_HANDLERS, *cls.HANDLERS])
            hint = difflib.get_close_matches(k, known, n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise ConfigError(f"{cls.KIND} has no parameter {key!r}{extra}", w)
    if not common.name:
        raise ConfigError(f"{cls.KIND} needs a name", where)
    if common.templating == "spawn" and not common.updates:
        raise ConfigError(f"spawn template {common.name!r} needs updates = VARIABLE", where)
    if common.duration == 0.0 and not duration_given and not common.perpetual:
        msg = (f"{where}: {cls.KIND} {common.name!r} has no duration: as in pHelmIvP it "
               "completes at its first running iteration (give duration = no-time-limit)")
        warn_user(msg)
    return BehaviorSpec(cls.KIND, common, params, where, tuple(cond_wheres))


def axis_from(name: str, v: object, where: str) -> DomainAxis:
    """One decision-space axis from ``low, high, npts [, optional]`` (a list or a ``:``- or
    ``,``-separated string), by pHelmIvP's rules (HelmIvP::handleConfigDomain,
    HelmIvP.cpp:1471-1518): ``npts`` may be given as ``delta=d``, ``high >= low``, and a
    one-point axis has ``low == high``."""
    parts = list(v) if isinstance(v, list | tuple) else str(v).replace(",", ":").split(":")
    optional = bool(parts) and str(parts[-1]).strip().lower() == "optional"
    if optional:
        parts = parts[:-1]
    if len(parts) != 3:
        raise ConfigError(f"domain axis {name!r} must be low, high, npts [, optional]", where)
    low, high = to_float(parts[0], name, where), to_float(parts[1], name, where)
    if high < low:
        raise ConfigError(f"domain axis {name!r}: high {high:g} is below low {low:g}", where)
    if str(parts[2]).strip().lower().startswith("delta="):
        delta = to_float(str(parts[2]).split("=", 1)[1], f"{name} delta", where)
        if not 0.0 < delta <= high - low:
            raise ConfigError(f"domain axis {name!r}: delta must be in (0, {high - low:g}]",
                              where)
        npts = int(min((high - low) / delta + 1, 2.0**62))  # too many is refused below
    else:
        n = to_float(parts[2], name, where)
        if n != int(n) or n < 1:
            raise ConfigError(f"domain axis {name!r} npts must be a whole number >= 1, "
                              f"got {parts[2]!r}", where)
        npts = int(n)
    if high == low and npts != 1:
        raise ConfigError(f"domain axis {name!r}: low == high needs npts 1", where)
    try:
        return DomainAxis(name, low, high, npts, optional=optional, wrap=name == "course")
    except ConfigError as error:
        raise ConfigError(error.problem, where) from None


def parse_domain(v: object, where: str = "domain") -> Domain:
    """Domain from {name: [low, high, npts(, optional)]} or ["course:0:359:360", ...]."""
    if isinstance(v, Mapping):
        axes = [axis_from(str(k), val, f"{where}.{k}") for k, val in v.items()]
    elif isinstance(v, list | tuple):
        axes = []
        for s in v:
            name, _, rest = str(s).partition(":")
            axes.append(axis_from(name.strip(), rest, where))
    else:
        raise ConfigError("domain must be a mapping or a list of 'name:low:high:npts'", where)
    try:
        return Domain(tuple(axes))
    except ConfigError as error:
        raise ConfigError(error.problem, where) from None


def _items_of(m: Mapping[str, Any], where: str) -> list[tuple[str, object, str]]:
    items = []
    for k, v in m.items():
        if k in ("type", "kind"):
            continue
        w = f"{where}.{k}"
        if str(k).lower() in REPEATABLE and isinstance(v, list | tuple):
            items.extend((k, x, w) for x in v)
        else:
            items.append((k, v, w))
    return items


@dataclass(frozen=True)
class HelmConfig:
    """Everything a :class:`~uhrisim.autonomy.helm.Helm` needs, frozen and comparable."""

    behaviors: tuple[BehaviorSpec, ...] = ()
    modes: tuple[ModeEntry, ...] = ()
    initialize: tuple[tuple[str, Value], ...] = ()
    domain: Domain = field(default_factory=Domain.paper)
    initialize_deferred: tuple[tuple[str, Value], ...] = ()
    settings: HelmSettings = field(default_factory=HelmSettings)
    source: str = field(default="", compare=False)

    @property
    def mode_vars(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(e.var for e in self.modes))

    def posted_vars(self) -> set[str]:
        """Variables this helm initialises or posts itself."""
        out = {v for v, _ in self.initialize + self.initialize_deferred}
        out |= set(self.mode_vars) | set(HELM_POSTED_VARS)
        for b in self.behaviors:
            out |= b.posted_vars()
        return out

    def validate(self, known_vars: Iterable[str] | None = ()) -> HelmConfig:
        """Check names, domain needs and that every condition variable has a source.

        A helm with no behavior is refused. Names: no behavior's name may begin with
        another's (templates aside), as pHelmIvP refuses (BehaviorSet.cpp:288-295,
        1208-1221). ``known_vars``: variables posted from
        outside (contact-manager alert variables, viewer buttons, the simulation); None
        skips the source check (a MOOS community has other apps posting: pHelmIvP itself
        does not check, a condition on a variable nobody posts is simply false). Returns
        self; raises ConfigError with the location.
        """
        for a in ("course", "speed"):
            if not self.domain.has(a) or self.domain.axis(a).optional:
                raise ConfigError(f"the helm domain needs a non-optional {a!r} axis", "domain")
        names: dict[str, str] = {}
        for b in self.behaviors:
            if not b.is_template:
                for other, where in names.items():
                    if b.name.startswith(other) or other.startswith(b.name):
                        raise ConfigError(
                            f"duplicate behavior name {b.name!r}: pHelmIvP counts names "
                            f"that begin with another as duplicates (also {other!r} at "
                            f"{where})", b.where,
                        )
                names[b.name] = b.where
            axes = {"BHV_ConstantDepth": ("depth",), "BHV_ConstantHeading": ("course",),
                    "BHV_ConstantSpeed": ("speed",), "BHV_MaxSpeed": ("speed",)}.get(
                        b.kind, ("course", "speed"))
            for a in axes:
                if not self.domain.has(a):
                    raise ConfigError(f"{b.kind} {b.name!r} needs a {a!r} domain axis", b.where)
        if known_vars is not None:
            self._check_condition_sources(set(known_vars))
        if not self.behaviors:
            raise ConfigError("the helm declares no behaviors: it could decide nothing",
                              self.source or "helm")
        return self

    def _check_condition_sources(self, known_vars: set[str]) -> None:
        """Every condition variable is posted or initialised by something (ConfigError)."""
        known = self.posted_vars() | set(NAV_VARS) | known_vars

        def check(var: str, where: str, owner: str) -> None:
            if var not in known and not _CONTACT_VAR.match(var):
                raise ConfigError(
                    f"{owner} condition uses {var!r}, which nothing posts or initialises", where
                )

        for e in self.modes:
            for var in sorted(e.variables()):
                check(var, e.where, f"mode {e.var}={e.value}")
        for b in self.behaviors:
            for i, c in enumerate(b.common.conditions):
                w = b.condition_wheres[i] if i < len(b.condition_wheres) else b.where
                for var in sorted(c.variables()):
                    check(var, w, f"behavior {b.name!r}")

    @classmethod
    def from_mapping(
        cls, m: Mapping[str, Any], where: str = "helm", known_vars: Iterable[str] = ()
    ) -> HelmConfig:
        """Build from the scenario mapping form (module docstring) and validate."""
        if not isinstance(m, Mapping):
            raise ConfigError("helm configuration must be a mapping", where)
        allowed = ("initialize", "modes", "behaviors", "domain")
        for k in m:
            if k not in allowed:
                hint = difflib.get_close_matches(str(k), allowed, n=1)
                extra = f" (did you mean {hint[0]!r}?)" if hint else ""
                raise ConfigError(f"unknown key {k!r}{extra}", where)
        init: list[tuple[str, Value]] = []
        raw_init = m.get("initialize", {}) or {}
        if isinstance(raw_init, Mapping):
            init = [
                (str(k), moos_value(v, f"{where}.initialize.{k}")) for k, v in raw_init.items()
            ]
        else:
            for i, s in enumerate(raw_init):
                init.append(parse_flag(s, "initialize", f"{where}.initialize[{i}]"))
        modes = []
        for i, e in enumerate(m.get("modes", []) or []):
            w = f"{where}.modes[{i}]"
            if isinstance(e, Mapping):
                conds = e.get("conditions", [])
                conds = [conds] if isinstance(conds, str) else list(conds)
                text = f"{e['var']} = {e['value']} {{ {' ; '.join(map(str, conds))} }}"
                text += f" {e['else']}" if e.get("else") else ""
                modes.append(parse_mode_entry(text, w))
            else:
                modes.append(parse_mode_entry(str(e), w))
        specs = []
        for i, b in enumerate(m.get("behaviors", []) or []):
            w = f"{where}.behaviors[{i}]"
            if not isinstance(b, Mapping) or not ("type" in b or "kind" in b):
                raise ConfigError("each behavior needs a 'type' (e.g. Loiter)", w)
            specs.append(build_behavior_spec(b.get("type", b.get("kind")), _items_of(b, w), w))
        if "domain" in m:
            domain = parse_domain(m["domain"], f"{where}.domain")
        else:
            domain = default_domain(where)
        cfg = cls(tuple(specs), tuple(modes), tuple(init), domain, source=where)
        return cfg.validate(known_vars)
