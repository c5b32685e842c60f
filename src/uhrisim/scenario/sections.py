"""The scenario's sections for the simulator's parts, made from the parts' own declarations.

A part (``SonarConfig``, ``CameraConfig``, ``VideoRayParams``, ``VideoRayGains``,
``DiverParams``) declares its settings once, in its dataclass (:mod:`uhrisim.core.settings`).
:func:`scenario_section` turns that declaration into the strict model the scenario file is
checked against: the same names, defaults and bounds (checked by the declaration itself, so
a bad value fails at load with the part's own message, the file line and the field path).
:func:`part_settings` hands a section's values back as the part's keyword arguments, and
``tests/unit/test_scenario_parts.py`` builds every part from YAML and from the Python API
and compares them.
"""

from __future__ import annotations

import dataclasses
import typing
from typing import Annotated, Any

from pydantic import AfterValidator, create_model

from uhrisim.core.settings import Quantity, quantity_of
from uhrisim.scenario.strict import Strict


def _checked(quantity: Quantity) -> AfterValidator:
    def check(value: Any) -> Any:
        for item in value if isinstance(value, tuple) else (value,):
            if item is not None:
                problem = quantity.problem(item)
                if problem is not None:
                    raise ValueError(problem)
        return value + 0.0 if isinstance(value, float) else value  # -0.0 is +0.0 here

    return AfterValidator(check)


def declared_as(part: type, name: str) -> Any:
    """The type of the field ``name`` of the dataclass ``part`` checked by its declaration
    (:func:`setting`), for a scenario field of another name: ``period: declared_as(
    BubbleParams, "period_s") = 4.0``."""
    field = next(f for f in dataclasses.fields(part) if f.name == name)
    quantity = quantity_of(field)
    assert quantity is not None, f"{part.__name__}.{name} is not a declared setting"
    return Annotated[typing.get_type_hints(part)[name], quantity, _checked(quantity)]


def scenario_section(part: type, name: str, *, exclude: tuple[str, ...] = (),
                     include: tuple[str, ...] | None = None, overrides: bool = False,
                     fields: dict[str, Any] | None = None, doc: str = "") -> type[Strict]:
    """A strict scenario model named ``name`` with the fields of the dataclass ``part``
    (those in ``include`` if given, but ``exclude``): same names, types and defaults; a
    declared setting (:func:`setting`) checked by its :class:`Quantity`, which it carries
    in its metadata. ``overrides``: every field defaults to None instead, "keep the
    part's own" (for parts that start from a preset). ``fields`` adds the section's own
    fields (``{"preset": (str, "mission")}``, pydantic's ``create_model`` form); ``doc``
    is the model's docstring."""
    hints = typing.get_type_hints(part)
    definitions: dict[str, Any] = dict(fields or {})
    taken: list[str] = []
    for field in dataclasses.fields(part):
        if field.name in exclude or (include is not None and field.name not in include):
            continue
        kind = hints[field.name]
        quantity = quantity_of(field)
        taken.append(field.name)
        if quantity is not None:
            kind = Annotated[kind, quantity, _checked(quantity)]
        if overrides:
            definitions[field.name] = (kind | None, None)
            continue
        if field.default is not dataclasses.MISSING:
            default = field.default
        elif field.default_factory is not dataclasses.MISSING:
            default = field.default_factory()
        else:
            default = ...
        definitions[field.name] = (kind, default)
    model = create_model(name, __base__=Strict, __doc__=doc or part.__doc__,
                         __module__=__name__, **definitions)
    model.__part_fields__ = tuple(taken)  # type: ignore[attr-defined]
    return model


def part_settings(section: Strict, given: bool = False) -> dict[str, Any]:
    """The values of a section made by :func:`scenario_section` that are its part's
    fields (not those a subclass replaced, such as the camera's ``water``), as keyword
    arguments of the part (``given``: only those not None)."""
    names = type(section).__part_fields__  # type: ignore[attr-defined]
    values = {k: getattr(section, k) for k in names}
    return {k: v for k, v in values.items() if v is not None} if given else values
