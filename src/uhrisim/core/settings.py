"""A part's settings, declared once: name, unit, default, physical range and meaning.

A part's configuration (``SonarConfig``, ``CameraConfig``, ``VideoRayParams``, ...) is a
frozen dataclass; each of its numeric fields is declared with :func:`setting`, which
puts a :class:`Quantity` (unit, bounds, a line of meaning, how the part's cost grows with
it) in the field's metadata. Everything else reads that one declaration:

* the part's own validation, :func:`check_settings` (called in ``__post_init__``):
  a finite number (a whole one where declared), inside its bounds, or a one-line
  ``ConfigError`` naming the part and the field;
* the scenario schema, which embeds each part's fields with the same names, defaults and
  bounds (``uhrisim.scenario.sections.scenario_section``): a YAML scenario and the
  Python API build identical parts;
* the documentation's tables (:func:`settings_rows`, docs/settings.md).

Units are written as in docs/conventions.md (SI unless the name's suffix says otherwise:
``_deg``, ``_db``, ``_hz``); ``"1"`` is dimensionless.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import typing
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Literal

from uhrisim.core.errors import ConfigError

#: How a part's cost (time per call) grows with a setting, for settings that drive it.
CostGrowth = Literal["linear", "quadratic"]


@dataclass(frozen=True)
class Quantity:
    """The declaration of one numeric setting: ``unit``, bounds (``ge``/``gt`` below,
    ``le``/``lt`` above; None: unbounded), ``integer`` for whole numbers, ``doc`` its
    meaning in a line, ``cost`` how the part's cost grows with it (None: not at all)."""

    unit: str
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    integer: bool = False
    doc: str = ""
    cost: CostGrowth | None = None

    def problem(self, value: Any) -> str | None:
        """What is wrong with ``value`` (None: nothing)."""
        kind = "an integer" if self.integer else "a finite number"
        if isinstance(value, bool) or not isinstance(
                value, numbers.Integral if self.integer else numbers.Real):
            return f"must be {kind}, got {value!r}"
        if not math.isfinite(value):
            return f"must be {kind}, got {value!r}"
        if not self.contains(float(value)):
            return f"must be {self.range_text()} {self.unit_text()}".rstrip() + \
                f", got {value!r}"
        return None

    def contains(self, value: float) -> bool:
        """Whether ``value`` is inside the bounds."""
        return not ((self.ge is not None and value < self.ge)
                    or (self.gt is not None and value <= self.gt)
                    or (self.le is not None and value > self.le)
                    or (self.lt is not None and value >= self.lt))

    def range_text(self) -> str:
        """The bounds in words: ``"in [0, 9]"``, ``"> 0"``, ``"any"``."""
        low = (f"[{self.ge:g}" if self.ge is not None else
               f"({self.gt:g}" if self.gt is not None else None)
        high = (f"{self.le:g}]" if self.le is not None else
                f"{self.lt:g})" if self.lt is not None else None)
        if low and high:
            return f"in {low}, {high}"
        if low:
            return f">= {self.ge:g}" if self.ge is not None else f"> {self.gt:g}"
        if high:
            return f"<= {self.le:g}" if self.le is not None else f"< {self.lt:g}"
        return "any"

    def unit_text(self) -> str:
        return "" if self.unit == "1" else self.unit

    def relative_cost(self, value: float, default: float) -> float:
        """The part's cost at ``value`` relative to its cost at ``default`` (1 when the
        setting does not drive it): the hook a cost budget on settings builds on."""
        if self.cost is None or not default:
            return 1.0
        ratio = float(value) / float(default)
        return ratio if self.cost == "linear" else ratio * ratio


def setting(default: Any, unit: str, *, ge: float | None = None, gt: float | None = None,
            le: float | None = None, lt: float | None = None, integer: bool = False,
            doc: str = "", cost: CostGrowth | None = None) -> Any:
    """A dataclass field with its default and its :class:`Quantity` (see the module
    docstring): ``rays_per_beam: int = setting(64, "1", ge=2, le=512, integer=True,
    doc="rays per beam in elevation", cost="linear")``."""
    quantity = Quantity(unit, ge, gt, le, lt, integer, doc, cost)
    return dataclasses.field(default=default, metadata={"quantity": quantity})


def quantity_of(field: dataclasses.Field) -> Quantity | None:
    """The :class:`Quantity` declared for a dataclass field (None: not a setting)."""
    return field.metadata.get("quantity")


def declared(part: type | Any) -> Iterator[tuple[dataclasses.Field, Quantity]]:
    """Each field of a part's dataclass (class or instance) with its declaration."""
    for field in dataclasses.fields(part):
        quantity = quantity_of(field)
        if quantity is not None:
            yield field, quantity


def check_settings(part: Any, where: str | None = None) -> None:
    """Every declared setting of the dataclass instance ``part`` (None allowed where its
    type allows None; a sequence checks each element): finite, whole where declared,
    inside its bounds; else a ConfigError at ``<where>.<field>`` (``where``: the part's
    class name)."""
    where = where or type(part).__name__
    hints = typing.get_type_hints(type(part))
    for field, quantity in declared(part):
        value = getattr(part, field.name)
        if value is None and _allows_none(hints.get(field.name)):
            continue
        for item in value if isinstance(value, tuple | list) else (value,):
            problem = quantity.problem(item)
            if problem is not None:
                raise ConfigError(problem, where=f"{where}.{field.name}")


def _allows_none(annotation: Any) -> bool:
    return annotation is not None and type(None) in typing.get_args(annotation)


def settings_rows(part: type) -> list[tuple[str, str, str, str, str]]:
    """The documentation rows of a part's declared settings: (name, unit, default, range,
    meaning), the cost growth appended to the meaning."""
    rows = []
    for field, quantity in declared(part):
        default = field.default
        if default is dataclasses.MISSING:
            default = "required"
        text = quantity.doc + (f" (cost ∝ value{'²' if quantity.cost == 'quadratic' else ''})"
                               if quantity.cost else "")
        rows.append((field.name, quantity.unit_text() or "—",
                     "—" if default is None else f"{default!r}".replace("'", ""),
                     quantity.range_text(), text))
    return rows
