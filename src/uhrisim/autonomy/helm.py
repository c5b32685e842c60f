"""The behavior-fusion helm, with pHelmIvP's semantics (docs/reference/helm.md "The helm
cycle"; MOOS-IvP ivp/src/pHelmIvP/HelmIvP.cpp, HelmEngine.cpp, lib_helmivp).

Inputs and outputs stay in the MOOS vocabulary: NAV_X (east, m), NAV_Y (north, m),
NAV_HEADING (compass deg), NAV_SPEED (m/s), NAV_DEPTH (m, down); out come DESIRED_HEADING
(deg), DESIRED_SPEED (m/s), DESIRED_DEPTH (m). The simulation converts to NED at the
boundary. One call of :meth:`Helm.step` is one helm iteration (4 Hz in the paper):

1. Mail enters the info buffer posting by posting - a mapping ``{var: value}`` or the
   stream of ``(var, value, time)`` postings as MOOS delivers them (:func:`postings_of`).
   Mail more than ``ok_skew`` s off the helm's time is ignored (IVPHELM_SKEW).
   ``MOOS_MANUAL_OVERRIDE`` (or ``MOOS_MANUAL_OVERIDE``) = "false" engages the helm,
   "true" parks it; it starts engaged only with ``start_engaged``. ``NODE_REPORT`` (and
   ``AIS_REPORT``) values go to the contact ledger under their NAME, exact case; a report
   without TIME or X/Y is refused (ContactLedger.cpp:195-208).
   Postings to an ``updates`` variable are kept for the next decision iteration.
2. Parked: IVPHELM_ALLSTOP = ManualOverride, DESIRED_* = 0 once, and the kept postings
   are dropped - a spawning alert that arrives while parked is lost, as in pHelmIvP
   (``clearDeltaVectors``, HelmIvP.cpp:400-404).
3. Until NAV_X, NAV_Y, NAV_HEADING, NAV_SPEED (and NAV_DEPTH with a depth axis) are known
   the helm waits (nothing posted, postings kept; HelmIvP.cpp:1942-1974).
4. A decision iteration: contacts older than ``contact_max_age`` (twice that for one a
   behavior names) leave the ledger; kept postings spawn templates (a posting with
   ``name=X`` to a template's variable makes ``<template name>X``, or ``X`` if it starts
   with the template's name; an existing one is updated instead; a name-less posting
   updates every instance) and update behaviors; mode variables are evaluated (one that
   no entry sets keeps its value); each behavior's conditions decide idle/running
   (a dynamically spawned contact behavior whose contact is not in the ledger completes;
   a duration ends a running behavior once reached - duration 0 at its first running
   iteration); running behaviors produce objectives; flags are posted on transitions.
5. A BHV_ERROR from a behavior halts the iteration (IVPHELM_ALLSTOP = BehaviorError).
   Otherwise the solver fuses priority-weighted functions (:mod:`solver`): no function is
   NothingToDo, a non-optional variable without a decision MissingDecVars:<vars> (also
   posted as BHV_ERROR), else clear and DESIRED_* for each decided variable.
   IVPHELM_ALLSTOP is posted when it changes; a non-clear one posts DESIRED_* = 0 for every
   domain variable once - for NothingToDo/MissingDecVars only from the second iteration in
   a row (HelmIvP.cpp:499-549, 1717-1771).

pHelmIvP's first second without decisions (HelmIvP.cpp:407-411, a wait for the first mail
of a live community) is not modelled. The helm's own posts (flags, mode, behavior posts)
are applied to its info buffer at the end of the step, so conditions see them on the next
tick - as when they come back through the MOOSDB.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cache

from uhrisim.autonomy.behaviors.base import (
    Behavior,
    BehaviorContext,
    ContactInfo,
    OwnNav,
    valid_name,
)
from uhrisim.autonomy.conditions import HeldMemo, Value
from uhrisim.autonomy.config import BehaviorSpec, HelmConfig
from uhrisim.autonomy.contacts import NodeReport, parse_node_report
from uhrisim.autonomy.modes import ModeEvaluator
from uhrisim.autonomy.params import moos_value, parse_updates
from uhrisim.autonomy.solver import SolveResult, WeightedObjective, solve
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import yaw_from_heading_deg

__all__ = ["Decision", "Helm", "HelmOutput", "Posting", "add_mail", "as_mail", "postings_of"]

log = logging.getLogger(__name__)


def as_mail(
    posts: Iterable[tuple[str, object]], base: Mapping[str, object] | None = None
) -> dict[str, object]:
    """Mail for :meth:`Helm.step` from ``(variable, value)`` postings, in order.

    A variable posted more than once becomes a list (each value is applied in order);
    ``base`` entries come first (e.g. the NAV_* values).
    """
    return add_mail(dict(base or {}), posts)


def add_mail(mail: dict[str, object], posts: Iterable[tuple[str, object]]) -> dict[str, object]:
    """``mail`` (changed in place, and returned) with ``posts`` added as :func:`as_mail`
    adds them."""
    for var, val in posts:
        if var in mail:
            prev = mail[var]
            mail[var] = [*(prev if isinstance(prev, list) else [prev]), val]
        else:
            mail[var] = val
    return mail


Posting = tuple[str, object, float]
"""One piece of mail as MOOS delivers it: (variable, value, MOOS time in s)."""


def postings_of(mail: Mapping[str, object] | Iterable[Posting], t: float) -> list[Posting]:
    """The postings in ``mail`` in delivery order: a mapping's entries (a list value is
    several postings of that variable) are dated ``t``; postings are taken as they are."""
    if not isinstance(mail, Mapping):
        return [(str(var), value, float(time)) for var, value, time in mail]
    out: list[Posting] = []
    for var, val in mail.items():
        for v in val if isinstance(val, list | tuple) else (val,):
            out.append((var, v, t))
    return out


@dataclass(slots=True, unsafe_hash=True)
class Decision:
    """The helm's decision: compass heading (deg), speed (m/s), depth (m) or None. (Made
    every iteration: slots, hashed by its fields, not frozen; read it, do not change it.)"""

    heading_deg: float
    speed: float
    depth: float | None = None

    @property
    def yaw_rad(self) -> float:
        """Desired NED yaw (rad, [-pi, pi)) - the compass heading (docs/conventions.md)."""
        return float(yaw_from_heading_deg(self.heading_deg))


@dataclass(slots=True)
class HelmOutput:
    """Result of one helm iteration (audit included: sum(contributions) == total). Made
    every iteration: slots, not frozen (a frozen one of these fields costs about five times
    as much to make); read it, do not change it."""

    t: float
    decision: Decision | None
    all_stop_reason: str | None
    posts: tuple[tuple[str, Value], ...]
    contributions: dict[str, float]
    total: float
    mode: str
    active: tuple[str, ...]
    running: tuple[str, ...]
    idle: tuple[str, ...]
    completed: tuple[str, ...]
    helm_state: str = "DRIVE"
    solve: SolveResult | None = field(default=None, repr=False)
    objectives: tuple[WeightedObjective, ...] = field(default=(), repr=False)

    def post_dict(self) -> dict[str, Value]:
        """Posts as a dict (the last value of a variable posted twice wins)."""
        return dict(self.posts)


@dataclass
class _Slot:
    """A behavior instance and its helm-side bookkeeping."""

    bhv: Behavior
    spawned: bool = False
    status: str = ""  # "", idle, running, active, completed
    dur_start: float | None = None
    dur_accum: float = 0.0
    last_t: float | None = None
    held: HeldMemo | None = None  # whether its run conditions hold (made at its first run)


def _num(v: object) -> float | None:
    if type(v) is float:  # the common case, without the conversion
        return v
    try:
        return float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


OVERRIDE_VARS = frozenset({"MOOS_MANUAL_OVERRIDE", "MOOS_MANUAL_OVERIDE"})
LEDGER_VARS = frozenset({"NODE_REPORT", "AIS_REPORT", "AIS_REPORT_LOCAL"})
_NO_DECISION = ("NothingToDo", "MissingDecVars")
_NOT_KEPT = frozenset(("BHV_WARNING", "BHV_ERROR", "IVPHELM_SKEW"))  # posts not in the info
_LIST_VARS = {status: f"IVPHELM_BHV_{status.upper()}"
              for status in ("active", "running", "idle", "completed")}


@cache
def _desired_var(axis: str) -> str:
    """The variable a decision on ``axis`` is posted to (DESIRED_COURSE is DESIRED_HEADING)."""
    return "DESIRED_HEADING" if axis == "course" else f"DESIRED_{axis.upper()}"


class Helm:
    """A MOOS-IvP style helm for one vehicle (see module docstring)."""

    def __init__(self, config: HelmConfig, vehicle_name: str = "") -> None:
        self.config = config
        self.settings = config.settings
        self.vehicle_name = vehicle_name
        self.domain = config.domain
        self.info: dict[str, Value] = {}
        self.ledger: dict[str, ContactInfo] = {}
        self.engaged = config.settings.start_engaged
        self.templates: dict[str, list[BehaviorSpec]] = {}
        self.spawn_counts: dict[str, int] = {}
        self.slots: list[_Slot] = []
        for spec in config.behaviors:
            if spec.is_template:
                self.templates.setdefault(spec.common.updates, []).append(spec)
            else:
                self.slots.append(_Slot(spec.instantiate()))
        self._mode_var_order = config.mode_vars  # declaration order (the first is MODE)
        self._modes = ModeEvaluator(config.modes)
        self._kept: list[tuple[str, str]] = []  # updates postings for the next iteration
        self._nav_started = False
        self._allstop = ""  # the last IVPHELM_ALLSTOP message (HelmIvP m_allstop_msg)
        self._no_decisions = 0
        self._first = True
        self._changes = 0  # behaviors spawned, removed or updated so far
        # every slot's status at the last output, _changes then, and the names by status
        # then (as last posted in IVPHELM_BHV_*)
        self._last_statuses: tuple[str, ...] = ()
        self._changes_listed = -1
        self._by_status: dict[str, tuple[str, ...]] = {}
        self._watched_at: tuple[int, int] | None = None  # (slots, changes) of _watched_vars
        self._watched_vars: frozenset[str] = frozenset()
        self.last_output: HelmOutput | None = None

    # -- queries ---------------------------------------------------------------------
    def behavior(self, name: str) -> Behavior | None:
        """The live behavior instance called ``name`` (spawned ones included)."""
        for s in self.slots:
            if s.bhv.name == name:
                return s.bhv
        return None

    @property
    def behavior_names(self) -> tuple[str, ...]:
        return tuple(s.bhv.name for s in self.slots)

    def own_nav(self) -> OwnNav | None:
        """Own ship from NAV_* in the info buffer (None until NAV_X/Y/HEADING are known)."""
        g = self.info.get
        x, y, h = _num(g("NAV_X")), _num(g("NAV_Y")), _num(g("NAV_HEADING"))
        if x is None or y is None or h is None:
            return None
        return OwnNav(x, y, h % 360.0, _num(g("NAV_SPEED")) or 0.0, _num(g("NAV_DEPTH")) or 0.0)

    # -- mail ------------------------------------------------------------------------
    def _warn(self, posts: list, msg: str) -> None:
        log.warning("helm %s: %s", self.vehicle_name, msg)
        posts.append(("BHV_WARNING", msg))

    def _node_report(self, text: object, posts: list) -> None:
        """A report into the contact ledger (ContactLedger::processNodeReport)."""
        try:
            r = text if isinstance(text, NodeReport) else parse_node_report(str(text))
        except ConfigError as e:
            self._warn(posts, f"Bad NodeReport: {e}")
            return
        if r.time is None:
            self._warn(posts, f"Bad NodeReport: {text} The issue: Missing timestamp.")
            return
        self.ledger[r.name] = ContactInfo(r.name, r.x, r.y, r.heading, r.speed, r.depth, r.time)
        if r.type:
            self.info[f"{r.name.upper()}_NAV_TYPE"] = r.type

    def _watched(self) -> frozenset[str]:
        """The variables whose postings are kept for the next decision iteration (the
        templates' and the behaviors' ``updates``); worked out again only after a behavior
        was spawned, removed or updated."""
        at = (len(self.slots), self._changes)
        if at != self._watched_at:
            self._watched_at = at
            self._watched_vars = frozenset(self.templates).union(
                s.bhv.common.updates for s in self.slots)
        return self._watched_vars

    def _take_mail(self, t: float, postings: Iterable[Posting], posts: list) -> None:
        watched = self._watched()
        skew = self.settings.ok_skew
        for var, v, t_post in postings:
            if skew is not None and abs(t - t_post) > skew:
                msg = f"Helm ignores MOOS msg due to skew: {var} Skew={t - t_post:.2f}"
                log.warning("helm %s: %s", self.vehicle_name, msg)
                posts.append(("IVPHELM_SKEW", msg))
                continue
            if var in LEDGER_VARS:
                self._node_report(v, posts)
                continue
            try:
                self.info[var] = v if type(v) is float else moos_value(v)
            except ConfigError as e:
                self._warn(posts, f"{var}: {e}")
                continue
            if var in OVERRIDE_VARS and str(v).strip().lower() in ("true", "false"):
                self.engaged = str(v).strip().lower() == "false"
            if var in watched:
                self._kept.append((var, str(v)))

    # -- spawning and updates ----------------------------------------------------------
    def _spawn(self, var: str, text: str, posts: list) -> None:
        """A posting to a template's variable (BehaviorSet::handlePossibleSpawnings)."""
        try:
            pairs = parse_updates(text)
        except ConfigError as e:
            self._warn(posts, f"bad {var} posting {text!r}: {e}")
            return
        given = dict(pairs).get("name")
        rest = [(k, v) for k, v in pairs if k != "name"]
        if given is None:  # updates every spawned instance (IvPBehavior::checkUpdates)
            for s in self.slots:
                if s.spawned and s.bhv.common.updates == var and s.status != "completed":
                    self._apply_update(s.bhv, var, rest, posts)
            return
        for tpl in self.templates[var]:
            new_name = given if given.startswith(tpl.name) else tpl.name + given
            existing = self.behavior(new_name) or self.behavior(given)
            if existing is not None:
                self._apply_update(existing, var, rest, posts)
                continue
            if not valid_name(given):
                self._warn(posts, f"Failed to spawn {new_name}. Bad name: {given}")
                continue
            limit = tpl.common.max_spawnings
            if limit and self.spawn_counts.get(tpl.name, 0) >= limit:
                self._warn(posts, f"Failed to spawn {new_name}: max_spawnings {limit} reached")
                continue
            try:
                b = tpl.instantiate(new_name)
                for k, v in rest:
                    b.set_param(k, v, f"{var} posting")
            except ConfigError as e:
                self._warn(posts, f"Failed to spawn {new_name}. Bad config: {e}")
                continue
            b.reset()
            self.slots.append(_Slot(b, spawned=True))
            self._changes += 1
            self.spawn_counts[tpl.name] = self.spawn_counts.get(tpl.name, 0) + 1
            posts.extend(self._expand(b, f) for f in b.common.spawnflags)
            log.info("helm %s: spawned %s", self.vehicle_name, new_name)

    def _apply_update(
        self, bhv: Behavior, var: str, pairs: list[tuple[str, str]], posts: list
    ) -> None:
        self._changes += 1
        try:
            for k, v in pairs:
                if k in ("name", "templating"):
                    raise ConfigError(f"{k} cannot be updated", f"{var} posting")
                bhv.set_param(k, v, f"{var} posting")
        except ConfigError as e:
            self._warn(posts, f"update of {bhv.name} from {var} rejected: {e}")

    def _apply_kept(self, posts: list) -> None:
        """Spawn and update from the postings kept since the last decision iteration."""
        kept, self._kept = self._kept, []
        for var, text in kept:
            if var in self.templates:
                self._spawn(var, text, posts)
            targets = [s.bhv for s in self.slots if s.bhv.common.updates == var
                       and not s.spawned and s.status != "completed"]  # fmt: skip
            if not targets:
                continue
            try:
                pairs = parse_updates(text)
            except ConfigError as e:
                self._warn(posts, f"bad {var} posting {text!r}: {e}")
                continue
            for bhv in targets:
                self._apply_update(bhv, var, pairs, posts)

    # -- the iteration ---------------------------------------------------------------
    def step(
        self, t: float, mail: Mapping[str, object] | Iterable[Posting] | None = None
    ) -> HelmOutput:
        """One helm iteration at time ``t`` (s) with the mail since the last one.

        ``mail``: a mapping ``{variable: value}`` (a list value = several postings, in
        order), all posted at ``t``; or the postings themselves, ``(variable, value,
        time)`` in the order MOOS delivered them (``time`` s, the posting's MOOS time)."""
        posts: list[tuple[str, Value]] = []
        init_posts: tuple[tuple[str, Value], ...] = ()
        if self._first:  # posted once, and applied before the first mail (mail wins)
            init_posts = self.config.initialize
            self.info.update(dict(self.config.initialize))
        self._take_mail(t, postings_of(mail or {}, t), posts)
        if self._first:  # initialize_: only what is still unknown (HelmIvP.cpp:923-952)
            late = tuple((v, x) for v, x in self.config.initialize_deferred if v not in self.info)
            self.info.update(dict(late))
            init_posts += late
        state = "DRIVE" if self.engaged else "PARK"
        posts.append(("IVPHELM_STATE", state))
        mode = str(self.info.get(self._mode_var_order[0], "")) if self._mode_var_order else ""
        if not self.engaged:
            self._kept.clear()
            self._post_allstop("ManualOverride", posts)
            return self._finish(t, init_posts, posts, None, "ManualOverride", mode, state)
        if not self._nav_known():
            return self._finish(t, init_posts, posts, None, None, mode, state)
        self._clear_stale_contacts(t)
        self._apply_kept(posts)
        built = self._modes(self.info)
        for var in self._mode_var_order:
            if var in built and (self.info.get(var) != built[var] or self._first):
                posts.append((var, built[var]))
                self.info[var] = built[var]
        mode = str(self.info.get(self._mode_var_order[0], "")) if self._mode_var_order else ""
        ctx = BehaviorContext(t, self.domain, self.info, self.own_nav(), self.ledger)
        weighted: list[WeightedObjective] = []
        for s in list(self.slots):
            if s.status != "completed":
                self._run_slot(s, ctx, weighted)
        posts.extend(ctx.posts)
        if any(s.spawned and s.status == "completed" for s in self.slots):
            self.slots = [s for s in self.slots if not (s.spawned and s.status == "completed")]
            self._changes += 1
        if any(var == "BHV_ERROR" for var, _ in ctx.posts):  # HelmEngine.cpp:233-243
            result, reason = None, "BehaviorError"
        else:
            result = solve(self.domain, weighted)
            reason = result.all_stop_reason or "clear"
            if reason.startswith("MissingDecVars"):
                posts.append(("BHV_ERROR", reason))
        self._post_allstop(reason, posts)
        if result is not None and result.decision is not None:
            posts.extend((_desired_var(a), v) for a, v in result.decision.items())
        return self._finish(t, init_posts, posts, result, reason, mode, state, tuple(weighted))

    def _nav_known(self) -> bool:
        if not self._nav_started:
            need = ["NAV_X", "NAV_Y", "NAV_HEADING", "NAV_SPEED"]
            need += ["NAV_DEPTH"] if self.domain.has("depth") else []
            self._nav_started = all(v in self.info for v in need)
        return self._nav_started

    def _clear_stale_contacts(self, t: float) -> None:
        """Contacts whose report is older than contact_max_age leave the ledger; twice as
        old for one a behavior names (HelmIvP.cpp:383-386, ContactLedger.cpp:400-425)."""
        age = self.settings.contact_max_age
        old = [n for n, c in self.ledger.items() if t - c.t_report > min(age, 2.0 * age)]
        if not old:  # (the usual case: no need to know which contacts behaviors name)
            return
        used = {getattr(s.bhv.params, "contact", "") for s in self.slots}
        for name in old:
            if t - self.ledger[name].t_report > age * (2.0 if name in used else 1.0):
                del self.ledger[name]

    def _post_allstop(self, msg: str, posts: list) -> None:
        """IVPHELM_ALLSTOP and the DESIRED_* zeros (HelmIvP::postAllStop)."""
        if msg == self._allstop:
            return
        self._allstop = msg
        self._no_decisions = self._no_decisions + 1 if msg.startswith(_NO_DECISION) else 0
        posts.append(("IVPHELM_ALLSTOP", msg))
        if msg == "clear":
            return
        if self._no_decisions == 1:  # one iteration's grace, to change modes
            self._allstop = "IncompleteOrEmptyDecision"
            return
        posts.extend((_desired_var(a.name), 0.0) for a in self.domain.axes)

    def _expand(self, b: Behavior, flag: tuple[str, Value]) -> tuple[str, Value]:
        """A flag with $[CONTACT], $[OWNSHIP], $[BHVNAME] expanded in a string value."""
        var, val = flag
        if isinstance(val, str) and "$[" in val:
            val = (
                val.replace("$[CONTACT]", str(getattr(b.params, "contact", "")))
                .replace("$[OWNSHIP]", self.vehicle_name)
                .replace("$[BHVNAME]", b.name)
            )
        return var, val

    def _flag(self, ctx: BehaviorContext, b: Behavior, flag: tuple[str, Value]) -> None:
        ctx.post(*self._expand(b, flag))

    def _run_slot(self, s: _Slot, ctx: BehaviorContext, weighted: list) -> None:
        b = s.bhv
        c = b.common
        b.priority_scale, b.complete_requested = 1.0, False
        contact = getattr(b.params, "contact", "")
        if s.spawned and contact and contact not in ctx.contacts:  # IvPBehavior.cpp:339-341
            self._complete(s, ctx)
            return
        if s.held is None or s.held.conditions is not c.conditions:  # (an update adds some)
            s.held = HeldMemo(c.conditions)
        running = s.held(self.info)
        prev = s.status
        t = ctx.t
        if not running:
            s.last_t = None  # idle time counts only with duration_idle_decay
            if prev in ("", "running", "active"):
                for f in c.idleflags:
                    self._flag(ctx, b, f)
            if prev == "active":
                for f in c.inactiveflags:
                    self._flag(ctx, b, f)
            s.status = "idle"
            b.on_idle(ctx)
            if b.complete_requested:
                self._complete(s, ctx)
            return
        if c.duration >= 0:  # the clock starts at the first running iteration
            if s.dur_start is None:
                s.dur_start = t
            elif s.last_t is not None:
                s.dur_accum += t - s.last_t
            s.last_t = t
            elapsed = (t - s.dur_start) if c.duration_idle_decay else s.dur_accum
            if elapsed >= c.duration:  # IvPBehavior::durationExceeded
                self._complete(s, ctx)
                return
        if prev == "idle":  # not at the first iteration (BehaviorSet.cpp:780-781)
            b.on_run_start(ctx)
        if prev in ("", "idle"):
            for f in c.runflags:
                self._flag(ctx, b, f)
        obj = b.on_run(ctx)
        priority = c.priority * b.priority_scale
        active = obj is not None and priority > 0.0
        if active:
            weighted.append(WeightedObjective(b.name, priority, obj))
            if prev != "active":
                for f in c.activeflags:
                    self._flag(ctx, b, f)
        elif prev == "active":
            for f in c.inactiveflags:
                self._flag(ctx, b, f)
        s.status = "active" if active else "running"
        if b.complete_requested:
            self._complete(s, ctx)

    def _complete(self, s: _Slot, ctx: BehaviorContext) -> None:
        b = s.bhv
        for f in b.common.endflags:
            self._flag(ctx, b, f)
        if b.common.perpetual:
            b.reset()
            b.complete_requested = False
            s.dur_start, s.dur_accum, s.last_t = None, 0.0, None
            s.status = "idle"
        else:
            s.status = "completed"
        log.info("helm %s: behavior %s completed at t=%.2f", self.vehicle_name, b.name, ctx.t)

    def _finish(
        self,
        t: float,
        init_posts: tuple[tuple[str, Value], ...],
        posts: list[tuple[str, Value]],
        result: SolveResult | None,
        reason: str | None,
        mode: str,
        state: str,
        weighted: tuple[WeightedObjective, ...] = (),
    ) -> HelmOutput:
        decision = None
        if result is not None and result.decision is not None:
            d = result.decision
            decision = Decision(d["course"], d["speed"], d.get("depth"))
        statuses = tuple([s.status for s in self.slots])
        if statuses != self._last_statuses or self._changes != self._changes_listed:
            groups: dict[str, list[str]] = {"active": [], "running": [], "idle": [],
                                            "completed": []}
            for s in self.slots:
                group = groups.get(s.status)
                if group is not None:
                    group.append(s.bhv.name)
            before = self._by_status
            by = self._by_status = {k: tuple(v) for k, v in groups.items()}
            self._last_statuses, self._changes_listed = statuses, self._changes
            for status, names in by.items():  # IVPHELM_BHV_ACTIVE, ... when they change
                if before.get(status) != names:
                    posts.append((_LIST_VARS[status], ",".join(names)))
        by = self._by_status
        info = self.info
        for var, val in posts:
            if var not in _NOT_KEPT:
                info[var] = val
        self._first = False
        out = HelmOutput(
            t=t,
            decision=decision,
            all_stop_reason=None if decision is not None else reason,
            posts=init_posts + tuple(posts),
            contributions=dict(result.contributions) if result else {},
            total=result.total if result else 0.0,
            mode=mode,
            active=by["active"],
            running=by["running"],
            idle=by["idle"],
            completed=by["completed"],
            helm_state=state,
            solve=result,
            objectives=weighted,
        )
        self.last_output = out
        return out
