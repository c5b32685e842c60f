"""Optional compilation of the physics kernels with numba (``pip install "uhrisim[fast]"``).

A kernel of :mod:`uhrisim.dynamics` is written once, over the components of a state
(:mod:`uhrisim.core.elementwise`): numpy runs it on (N,) arrays, one numpy call per
operation. With numba installed, the *same* kernel, on floats, is compiled and called
once per vehicle in a compiled loop over the N rows — no numpy call per operation, which
is what costs at small N. The numpy path stays and the tests hold the two equal.

Set ``UHRISIM_NUMBA=0`` to run numpy only. Compiling costs about three seconds of CPU on
the first batch; numba keeps the result on disk, so later processes load it in a fraction
of that. The cache folder is ``$NUMBA_CACHE_DIR`` (else ``$XDG_CACHE_HOME`` or
``~/.cache``) ``/uhrisim-numba/<state>``, where ``<state>`` digests the size and time of
every source file of the package: numba notices a change of a kernel's own file but not of
a kernel it calls from another file, so any edit starts a fresh folder (old ones may be
deleted at will). Where no cache folder is writable, each process compiles.
"""

from __future__ import annotations

import hashlib
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
        numba = importlib.import_module("numba")
    except ImportError:
        return None
    numba.config.CACHE_DIR = kernel_cache_folder()
    return numba


def kernel_cache_folder() -> str:
    """The folder for this state of the package's compiled kernels (see the module's text)."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    state = hashlib.sha256()
    for folder, subfolders, files in os.walk(package):
        subfolders.sort()
        for name in sorted(files):
            if name.endswith(".py"):
                stat = os.stat(os.path.join(folder, name))
                state.update(f"{folder}/{name}:{stat.st_size}:{stat.st_mtime_ns}\n".encode())
    user_cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    base = os.environ.get("NUMBA_CACHE_DIR") or user_cache
    return os.path.join(base, "uhrisim-numba", state.hexdigest()[:16])


def jit(function: Callable[..., Any], numpy_errors: bool = False, on_disk: bool = True
        ) -> Callable[..., Any] | None:
    """``function`` compiled in numba's nopython mode (lazily, at its first call), or None
    without numba. ``numpy_errors``: a division by zero gives inf or NaN as in numpy
    instead of raising, so that loops with divisions vectorise (same IEEE results).
    ``on_disk=False`` for a closure (numba cannot cache what it captures)."""
    numba = numba_module()
    if numba is None:
        return None
    options = {"nogil": True, "error_model": "numpy" if numpy_errors else "python"}
    if on_disk:
        try:
            return numba.njit(cache=True, **options)(function)
        except RuntimeError:  # no writable cache folder (read-only package and home)
            pass
    return numba.njit(**options)(function)


def typed_entry(kernel: Any, *arguments: Any) -> Callable[..., Any]:
    """The compiled entry of the :func:`jit` ``kernel`` for the numba types of
    ``arguments`` (compiled, or loaded from the disk cache, now). Calling it skips numba's
    dispatch, which types every argument at every call (microseconds for each named tuple
    of settings): its callers pass arguments of exactly these types (dtypes, dimensions,
    C-contiguous arrays), which nothing checks."""
    numba = numba_module()
    return kernel.compile(tuple(numba.typeof(a) for a in arguments))


@cache
def callable_compiled(function: Callable[..., Any]) -> None:
    """Let compiled kernels call ``function`` (numba compiles it where they do); it stays
    a plain Python function for the numpy paths. Once a process (each registration would
    compile it anew for its callers); nothing without numba."""
    numba = numba_module()
    if numba is not None:
        numba.extending.register_jitable(function)


def jit_with(function: Callable[..., Any], helpers: tuple[Callable[..., Any], ...],
             on_disk: bool = True, numpy_errors: bool = False) -> Callable[..., Any] | None:
    """:func:`jit` of ``function``, which calls the plain functions ``helpers`` (kernels
    written for :mod:`uhrisim.core.elementwise`): each is registered with numba, compiled
    where ``function`` calls it and left as it is for Python callers. None without numba.
    ``on_disk`` and ``numpy_errors`` as for :func:`jit`."""
    numba = numba_module()
    if numba is None:
        return None
    _register_frames(numba)
    for helper in (_cos, _sin, _clip, _where, _sqrt, _copysign, _remainder, float_ops,
                   *helpers):
        callable_compiled(helper)
    return jit(function, numpy_errors=numpy_errors, on_disk=on_disk)


def float_ops() -> Elementwise:
    """:data:`~uhrisim.core.elementwise.FLOATS_AS_ARRAYS` for a compiled kernel, which calls
    this to form the ``ops`` it gives the kernels it calls (:func:`jit_with` lets it): a
    set of plain functions that numba compiles where they are called, so the kernel that
    forms it can be kept on disk (one given compiled functions as an argument or a global
    value cannot)."""
    return Elementwise(_cos, _sin, _clip, _where, _sqrt, _copysign, _remainder, False)


def _cos(x: float) -> float:
    return math.cos(x)


def _sin(x: float) -> float:
    return math.sin(x)


def _sqrt(x: float) -> float:
    return math.sqrt(x)


def _copysign(x: float, y: float) -> float:
    return math.copysign(x, y)


_clip, _where, _remainder = (FLOATS_AS_ARRAYS.clip, FLOATS_AS_ARRAYS.where,
                             FLOATS_AS_ARRAYS.remainder)


def record(settings: Any) -> tuple:
    """A settings dataclass's fields as a named tuple (the values, by name), which numba can
    take where the kernels read ``settings.field``."""
    names = tuple(f.name for f in fields(settings))
    return _record_type(type(settings).__name__, names)(*(getattr(settings, n) for n in names))


@cache
def _record_type(name: str, names: tuple[str, ...]) -> type:
    """A named tuple class kept as an attribute of this module, so that pickle (numba's
    disk cache keys a kernel by the types of its arguments) finds it by name."""
    key = f"{name}_record_{hashlib.sha256(' '.join(names).encode()).hexdigest()[:8]}"
    kind = namedtuple(key, names, module=__name__)
    globals()[key] = kind
    return kind


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
