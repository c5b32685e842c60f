"""Optional compilation of the physics kernels with numba (``pip install "uhrisim[fast]"``).

A kernel of :mod:`uhrisim.dynamics` is written once, over the components of a state
(:mod:`uhrisim.core.elementwise`): numpy runs it on (N,) arrays, one numpy call per
operation. With numba installed, the *same* kernel, on floats, is compiled and called
once per vehicle in a compiled loop over the N rows — no numpy call per operation, which
is what costs at small N. The numpy path stays and the tests hold the two equal.

Set ``UHRISIM_NUMBA=0`` to run numpy only. Compiling costs a second or two, once per
process, on the first batch (nothing is written to disk).
"""

from __future__ import annotations

import importlib
import math
import os
from collections import namedtuple
from collections.abc import Callable
from dataclasses import fields
from functools import cache
from typing import Any

from uhrisim.core import frames
from uhrisim.core.elementwise import FLOATS_AS_ARRAYS, Elementwise


@cache
def numba_module() -> Any:
    """The numba module, or None when it is not installed or ``UHRISIM_NUMBA=0``."""
    if os.environ.get("UHRISIM_NUMBA", "1") == "0":
        return None
    try:
        return importlib.import_module("numba")
    except ImportError:
        return None


def jit(function: Callable[..., Any]) -> Callable[..., Any] | None:
    """``function`` compiled in numba's nopython mode (lazily, at its first call), or None
    without numba."""
    numba = numba_module()
    return None if numba is None else numba.njit(cache=False, nogil=True)(function)



def jit_with(function: Callable[..., Any], helpers: tuple[Callable[..., Any], ...]
             ) -> Callable[..., Any] | None:
    """:func:`jit` of ``function``, which calls the plain functions ``helpers`` (kernels
    written for :mod:`uhrisim.core.elementwise`): each is registered with numba, compiled
    where ``function`` calls it and left as it is for Python callers. None without numba."""
    numba = numba_module()
    if numba is None:
        return None
    _register_frames(numba)
    for helper in helpers:
        _register(numba, helper)
    return jit(function)


@cache
def _register(numba: Any, helper: Callable[..., Any]) -> None:
    """``helper`` registered with numba, once a process (each registration would compile
    it anew for its callers)."""
    numba.extending.register_jitable(helper)


@cache
def floats() -> Elementwise | None:
    """:data:`~uhrisim.core.elementwise.FLOATS_AS_ARRAYS` compiled: the elementwise set a
    compiled kernel is given as its ``ops``; None without numba."""
    numba = numba_module()
    if numba is None:
        return None
    compiled = {name: numba.njit(getattr(FLOATS_AS_ARRAYS, name))
                for name in ("clip", "where", "remainder")}
    return FLOATS_AS_ARRAYS._replace(
        cos=numba.njit(lambda x: math.cos(x)), sin=numba.njit(lambda x: math.sin(x)),
        sqrt=numba.njit(lambda x: math.sqrt(x)),
        copysign=numba.njit(lambda x, y: math.copysign(x, y)), **compiled)


def record(settings: Any) -> tuple:
    """A settings dataclass's fields as a named tuple (the values, by name), which numba can
    take where the kernels read ``settings.field``."""
    names = tuple(f.name for f in fields(settings))
    return _record_type(type(settings).__name__, names)(*(getattr(settings, n) for n in names))


@cache
def _record_type(name: str, names: tuple[str, ...]) -> type:
    return namedtuple(name, names)


@cache
def _register_frames(numba: Any) -> None:
    """The compiled form of :mod:`uhrisim.core.frames`' angle wraps, on one float: their own
    float arithmetic (``isinstance`` picks that branch in Python)."""
    overload = numba.extending.overload
    overload(frames.wrap_360)(lambda angle_deg: lambda angle_deg: angle_deg % 360.0)
    overload(frames.wrap_180)(
        lambda angle_deg: lambda angle_deg: (angle_deg + 180.0) % 360.0 - 180.0)
    overload(frames.heading_deg_from_yaw)(
        lambda yaw_rad: lambda yaw_rad: math.degrees(yaw_rad) % 360.0)
