"""The helm's discrete decision domain and objective functions over it.

Conventions (MOOS-IvP, docs/reference/helm.md): ``course`` in compass degrees (0 = north,
clockwise), ``speed`` in m/s, ``depth`` in metres positive down. The paper's mission uses
course 0..359 (360 points), speed 0..5 m/s (26 points, 0.2 m/s apart) and an optional
depth 0..100 m (101 points).

An :class:`Objective` is a utility table over a subset of the domain's axes (in domain
order); a function over fewer variables is constant along the others.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from itertools import combinations
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError

__all__ = ["Domain", "DomainAxis", "Objective"]


#: The most points on one decision axis, and over the domain's required (non-optional)
#: axes together: the helm's cost. Every behavior's objective function is an array over
#: the axes it spans, every helm iteration; the solver maximises independent axes apart
#: (:mod:`uhrisim.autonomy.solver`), and an optional axis (depth) is one behavior's
#: alone (ConstantDepth), so a 1 cm depth axis costs its own points, not their product.
MAX_AXIS_POINTS = 10_000
MAX_DOMAIN_POINTS = 50_000_000


@dataclass(frozen=True)
class DomainAxis:
    """One decision variable: ``npts`` evenly spaced values from ``low`` to ``high``.

    ``optional`` axes (MOOS ``depth:0:100:101:optional``) may go undecided without an
    all-stop. ``wrap`` marks a circular variable (course): its period is ``npts * delta``.
    """

    name: str
    low: float
    high: float
    npts: int
    optional: bool = False
    wrap: bool = False

    def __post_init__(self) -> None:
        if self.npts < 1:
            raise ConfigError(f"axis {self.name!r} needs npts >= 1, got {self.npts}", "domain")
        if self.npts > MAX_AXIS_POINTS:
            raise ConfigError(f"axis {self.name!r} has {self.npts:g} points, more than "
                              f"{MAX_AXIS_POINTS} (pHelmIvP's usual course axis has 360)",
                              "domain")
        if self.npts > 1 and not self.high > self.low:
            raise ConfigError(f"axis {self.name!r} needs high > low", "domain")

    @property
    def delta(self) -> float:
        """Spacing between grid values (0 for a single-point axis)."""
        return (self.high - self.low) / (self.npts - 1) if self.npts > 1 else 0.0

    @property
    def period(self) -> float:
        """Period of a wrapping axis (360 for course 0..359 by 1)."""
        return self.npts * self.delta

    @cached_property
    def values(self) -> NDArray[np.float64]:
        """The grid values (read-only)."""
        v = np.linspace(self.low, self.high, self.npts)
        v.flags.writeable = False
        return v

    def index_of(self, value: float) -> int:
        """Index of the grid value nearest ``value`` (circular for a wrapping axis)."""
        if self.npts == 1:
            return 0
        if self.wrap:
            d = np.abs(self.values - value) % self.period
            d = np.minimum(d, self.period - d)
            return int(np.argmin(d))
        return int(np.clip(round((value - self.low) / self.delta), 0, self.npts - 1))


@dataclass(frozen=True)
class Domain:
    """An ordered set of decision axes (MOOS pHelmIvP ``domain = ...`` lines)."""

    axes: tuple[DomainAxis, ...]

    def __post_init__(self) -> None:
        names = [a.name for a in self.axes]
        if len(set(names)) != len(names):
            raise ConfigError(f"duplicate domain axis in {names}", "domain")
        points = math.prod(axis.npts for axis in self.axes if not axis.optional)
        if points > MAX_DOMAIN_POINTS:
            raise ConfigError(f"the decision domain's required axes have {points:g} points "
                              f"together, more than {MAX_DOMAIN_POINTS} (course 360 x speed 21 "
                              "x depth 101 have 763560)", "domain")

    @classmethod
    def paper(cls, with_depth: bool = True) -> Domain:
        """Paper mission: course 0..359/360, speed 0..5/26, depth 0..100/101 (optional)."""
        axes = [
            DomainAxis("course", 0.0, 359.0, 360, wrap=True),
            DomainAxis("speed", 0.0, 5.0, 26),
        ]
        if with_depth:
            axes.append(DomainAxis("depth", 0.0, 100.0, 101, optional=True))
        return cls(tuple(axes))

    @cached_property
    def names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @cached_property
    def _by_name(self) -> dict[str, DomainAxis]:
        return {a.name: a for a in self.axes}

    def has(self, name: str) -> bool:
        return name in self._by_name

    def axis(self, name: str) -> DomainAxis:
        try:
            return self._by_name[name]
        except KeyError:
            raise ConfigError(f"decision domain has no axis {name!r}", "domain") from None

    def order(self, names: tuple[str, ...] | list[str]) -> tuple[str, ...]:
        """``names`` sorted into domain order."""
        return tuple(n for n in self.names if n in names)

    def shape(self, names: tuple[str, ...]) -> tuple[int, ...]:
        """Grid shape (npts per axis) of the sub-grid over ``names`` (in the given order)."""
        by = self._by_name
        return tuple(by[n].npts for n in names)

    @cached_property
    def solver_plans(self) -> dict[tuple[tuple[str, ...], ...], Any]:
        """The solver's plans for this domain (``solver._Plan`` records, typed loosely: the
        domain does not import the solver, which imports it), by the axes of the functions
        it fuses (:func:`uhrisim.autonomy.solver._plan` fills it)."""
        return {}

    @cached_property
    def subgrids(self) -> Mapping[tuple[str, ...], tuple[int, ...]]:
        """Every axis subset in domain order -> its sub-grid shape (read-only; () -> ())."""
        return MappingProxyType({
            c: self.shape(c)
            for k in range(len(self.axes) + 1)
            for c in combinations(self.names, k)
        })  # fmt: skip


@dataclass(eq=False, slots=True)
class Objective:
    """A utility table over ``axes`` (domain order); ``values.shape`` = their ``npts``.

    Behaviors normalise their functions to 0..100 (IvP convention); the helm multiplies by
    the behavior's priority weight. ``value_range``: the exact (min, max) of ``values``
    when the maker knows it (the solver's range check then reads no table), else None.
    Made by behaviors at every iteration: slots, not frozen (about three times as fast to
    make); do not change one once made.
    """

    axes: tuple[str, ...]
    values: NDArray[np.float64]
    value_range: tuple[float, float] | None = None

    @classmethod
    def over(
        cls,
        domain: Domain,
        axes: tuple[str, ...],
        values: NDArray,
        value_range: tuple[float, float] | None = None,
    ) -> Objective:
        """Build after checking that ``axes`` are in domain order and the shape matches."""
        axes = tuple(axes)
        shape = domain.subgrids.get(axes)
        if shape is None:  # unknown, repeated or out-of-order axes
            raise ConfigError(f"objective axes {axes} not in domain order {domain.names}", "helm")
        arr = np.asarray(values, dtype=float)
        if arr.shape != shape:
            raise ConfigError(f"objective over {axes} has shape {arr.shape}, want {shape}", "helm")
        return cls(axes, arr, value_range)

    def min_max(self) -> tuple[float, float]:
        """(min, max) of the values: ``value_range``, or taken from the table."""
        if self.value_range is not None:
            return self.value_range
        return float(self.values.min()), float(self.values.max())

    def at(self, indices: dict[str, int]) -> float:
        """Value at a decision given as axis-name -> grid index."""
        return float(self.values[tuple(indices[a] for a in self.axes)])
