"""Node reports and the contact manager (pBasicContactMgr semantics).

NODE_REPORT (docs/reference/helm.md): one comma-separated ``KEY=value`` string, e.g.
``NAME=videoray,X=12.30,Y=-4.10,SPD=1.20,HDG=87.00,DEP=1.50,TYPE=UUV,TIME=12.25,LENGTH=1``.
Keys are case-insensitive; aliases SPEED/SPD, HEADING/HDG, DEPTH/DEP, LONG/LON; unknown
keys are kept (in order) and written back by :func:`format_node_report`. Frame: x east,
y north (m), heading compass degrees, speed m/s, depth m (positive down). ``TIME`` must
be on the same clock as the helm's ``t`` (simulation seconds, or an epoch offset of it).

The contact manager keeps one record per contact (latest report, dead-reckoned by a
linear extrapolator with decay) and posts each configured alert once per contact when
the contact comes within ``alert_range`` of own ship, or within ``cpa_range`` with a
projected CPA (both on current course and speed, over ``cpa_time`` s) inside
``alert_range``. Alert values are patterns with ``$[VNAME]``, ``$[X]``, ``$[Y]``,
``$[HDG]``, ``$[SPD]``, ``$[DEP]``, ``$[VTYPE]``, ``$[UTIME]``. It also posts
``CONTACTS_LIST``, ``CONTACTS_ALERTED``, ``CONTACTS_RETIRED`` when they change. Contacts not
heard from for ``contact_max_age`` s are retired.

Relays (a uhrisim extension, not in pBasicContactMgr): ``relays`` post a pattern (same
substitutions) every time a named contact's report changes the expanded text, e.g.
``{var: DEPTH_UPDATES, pattern: "depth=$[DEP]", contact: diver}`` makes the ROV's
ConstantDepth (``updates = DEPTH_UPDATES``) follow the diver's depth, as in the paper.
"""

from __future__ import annotations

import difflib
import logging
import math
import re
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from uhrisim.autonomy.behaviors.base import OwnNav
from uhrisim.autonomy.cpa import cpa_distance
from uhrisim.autonomy.extrapolator import LinearExtrapolator
from uhrisim.autonomy.params import to_decay, to_float, to_str
from uhrisim.core.errors import ConfigError

__all__ = [
    "AlertSpec",
    "ContactManager",
    "ContactManagerConfig",
    "ContactRecord",
    "NodeReport",
    "RelaySpec",
    "format_node_report",
    "node_report_text",
    "parse_node_report",
]

log = logging.getLogger(__name__)

_ALIASES = {
    "SPD": "SPD",
    "SPEED": "SPD",
    "HDG": "HDG",
    "HEADING": "HDG",
    "DEP": "DEP",
    "DEPTH": "DEP",
    "LON": "LON",
    "LONG": "LON",
    "UTC_TIME": "TIME",
}
_NUMERIC = ("X", "Y", "SPD", "HDG", "DEP", "LAT", "LON", "TIME", "LENGTH")


@dataclass(slots=True, unsafe_hash=True)
class NodeReport:
    """A parsed NODE_REPORT (MOOS frame: x east, y north, compass heading). Hashed by its
    fields, as a frozen one; not frozen, which would make one (every report, every tick)
    several times as costly: read it, do not change it."""

    name: str
    x: float
    y: float
    speed: float = 0.0
    heading: float = 0.0
    depth: float = 0.0
    time: float | None = None
    type: str = ""
    mode: str = ""
    lat: float | None = None
    lon: float | None = None
    length: float | None = None
    extra: tuple[tuple[str, str], ...] = ()


_KNOWN_KEYS = frozenset(("NAME", "TYPE", "MODE", *_NUMERIC))
#: Known keys and aliases as reports usually spell them (upper, lower or title case, no
#: spaces), to the key they stand for: a look-up instead of strip, upper and alias.
_KEY_SPELT = {spelt: _ALIASES.get(k, k) for k in (*_KNOWN_KEYS, *_ALIASES)
              for spelt in (k, k.lower(), k.title())}


#: Reports made by :func:`node_report_text` with ``remember=True``, by their exact text,
#: oldest first: what :func:`parse_node_report` would return for that text (built from
#: the same field strings), so a report made and read in one process is parsed once.
_MADE: OrderedDict[str, NodeReport] = OrderedDict()
_MADE_KEPT = 256  # reports remembered at most (a few ticks of a large team)


#: The layout :func:`node_report_text` writes (upper-case keys in its order, no extra
#: keys; values without spaces, commas or '=', so nothing to strip): read by one match,
#: the fields as the general parser reads them.
_WRITTEN = re.compile(",".join(
    [f"{key}=([^,=\\s]+)" for key in ("NAME", "X", "Y", "SPD", "HDG", "DEP")]) + "".join(
    [f"(?:,{key}=([^,=\\s]+))?" for key in ("LAT", "LON", "TYPE", "MODE", "TIME", "LENGTH")]))


def parse_node_report(text: str) -> NodeReport:
    """Parse a NODE_REPORT string; malformed input -> ConfigError (a ValueError)."""
    if not isinstance(text, str):
        return _parse_text(text)
    made = _MADE.get(text)
    if made is not None:
        return made
    written = _WRITTEN.fullmatch(text)
    if written is not None:
        report = _parse_written(*written.groups())
        if report is not None:
            return report
    return _parse_text(text)


def _parse_written(name: str, x: str, y: str, spd: str, hdg: str, dep: str, lat: str | None,
                   lon: str | None, type: str | None, mode: str | None, time: str | None,
                   length: str | None) -> NodeReport | None:
    """:func:`_parse_text`'s report from the field texts of :data:`_WRITTEN`; None where a
    number does not read or is not finite (the general parser then says which)."""
    try:
        xf, yf, speed, heading, depth = float(x), float(y), float(spd), float(hdg), float(dep)
        latf = None if lat is None else float(lat)
        lonf = None if lon is None else float(lon)
        timef = None if time is None else float(time)
        lengthf = None if length is None else float(length)
    except ValueError:
        return None
    if not math.isfinite(xf + yf + speed + heading + depth + (latf or 0.0) + (lonf or 0.0)
                         + (timef or 0.0) + (lengthf or 0.0)):  # (or the sum overflows)
        return None
    return NodeReport(name, xf, yf, speed, heading % 360.0, depth, timef, type or "",
                      mode or "", latf, lonf, lengthf)


def _parse_text(text: str) -> NodeReport:
    """:func:`parse_node_report` of a text not made here."""
    if not isinstance(text, str) or not text.strip():
        raise ConfigError("empty node report", "NODE_REPORT")
    fields: dict[str, str] = {}
    extra: list[tuple[str, str]] = []
    for part in text.split(","):
        k, has_value, v = part.partition("=")
        if not has_value:
            if not part.strip():
                continue
            raise ConfigError(f"field {part.strip()!r} is not KEY=value", "NODE_REPORT")
        key = _KEY_SPELT.get(k)
        if key is None:
            key = k.strip().upper()
            key = _ALIASES.get(key, key)
            if key not in _KNOWN_KEYS:
                extra.append((k.strip(), v.strip()))
                continue
        fields[key] = v.strip()
    for need in ("NAME", "X", "Y"):
        if not fields.get(need):
            raise ConfigError(f"node report lacks {need}=: {text!r}", "NODE_REPORT")
    num: dict[str, float] = {}
    for key in _NUMERIC:
        value = fields.get(key)
        if value is None:
            continue
        try:
            number = float(value)
        except ValueError:
            raise ConfigError(f"{key}={value!r} is not a number", "NODE_REPORT") from None
        if not math.isfinite(number):
            raise ConfigError(f"{key}={value!r} is not finite", "NODE_REPORT")
        num[key] = number
    got = num.get
    return NodeReport(fields["NAME"], num["X"], num["Y"], got("SPD", 0.0), got("HDG", 0.0) % 360.0,
                      got("DEP", 0.0), got("TIME"), fields.get("TYPE", ""),
                      fields.get("MODE", ""), got("LAT"), got("LON"), got("LENGTH"), tuple(extra))


_FIXED = {nd: f".{nd}f" for nd in range(10)}  # format specs of 0..9 decimals


def _f(v: float, nd: int) -> str:
    """``v`` to ``nd`` decimals without trailing zeros or point (``-0`` as ``0``)."""
    s = format(v, _FIXED[nd]).rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def format_node_report(r: NodeReport) -> str:
    """NODE_REPORT string (X/Y/SPD/DEP to 1 mm or 1 mm/s, HDG 0.01 deg, TIME 1 ms)."""
    return node_report_text(r.name, r.x, r.y, r.speed, r.heading, r.depth, lat=r.lat,
                            lon=r.lon, type=r.type, mode=r.mode, time=r.time,
                            length=r.length, extra=r.extra)


def node_report_text(
    name: str, x: float, y: float, speed: float, heading: float, depth: float, *,
    lat: float | None = None, lon: float | None = None, type: str = "", mode: str = "",
    time: float | None = None, length: float | None = None,
    extra: tuple[tuple[str, str], ...] = (), remember: bool = False,
) -> str:
    """:func:`format_node_report` of the fields of a :class:`NodeReport`, without making
    one (a bridge posting ten reports a simulated second saves the object).

    ``remember``: also keep the parsed report of the text (for a reader in this process,
    e.g. a helm: :func:`parse_node_report` of the text then costs a dictionary look-up)."""
    for label, text in (("name", name), ("type", type), ("mode", mode)):
        if "," in text or "=" in text:
            raise ConfigError(f"NODE_REPORT {label} {text!r} may not contain ',' or '='",
                              "NODE_REPORT")
    xs, ys, spds, hdgs, deps = _f(x, 3), _f(y, 3), _f(speed, 3), _f(heading, 2), _f(depth, 3)
    parts = [f"NAME={name}", f"X={xs}", f"Y={ys}", f"SPD={spds}", f"HDG={hdgs}", f"DEP={deps}"]
    lats = lons = times = lengths = None
    if lat is not None:
        lats = _f(lat, 8)
        parts.append(f"LAT={lats}")
    if lon is not None:
        lons = _f(lon, 8)
        parts.append(f"LON={lons}")
    if type:
        parts.append(f"TYPE={type}")
    if mode:
        parts.append(f"MODE={mode}")
    if time is not None:
        times = _f(time, 3)
        parts.append(f"TIME={times}")
    if length is not None:
        lengths = _f(length, 3)
        parts.append(f"LENGTH={lengths}")
    parts += [f"{k}={v}" for k, v in extra]
    text = ",".join(parts)
    if remember and not extra and name and (  # else the parser's own rules decide
            name == name.strip() and type == type.strip() and mode == mode.strip()) and (
            math.isfinite(x + y + speed + heading + depth + (lat or 0.0) + (lon or 0.0)
                          + (time or 0.0) + (length or 0.0))):  # (or the sum overflows)
        _MADE[text] = NodeReport(  # what the parser reads from these field texts
            name, float(xs), float(ys), float(spds), float(hdgs) % 360.0, float(deps),
            None if times is None else float(times), type, mode,
            None if lats is None else float(lats), None if lons is None else float(lons),
            None if lengths is None else float(lengths))
        if len(_MADE) > _MADE_KEPT:
            _MADE.popitem(last=False)
    return text


@dataclass(frozen=True)
class AlertSpec:
    """One alert (pBasicContactMgr ``alert = id=.., var=.., val=.., alert_range=..``)."""

    id: str
    var: str
    pattern: str = "name=$[VNAME] # contact=$[VNAME]"
    alert_range: float = 1000.0
    cpa_range: float = 0.0
    cpa_time: float = 60.0
    match_type: tuple[str, ...] = ()
    ignore_type: tuple[str, ...] = ()

    def applies_to(self, vtype: str) -> bool:
        t = vtype.lower()
        if self.match_type and t not in self.match_type:
            return False
        return t not in self.ignore_type


def _types(v: object, key: str, where: str) -> tuple[str, ...]:
    vals = v if isinstance(v, list | tuple) else str(v).split(",")
    return tuple(sorted({str(x).strip().lower() for x in vals if str(x).strip()}))


_ALERT_KEYS = {
    "id": to_str,
    "var": to_str,
    "val": to_str,
    "pattern": to_str,
    "alert_range": to_float,
    "cpa_range": to_float,
    "cpa_time": to_float,
    "match_type": _types,
    "ignore_type": _types,
}


def parse_alert(v: object, where: str) -> AlertSpec:
    """Alert from a mapping or the MOOS string ``id=trail, var=TRAIL_INFO, val="..", ...``."""
    if isinstance(v, Mapping):
        items = list(v.items())
    else:
        s = str(v)
        items = []
        for part in _split_outside_quotes(s):
            if "=" not in part:
                raise ConfigError(f"alert field {part.strip()!r} is not key=value", where)
            k, val = part.split("=", 1)
            items.append((k.strip(), val.strip()))
    got: dict[str, Any] = {}
    for k, val in items:
        key = str(k).lower()
        if key not in _ALERT_KEYS:
            hint = difflib.get_close_matches(key, list(_ALERT_KEYS), n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise ConfigError(f"unknown alert field {k!r}{extra}", where)
        got["pattern" if key == "val" else key] = _ALERT_KEYS[key](val, key, where)
    if "var" not in got:
        raise ConfigError("alert needs var=", where)
    got.setdefault("id", got["var"].lower())
    return AlertSpec(**got)


def _split_outside_quotes(s: str) -> list[str]:
    out, cur, quote = [], [], ""
    for ch in s:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == ",":
            out.append("".join(cur))
            cur = []
            continue
        cur.append(ch)
    out.append("".join(cur))
    return [p for p in out if p.strip()]


@dataclass(frozen=True)
class RelaySpec:
    """Post ``pattern`` expanded for ``contact`` to ``var`` whenever the text changes."""

    var: str
    pattern: str
    contact: str


def parse_relay(v: object, where: str) -> RelaySpec:
    if not isinstance(v, Mapping):
        raise ConfigError("a relay must be a mapping {var, pattern, contact}", where)
    unknown = set(v) - {"var", "pattern", "contact"}
    if unknown or not {"var", "pattern", "contact"} <= set(v):
        raise ConfigError(
            f"a relay needs exactly var, pattern, contact (got {sorted(map(str, v))})", where
        )
    return RelaySpec(str(v["var"]), str(v["pattern"]), str(v["contact"]))


@dataclass(frozen=True)
class ContactManagerConfig:
    """Alerts and bookkeeping. ``decay`` (s) feeds the dead reckoning of contacts."""

    alerts: tuple[AlertSpec, ...] = ()
    contact_max_age: float = 600.0
    decay: tuple[float, float] = (30.0, 60.0)
    relays: tuple[RelaySpec, ...] = ()

    @property
    def alert_vars(self) -> tuple[str, ...]:
        """Variables the manager posts (alerts and relays): give them to HelmConfig checks."""
        return tuple(dict.fromkeys([a.var for a in self.alerts] + [r.var for r in self.relays]))

    @classmethod
    def from_mapping(cls, m: Mapping[str, Any], where: str = "contacts") -> ContactManagerConfig:
        allowed = ("alerts", "contact_max_age", "decay", "relays")
        for k in m:
            if k not in allowed:
                raise ConfigError(f"unknown key {k!r} (known: {', '.join(allowed)})", where)
        alerts = tuple(
            parse_alert(a, f"{where}.alerts[{i}]") for i, a in enumerate(m.get("alerts", []))
        )
        d = to_decay(m.get("decay", (30.0, 60.0)), "decay", where)
        age = to_float(m.get("contact_max_age", 600.0), "contact_max_age", where)
        relays = tuple(
            parse_relay(r, f"{where}.relays[{i}]") for i, r in enumerate(m.get("relays", []))
        )
        return cls(alerts, age, d, relays)


@dataclass
class ContactRecord:
    """Latest knowledge of one contact (positions MOOS x east / y north)."""

    name: str
    report: NodeReport
    t_report: float
    t_received: float
    x: float = 0.0
    y: float = 0.0
    range: float = math.inf
    decay_maxed: bool = False
    alerted: set[str] = field(default_factory=set)


def _own(own_nav: OwnNav | Mapping[str, Any]) -> OwnNav:
    if isinstance(own_nav, OwnNav):
        return own_nav
    g = own_nav.get
    return OwnNav(
        float(g("NAV_X", g("x", 0.0))),
        float(g("NAV_Y", g("y", 0.0))),
        float(g("NAV_HEADING", g("heading", 0.0))),
        float(g("NAV_SPEED", g("speed", 0.0))),
        float(g("NAV_DEPTH", g("depth", 0.0))),
    )


class ContactManager:
    """Per-vehicle contact bookkeeping and alerts (see module docstring)."""

    def __init__(self, config: ContactManagerConfig, own_name: str) -> None:
        self.config = config
        self.own_name = own_name
        self.contacts: dict[str, ContactRecord] = {}
        self.retired: list[str] = []
        self._extrap = LinearExtrapolator(*config.decay)
        self._last_posted: dict[str, str] = {}
        self._lists_stale = True  # a contact came, was retired or alerted since the lists

    def on_node_report(self, report: str | NodeReport, t: float) -> ContactRecord | None:
        """Take one report received at ``t``; own reports are ignored (returns None)."""
        r = parse_node_report(report) if isinstance(report, str) else report
        if r.name.lower() == self.own_name.lower():
            return None
        key = r.name.lower()
        t_rep = r.time if r.time is not None else t
        rec = self.contacts.get(key)
        if rec is None:
            rec = ContactRecord(r.name, r, t_rep, t, r.x, r.y)
            self.contacts[key] = rec
            self._lists_stale = True
            if r.name in self.retired:
                self.retired.remove(r.name)
        elif t_rep >= rec.t_report:
            rec.report, rec.t_report, rec.t_received = r, t_rep, t
        return rec

    def step(
        self, t: float, own_nav: OwnNav | Mapping[str, Any], reports: Iterable[str] = ()
    ) -> list[tuple[str, str]]:
        """Update records at ``t`` and return the posts (alerts once per contact, lists)."""
        for rep in reports:
            self.on_node_report(rep, t)
        own = _own(own_nav)
        posts: list[tuple[str, str]] = []
        for key in list(self.contacts):
            rec = self.contacts[key]
            if t - rec.t_received > self.config.contact_max_age:
                del self.contacts[key]
                self.retired.append(rec.name)
                self._lists_stale = True
                continue
            r = rec.report
            ex = self._extrap.extrapolate(r.x, r.y, r.heading, r.speed, rec.t_report, t)
            rec.x, rec.y, rec.decay_maxed = ex.x, ex.y, ex.decay_maxed
            rec.range = math.hypot(rec.x - own.x, rec.y - own.y)
            for a in self.config.alerts:
                if a.id in rec.alerted or not a.applies_to(r.type):
                    continue
                if self._triggers(a, rec, own):
                    rec.alerted.add(a.id)
                    self._lists_stale = True
                    posts.append((a.var, self._expand(a.pattern, rec, t)))
                    log.debug("alert %s for contact %s at t=%.2f", a.id, rec.name, t)
        for rl in self.config.relays:
            rec = self.contacts.get(rl.contact.lower())
            if rec is None:
                continue
            text = self._expand(rl.pattern, rec, t)
            key = f"relay:{rl.var}:{rl.contact.lower()}"
            if self._last_posted.get(key) != text:
                posts.append((rl.var, text))
                self._last_posted[key] = text
        if self._lists_stale:  # else the lists are as last posted
            self._lists_stale = False
            self._post_lists(posts)
        return posts

    def _post_lists(self, posts: list[tuple[str, str]]) -> None:
        """CONTACTS_LIST, CONTACTS_ALERTED and CONTACTS_RETIRED, each when its text changed."""
        lists = {
            "CONTACTS_LIST": ",".join(c.name for c in self.contacts.values()),
            "CONTACTS_ALERTED": ",".join(
                f"({c.name},{a})" for c in self.contacts.values() for a in sorted(c.alerted)
            ),
            "CONTACTS_RETIRED": ",".join(self.retired),
        }
        for var, val in lists.items():
            if self._last_posted.get(var) != val:
                posts.append((var, val))
                self._last_posted[var] = val

    def _triggers(self, a: AlertSpec, rec: ContactRecord, own: OwnNav) -> bool:
        if rec.range <= a.alert_range:
            return True
        if a.cpa_range > 0 and rec.range <= a.cpa_range:
            r = rec.report
            cpa = cpa_distance(
                own.x, own.y, own.heading, own.speed, rec.x, rec.y, r.heading, r.speed, a.cpa_time
            )
            return float(cpa) <= a.alert_range
        return False

    @staticmethod
    def _expand(pattern: str, rec: ContactRecord, t: float) -> str:
        out = pattern
        for token, text_of in _SUBSTITUTIONS:  # in order; each formatted only if used
            if token in out:
                out = out.replace(token, text_of(rec, t))
        return out


#: The ``$[...]`` of alert and relay patterns and their text for a contact at ``t``.
_SUBSTITUTIONS: tuple[tuple[str, Callable[[ContactRecord, float], str]], ...] = (
    ("$[VNAME]", lambda rec, t: rec.report.name),
    ("$[X]", lambda rec, t: _f(rec.x, 2)),
    ("$[Y]", lambda rec, t: _f(rec.y, 2)),
    ("$[HDG]", lambda rec, t: _f(rec.report.heading, 2)),
    ("$[SPD]", lambda rec, t: _f(rec.report.speed, 2)),
    ("$[DEP]", lambda rec, t: _f(rec.report.depth, 2)),
    ("$[VTYPE]", lambda rec, t: rec.report.type),
    ("$[UTIME]", lambda rec, t: _f(t, 2)),
)
