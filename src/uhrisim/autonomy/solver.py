"""Behavior fusion: decision = argmax over the grid of sum_i priority_i * f_i (IvP solver).

The C++ helm uses branch and bound over piecewise-linear boxes; here every function is a
table on the discrete grid, so the argmax is exact on the grid (docs/reference/helm.md, step 4).

Separability: axes are grouped into connected components (two axes are connected when
some function spans both). The sum over independent components separates, so each
component is maximised on its own sub-grid (exactly the same argmax, far less work than
the full course x speed x depth grid).

Tie rule (documented, deterministic): among grid points with the same total, the FIRST in
C order of the domain axes wins - lowest course index, then lowest speed index, then
lowest depth index (``numpy.argmax`` on the flattened component grid).

All-stop: no functions at all ("NothingToDo"), or a non-optional axis that no function
covers ("MissingDecVars:<axes>", in domain order), gives no decision - pHelmIvP's
IVPHELM_ALLSTOP values (HelmIvP.cpp:499-531).

Weights: a function whose values span more than 100 is first normalised to 0..100, then
multiplied by its priority (IvP ``Problem::addOF``, Problem.cpp:127-134); weight <= 0 is
dropped. Behaviors hand in functions within 0..100, so this guards outside functions.
"""

from __future__ import annotations

from collections.abc import Container, Iterable
from dataclasses import dataclass, field
from functools import cache

import numpy as np
from numpy.typing import NDArray

from uhrisim.autonomy.domain import Domain, Objective
from uhrisim.core.compiled import jit

__all__ = ["SolveResult", "WeightedObjective", "solve", "solve_reference"]


@dataclass(slots=True)
class WeightedObjective:
    """A behavior's function and its priority weight (weight <= 0 is dropped by the solver).
    (Made for every function at every iteration: slots, not frozen, as :class:`_Term`.)"""

    name: str
    priority: float
    objective: Objective


@dataclass(slots=True)
class SolveResult:
    """Decision (axis -> value, or None for all-stop) with the audit of contributions.

    ``contributions[name] = priority * f(decision)`` for every function that took part and
    ``total = sum(contributions)`` - the maximised objective value. (Made at every solve:
    slots, not frozen, as :class:`_Term`.)
    """

    decision: dict[str, float] | None
    indices: dict[str, int] = field(default_factory=dict)
    total: float = 0.0
    contributions: dict[str, float] = field(default_factory=dict)
    all_stop_reason: str | None = None


@dataclass(slots=True)
class _Term:
    """A function as the solver adds it: ``priority * f``, where f is the behavior's table,
    renormalised to 0..100 first when it spans more than 100 (``PDMap::normalize(0, 100)``:
    ``(values + offset) * scale``, intercept first, then the scale), point by point as the
    sum reads it - no scaled copy of the table is made. (Made for every function at every
    solve: slots, not frozen, which costs four times as much to make.)"""

    name: str
    priority: float
    axes: tuple[str, ...]
    values: NDArray[np.float64]
    offset: float = 0.0
    scale: float | None = None

    def table(self) -> NDArray[np.float64]:
        """f on its axes (the renormalised table when there is a scale: a new array)."""
        if self.scale is None:
            return self.values
        return (self.values + self.offset) * self.scale

    def at(self, where: tuple[int, ...]) -> float:
        """f at a decision given as the grid index on each of its axes."""
        v = self.values.item(where)
        return v if self.scale is None else (v + self.offset) * self.scale


def _taking_part(objectives: list[WeightedObjective]) -> list[_Term]:
    """The functions the solver uses: weight > 0, over some axis; one spanning more than
    100 is renormalised to 0..100 (IvP ``Problem::addOF``)."""
    out = []
    for w in objectives:
        f = w.objective
        if not (w.priority > 0.0 and f.axes):
            continue
        lo, hi = f.min_max()
        if hi - lo > 100.0:
            out.append(_Term(w.name, w.priority, f.axes, f.values, 0.0 - lo, 100.0 / (hi - lo)))
        else:
            out.append(_Term(w.name, w.priority, f.axes, f.values))
    return out


def _components_of(
    names: tuple[str, ...], spans: tuple[tuple[str, ...], ...]
) -> tuple[tuple[str, ...], ...]:
    """Connected groups of the axes ``spans`` (the functions' axes) cover, each in the
    order of the domain's axis ``names``, ordered by their first axis."""
    groups: list[set[str]] = []
    for span in spans:
        axes = set(span)
        for g in [g for g in groups if not g.isdisjoint(axes)]:
            axes |= g
            groups.remove(g)
        groups.append(axes)
    if len(groups) > 1:
        rank = {n: i for i, n in enumerate(names)}
        groups.sort(key=lambda g: min(rank[n] for n in g))
    return tuple(tuple(n for n in names if n in g) for g in groups)


def _components_reference(domain: Domain, objs: list[_Term]) -> list[tuple[str, ...]]:
    parent = {n: n for n in domain.names}

    def find(a: str) -> str:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    covered: set[str] = set()
    for w in objs:
        covered.update(w.axes)
        first = w.axes[0]
        for other in w.axes[1:]:
            parent[find(other)] = find(first)
    groups: dict[str, list[str]] = {}
    for n in domain.names:
        if n in covered:
            groups.setdefault(find(n), []).append(n)
    return [domain.order(g) for g in groups.values()]


def _fuse(domain: Domain, comp: tuple[str, ...], members: list[_Term]) -> NDArray[np.float64]:
    """sum_i priority_i * f_i over the component's sub-grid, added in objective order.

    The first full-grid term starts the sum (``0 + x`` is x for the argmax), the others
    are added to it: the same additions in the same order as a zero-filled accumulator,
    with no per-term temporaries. With numba each full-grid term (renormalised or not) is
    one compiled pass (:func:`_add_weighted`); else numpy, through one scratch array.
    """
    shape = domain.shape(comp)
    acc: NDArray[np.float64] | None = None
    tmp: NDArray[np.float64] | None = None
    compiled = _compiled_add_weighted()
    for w in members:
        if w.axes == comp and compiled is not None:
            first = acc is None
            if first:
                acc = np.empty(shape)
            compiled(acc.reshape(-1), w.values.reshape(-1), float(w.priority), w.offset,
                     1.0 if w.scale is None else w.scale, w.scale is not None, first)
            continue
        v = w.table()
        if w.axes != comp:  # a function over fewer axes: broadcast it
            view_shape = [1] * len(comp)
            for a, n in zip(w.axes, v.shape, strict=True):
                view_shape[comp.index(a)] = n
            v = v.reshape(view_shape)
        if v.shape != shape:
            if acc is None:
                acc = np.zeros(shape)
            acc += w.priority * v
        elif acc is None:
            acc = np.multiply(v, w.priority)
        else:
            if tmp is None:
                tmp = np.empty(shape)
            acc += np.multiply(v, w.priority, out=tmp)
    assert acc is not None  # a component has at least one member
    return acc


#: The first maximum of a lone read-only table's weighted values, by the table's id:
#: (table, priority, offset, scale, flat index). A behavior that hands in the same
#: function tick after tick (ConstantDepth: one read-only table while its depth stays)
#: has it found once; the table's values cannot have changed (read-only), so it is the
#: index the sum and argmax would give.
_LONE_MAXIMA: dict[int, tuple[NDArray[np.float64], float, float, float | None, int]] = {}
_LONE_KEPT = 64


def _first_maximum(domain: Domain, comp: tuple[str, ...], members: list[_Term]) -> int:
    """Flat index (C order) of the first maximum of the component's sum (the tie rule)."""
    lone = members[0].values if len(members) == 1 else None
    if lone is not None and not lone.flags.writeable:
        w = members[0]
        known = _LONE_MAXIMA.get(id(lone))
        if known is not None and known[0] is lone and known[1:4] == (w.priority, w.offset,
                                                                     w.scale):
            return known[4]
        flat = int(_fuse(domain, comp, members).argmax())
        if len(_LONE_MAXIMA) >= _LONE_KEPT:
            _LONE_MAXIMA.clear()
        _LONE_MAXIMA[id(lone)] = (lone, w.priority, w.offset, w.scale, flat)
        return flat
    return int(_fuse(domain, comp, members).argmax())


def _add_weighted(acc, v, priority, offset, scale, renormalised, first):  # type: ignore[no-untyped-def]
    """``acc (+)= f * priority`` point by point (compiled by numba), f being ``v`` or, when
    ``renormalised``, ``(v + offset) * scale``: the numpy path's roundings in its order
    (the renormalisation's two, the product's, then the sum's unless ``first``)."""
    n = acc.shape[0]
    if renormalised and first:
        for k in range(n):
            acc[k] = ((v[k] + offset) * scale) * priority
    elif renormalised:
        for k in range(n):
            acc[k] = acc[k] + ((v[k] + offset) * scale) * priority
    elif first:
        for k in range(n):
            acc[k] = v[k] * priority
    else:
        for k in range(n):
            acc[k] = acc[k] + v[k] * priority


@cache
def _compiled_add_weighted():  # type: ignore[no-untyped-def]
    return jit(_add_weighted, numpy_errors=True)


@dataclass(frozen=True, slots=True)
class _Plan:
    """What a solve works out from the functions' axes alone (kept per domain and
    combination of axes, :func:`_plan`): the components (:func:`_components_of`), each with
    the positions of its members among the functions and its sub-grid's shape and axis
    values; where each function's decision indices lie (its component, and its axes'
    places in that component, None when it spans the whole component); the all-stop of
    the non-optional axes that no function covers."""

    components: tuple[tuple[str, ...], ...]
    members: tuple[tuple[int, ...], ...]
    shapes: tuple[tuple[int, ...], ...]
    values: tuple[tuple[NDArray[np.float64], ...], ...]
    term_places: tuple[tuple[int, tuple[int, ...] | None], ...]
    missing: str | None


_PLANS_KEPT = 64  # plans kept per domain at most (a helm uses a few)


def _plan(domain: Domain, spans: tuple[tuple[str, ...], ...]) -> _Plan:
    """:class:`_Plan` for the functions' ``spans`` (their axes), made once per domain and
    spans: a helm hands the solver the same few combinations tick after tick."""
    plans = domain.solver_plans
    plan = plans.get(spans)
    if plan is None:
        if len(plans) >= _PLANS_KEPT:
            plans.clear()
        comps = _components_of(domain.names, spans)
        comp_of = {a: k for k, comp in enumerate(comps) for a in comp}
        places = []
        for axes in spans:
            comp = comps[comp_of[axes[0]]]
            places.append((comp_of[axes[0]],
                           None if axes == comp else tuple(comp.index(a) for a in axes)))
        plan = plans[spans] = _Plan(
            comps,
            tuple(tuple(k for k, axes in enumerate(spans) if axes[0] in comp) for comp in comps),
            tuple(domain.shape(comp) for comp in comps),
            tuple(tuple(domain.axis(a).values for a in comp) for comp in comps),
            tuple(places),
            _missing_reason(domain, comp_of))
    return plan


def _missing_reason(domain: Domain, covered: Container[str]) -> str | None:
    """The all-stop for the non-optional axes not in ``covered`` ("MissingDecVars:<axes>",
    in domain order); None when it holds every one."""
    missing = [a.name for a in domain.axes if not a.optional and a.name not in covered]
    return "MissingDecVars:" + ",".join(missing) if missing else None


def _result(
    objs: list[_Term],
    places: Iterable[tuple[int, ...]],
    decision: dict[str, float],
    indices: dict[str, int],
    missing: str | None,
) -> SolveResult:
    """The result of a solve: each function's ``priority * f`` at its decision indices
    (``places``, one per function; summed by name) and their total; no decision, with
    ``missing`` as the all-stop reason, when that is not None."""
    contributions = {w.name: 0.0 for w in objs}
    for w, at in zip(objs, places, strict=True):
        contributions[w.name] += w.priority * w.at(at)
    total = float(sum(contributions.values()))
    if missing is not None:
        return SolveResult(None, indices, total, contributions, all_stop_reason=missing)
    return SolveResult(decision, indices, total, contributions)


def solve(domain: Domain, objectives: list[WeightedObjective]) -> SolveResult:
    """Fuse weighted objectives and return the argmax decision (see module docstring)."""
    objs = _taking_part(objectives)
    if not objs:
        return SolveResult(None, all_stop_reason="NothingToDo")
    plan = _plan(domain, tuple([w.axes for w in objs]))
    decision: dict[str, float] = {}
    indices: dict[str, int] = {}
    best_of: list[tuple[int, ...]] = []  # each component's decision indices
    for comp, members, shape, values in zip(plan.components, plan.members, plan.shapes,
                                            plan.values, strict=True):
        flat = _first_maximum(domain, comp, [objs[k] for k in members])
        best = []
        for n in reversed(shape):  # unravel (C order)
            flat, i = divmod(flat, n)
            best.append(i)
        best.reverse()
        best_of.append(tuple(best))
        for a, i, v in zip(comp, best, values, strict=True):
            indices[a] = i
            decision[a] = float(v[i])
    return _result(objs, [best_of[k] if places is None else tuple([best_of[k][p] for p in places])
                          for k, places in plan.term_places], decision, indices, plan.missing)


def solve_reference(domain: Domain, objectives: list[WeightedObjective]) -> SolveResult:
    """Plain form of :func:`solve` (zero-filled accumulator per component; tests only)."""
    objs = _taking_part(objectives)
    if not objs:
        return SolveResult(None, all_stop_reason="NothingToDo")
    decision: dict[str, float] = {}
    indices: dict[str, int] = {}
    for comp in _components_reference(domain, objs):
        shape = tuple(domain.axis(a).npts for a in comp)
        acc = np.zeros(shape)
        for w in objs:
            if w.axes[0] not in comp:
                continue
            view_shape = [1] * len(comp)
            v = w.table()
            for a, n in zip(w.axes, v.shape, strict=True):
                view_shape[comp.index(a)] = n
            acc += w.priority * v.reshape(view_shape)
        best = np.unravel_index(int(np.argmax(acc)), shape)
        for a, i in zip(comp, best, strict=True):
            indices[a] = int(i)
            decision[a] = float(domain.axis(a).values[i])
    return _result(objs, [tuple(indices[a] for a in w.axes) for w in objs], decision, indices,
                   _missing_reason(domain, indices))
