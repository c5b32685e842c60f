"""The behavior-fusion helm (pHelmIvP semantics, reference/helm.md "The helm cycle").

Inputs and outputs stay in the MOOS vocabulary: NAV_X (east, m), NAV_Y (north, m),
NAV_HEADING (compass deg), NAV_SPEED (m/s), NAV_DEPTH (m, down); out come DESIRED_HEADING
(deg), DESIRED_SPEED (m/s), DESIRED_DEPTH (m). The simulation converts to NED at the
boundary. One call of :meth:`Helm.step` is one helm iteration (4 Hz in the paper):

1. mail (variables changed since the last step) enters the info buffer. ``NODE_REPORT``
   values (a string, a :class:`NodeReport`, or a list of them) become
   ``<NAME>_NAV_X/_Y/_HEADING/_SPEED/_DEPTH/_UTC`` entries (name upper-cased; own
   reports ignored). A posting to a spawn template's ``updates`` variable containing
   ``name=X`` spawns behavior ``<template name><X>`` (IvP concatenation) with the other
   ``param=value`` pairs applied, or updates it if it already exists; postings to a
   behavior's ``updates`` variable set parameters. A list value means several postings
   of that variable, applied in order. The ``initialize`` values are applied (and
   posted) before the first mail;
2. mode variables are evaluated (:mod:`modes`), posted when they change;
3. each behavior's conditions decide idle/running; durations expire; running behaviors
   produce objectives; flags are posted on transitions (runflag: idle -> running,
   idleflag: -> idle, activeflag / inactiveflag: starts / stops producing a function,
   endflag: completion);
4. the solver fuses priority-weighted functions (:mod:`solver`; tie rule there);
5. DESIRED_* are posted every tick; with no decision, DESIRED_SPEED = 0 and the reason
   goes to IVPHELM_ALLSTOP.

The helm's own posts (flags, mode, behavior posts) are applied to its info buffer at the
end of the step, so conditions see them on the next tick - as when they come back through
the MOOSDB. ``MOOS_MANUAL_OVERRIDE = true`` parks the helm (IVPHELM_STATE = PARK: no
behaviors run, nothing DESIRED_* is posted).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from uhrisim.autonomy.behaviors.base import Behavior, BehaviorContext, OwnNav
from uhrisim.autonomy.conditions import Value
from uhrisim.autonomy.config import BehaviorSpec, HelmConfig
from uhrisim.autonomy.contacts import NodeReport, parse_node_report
from uhrisim.autonomy.modes import evaluate_modes
from uhrisim.autonomy.params import moos_value, parse_updates
from uhrisim.autonomy.solver import SolveResult, WeightedObjective, solve
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import yaw_from_heading_deg

__all__ = ["Decision", "Helm", "HelmOutput", "as_mail"]

log = logging.getLogger(__name__)


def as_mail(
    posts: Iterable[tuple[str, object]], base: Mapping[str, object] | None = None
) -> dict[str, object]:
    """Mail for :meth:`Helm.step` from ``(variable, value)`` postings, in order.

    A variable posted more than once becomes a list (each value is applied in order);
    ``base`` entries come first (e.g. the NAV_* values).
    """
    mail: dict[str, object] = dict(base or {})
    for var, val in posts:
        if var in mail:
            prev = mail[var]
            mail[var] = [*(prev if isinstance(prev, list) else [prev]), val]
        else:
            mail[var] = val
    return mail


@dataclass(frozen=True)
class Decision:
    """The helm's decision: compass heading (deg), speed (m/s), depth (m) or None."""

    heading_deg: float
    speed: float
    depth: float | None = None

    @property
    def yaw_rad(self) -> float:
        """Desired NED yaw (rad, [-pi, pi)) - the compass heading (docs/conventions.md)."""
        return float(yaw_from_heading_deg(self.heading_deg))


@dataclass(frozen=True)
class HelmOutput:
    """Result of one helm iteration (audit included: sum(contributions) == total)."""

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


def _num(v: object) -> float | None:
    try:
        return float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


class Helm:
    """A MOOS-IvP style helm for one vehicle (see module docstring)."""

    def __init__(self, config: HelmConfig, vehicle_name: str = "") -> None:
        self.config = config
        self.vehicle_name = vehicle_name
        self.domain = config.domain
        self.info: dict[str, Value] = {}
        self.templates: dict[str, list[BehaviorSpec]] = {}
        self.slots: list[_Slot] = []
        for spec in config.behaviors:
            if spec.is_template:
                self.templates.setdefault(spec.common.updates, []).append(spec)
            else:
                self.slots.append(_Slot(spec.instantiate()))
        self.mode_vars = frozenset(config.mode_vars)
        self._mode_var_order = config.mode_vars  # declaration order (the first is MODE)
        self._first = True
        self._last_lists: dict[str, str] = {}
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

    def _node_report(self, text: object, t: float, posts: list) -> None:
        try:
            r = text if isinstance(text, NodeReport) else parse_node_report(str(text))
        except ConfigError as e:
            self._warn(posts, f"bad NODE_REPORT ignored: {e}")
            return
        if r.name.lower() == self.vehicle_name.lower():
            return
        k = r.name.upper()
        self.info.update(
            {
                f"{k}_NAV_X": r.x,
                f"{k}_NAV_Y": r.y,
                f"{k}_NAV_HEADING": r.heading,
                f"{k}_NAV_SPEED": r.speed,
                f"{k}_NAV_DEPTH": r.depth,
                f"{k}_NAV_UTC": r.time if r.time is not None else t,
            }
        )

    def _spawn(self, var: str, text: str, posts: list) -> None:
        try:
            pairs = parse_updates(text)
        except ConfigError as e:
            self._warn(posts, f"bad {var} posting {text!r}: {e}")
            return
        given = dict(pairs).get("name")
        if not given:
            self._warn(posts, f"{var} posting {text!r} has no name= to spawn with")
            return
        rest = [(k, v) for k, v in pairs if k != "name"]
        for tpl in self.templates[var]:
            new_name = tpl.name + given
            existing = self.behavior(new_name)
            try:
                if existing is None:
                    b = tpl.instantiate(new_name)
                    for k, v in rest:
                        b.set_param(k, v, f"{var} posting")
                    b.reset()
                    self.slots.append(_Slot(b, spawned=True))
                    log.info("helm %s: spawned %s", self.vehicle_name, new_name)
                else:
                    for k, v in rest:
                        existing.set_param(k, v, f"{var} posting")
            except ConfigError as e:
                self._warn(posts, f"spawn of {new_name} from {var} failed: {e}")

    def _update(self, var: str, text: str, posts: list) -> None:
        for s in self.slots:
            if s.bhv.common.updates != var or s.status == "completed":
                continue
            if s.spawned and var in self.templates:
                continue  # spawned instances are updated through _spawn (by name)
            try:
                for k, v in parse_updates(text):
                    if k in ("name", "templating"):
                        raise ConfigError(f"{k} cannot be updated", f"{var} posting")
                    s.bhv.set_param(k, v, f"{var} posting")
            except ConfigError as e:
                self._warn(posts, f"update of {s.bhv.name} from {var} rejected: {e}")

    def _take_mail(self, t: float, mail: Mapping[str, object], posts: list) -> None:
        update_vars = {s.bhv.common.updates for s in self.slots if s.bhv.common.updates}
        for var, val in mail.items():
            values = list(val) if isinstance(val, list | tuple) else [val]
            for v in values:
                if var == "NODE_REPORT":
                    self._node_report(v, t, posts)
                    continue
                try:
                    self.info[var] = moos_value(v)
                except ConfigError as e:
                    self._warn(posts, f"{var}: {e}")
                    continue
                if var in self.templates:
                    self._spawn(var, str(v), posts)
                if var in update_vars:
                    self._update(var, str(v), posts)

    # -- the iteration ---------------------------------------------------------------
    def step(self, t: float, mail: Mapping[str, object] | None = None) -> HelmOutput:
        """One helm iteration at time ``t`` (s) with the variables changed since the last."""
        posts: list[tuple[str, Value]] = []
        self._init_posts: tuple[tuple[str, Value], ...] = ()
        if self._first:  # posted once, and applied before the first mail (mail wins)
            self._init_posts = self.config.initialize
            self.info.update(dict(self.config.initialize))
        self._take_mail(t, mail or {}, posts)
        parked = str(self.info.get("MOOS_MANUAL_OVERRIDE", "false")).lower() == "true"
        state = "PARK" if parked else "DRIVE"
        if self._last_lists.get("IVPHELM_STATE") != state:
            posts.append(("IVPHELM_STATE", state))
            self._last_lists["IVPHELM_STATE"] = state
        built = evaluate_modes(self.config.modes, self.info)
        mode_vars = self._mode_var_order
        for var in mode_vars:
            value = built.get(var, "")  # no entry matched: the mode variable is empty
            if self.info.get(var) != value or self._first:
                posts.append((var, value))
            self.info[var] = value
        mode = str(self.info.get(mode_vars[0], "")) if mode_vars else ""
        if parked:
            out = self._finish(t, posts, None, "helm parked (MOOS_MANUAL_OVERRIDE=true)", mode)
            return out
        ctx = BehaviorContext(t, self.domain, self.info, self.own_nav())
        weighted: list[WeightedObjective] = []
        for s in list(self.slots):
            if s.status == "completed":
                continue
            self._run_slot(s, ctx, weighted)
        posts.extend(ctx.posts)
        self.slots = [s for s in self.slots if not (s.spawned and s.status == "completed")]
        result = solve(self.domain, weighted)
        return self._finish(t, posts, result, result.all_stop_reason, mode, tuple(weighted))

    def _flag(self, ctx: BehaviorContext, b: Behavior, flag: tuple[str, Value]) -> None:
        """Post a flag, expanding $[CONTACT], $[OWNSHIP], $[BHVNAME] in string values."""
        var, val = flag
        if isinstance(val, str) and "$[" in val:
            val = (
                val.replace("$[CONTACT]", str(getattr(b.params, "contact", "")))
                .replace("$[OWNSHIP]", self.vehicle_name)
                .replace("$[BHVNAME]", b.name)
            )
        ctx.post(var, val)

    def _run_slot(self, s: _Slot, ctx: BehaviorContext, weighted: list) -> None:
        b = s.bhv
        c = b.common
        b.priority_scale, b.complete_requested = 1.0, False
        running = all(cond.evaluate(self.info) for cond in c.conditions)
        prev = s.status
        t = ctx.t
        if c.duration > 0:
            if running and s.dur_start is None:
                s.dur_start = t
            if running and s.last_t is not None and s.dur_start is not None:
                s.dur_accum += t - s.last_t
            s.last_t = t if running else None
            if s.dur_start is not None:
                elapsed = (t - s.dur_start) if c.duration_idle_decay else s.dur_accum
                if elapsed >= c.duration:
                    self._complete(s, ctx)
                    return
        if not running:
            if prev in ("", "running", "active"):
                for f in c.idleflags:
                    self._flag(ctx, b, f)
            if prev == "active":
                for f in c.inactiveflags:
                    self._flag(ctx, b, f)
            s.status = "idle"
            b.on_idle(ctx)
            return
        if prev in ("", "idle"):
            b.on_run_start(ctx)
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
        posts: list[tuple[str, Value]],
        result: SolveResult | None,
        reason: str | None,
        mode: str,
        weighted: tuple[WeightedObjective, ...] = (),
    ) -> HelmOutput:
        decision = None
        if result is not None and result.decision is not None:
            d = result.decision
            decision = Decision(d["course"], d["speed"], d.get("depth"))
            posts += [("DESIRED_HEADING", decision.heading_deg), ("DESIRED_SPEED", decision.speed)]
            if decision.depth is not None:
                posts.append(("DESIRED_DEPTH", decision.depth))
        elif result is not None:
            posts.append(("DESIRED_SPEED", 0.0))
        groups: dict[str, list[str]] = {"active": [], "running": [], "idle": [], "completed": []}
        for s in self.slots:
            if s.status in groups:
                groups[s.status].append(s.bhv.name)
        by = {k: tuple(v) for k, v in groups.items()}
        lists = {
            "IVPHELM_ALLSTOP": reason or "clear",
            "IVPHELM_BHV_ACTIVE": ",".join(by["active"]),
            "IVPHELM_BHV_RUNNING": ",".join(by["running"]),
            "IVPHELM_BHV_IDLE": ",".join(by["idle"]),
            "IVPHELM_BHV_COMPLETED": ",".join(by["completed"]),
        }
        for var, val in lists.items():
            if self._last_lists.get(var) != val:
                posts.append((var, val))
                self._last_lists[var] = val
        for var, val in posts:
            if var not in ("NODE_REPORT", "BHV_WARNING", "BHV_ERROR"):
                self.info[var] = val
        self._first = False
        out = HelmOutput(
            t=t,
            decision=decision,
            all_stop_reason=None if decision is not None else reason,
            posts=self._init_posts + tuple(posts),
            contributions=dict(result.contributions) if result else {},
            total=result.total if result else 0.0,
            mode=mode,
            active=by["active"],
            running=by["running"],
            idle=by["idle"],
            completed=by["completed"],
            helm_state="PARK" if result is None else "DRIVE",
            solve=result,
            objectives=weighted,
        )
        self.last_output = out
        return out
