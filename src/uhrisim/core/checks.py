"""Checks of configuration values shared by parameter classes."""

from __future__ import annotations

import math
from collections.abc import Iterable

from uhrisim.core.errors import ConfigError


def require_positive(owner: object, names: Iterable[str], where: str,
                     allow_zero: bool = False) -> None:
    """ConfigError ``"<where>.<name>: must be a finite number > 0, got ..."`` for the first
    attribute of ``owner`` among ``names`` that is not (``>= 0`` with ``allow_zero``)."""
    for name in names:
        value = getattr(owner, name)
        ok = (isinstance(value, (int, float)) and not isinstance(value, bool)
              and math.isfinite(value) and (value >= 0.0 if allow_zero else value > 0.0))
        if not ok:
            bound = ">= 0" if allow_zero else "> 0"
            raise ConfigError(f"must be a finite number {bound}, got {value!r}",
                              where=f"{where}.{name}")
