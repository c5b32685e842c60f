"""Optional compilation of the physics kernels with numba (``pip install "uhrisim[fast]"``).

A kernel of :mod:`uhrisim.dynamics` is written once, over the components of a state
(:mod:`uhrisim.core.elementwise`): numpy runs it on (N,) arrays, one numpy call per
operation. With numba installed, the *same* kernel, on floats, is compiled and called
once per vehicle in a compiled loop over the N rows — no numpy call per operation, which
is what costs at small N. The numpy path stays and the tests hold the two equal.

Set ``UHRISIM_NUMBA=0`` to run numpy only. Compiling costs about three seconds of CPU on
the first batch; numba keeps the result in ``__pycache__`` beside the kernel's module (or
in ``NUMBA_CACHE_DIR``), so later processes load it in a fraction of that, until the
module's source changes. Where no cache folder is writable, each process compiles.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from functools import cache
from typing import Any


@cache
def numba_module() -> Any:
    """The numba module, or None when it is not installed or ``UHRISIM_NUMBA=0``."""
    if os.environ.get("UHRISIM_NUMBA", "1") == "0":
        return None
    try:
        return importlib.import_module("numba")
    except ImportError:
        return None


def jit(function: Callable[..., Any], numpy_errors: bool = False) -> Callable[..., Any] | None:
    """``function`` compiled in numba's nopython mode (lazily, at its first call), or None
    without numba. ``numpy_errors``: a division by zero gives inf or NaN as in numpy
    instead of raising, so that loops with divisions vectorise (same IEEE results)."""
    numba = numba_module()
    if numba is None:
        return None
    model = "numpy" if numpy_errors else "python"
    try:
        return numba.njit(cache=True, nogil=True, error_model=model)(function)
    except RuntimeError:  # no writable cache place (read-only package and home): compile each run
        return numba.njit(nogil=True, error_model=model)(function)



@cache
def callable_compiled(function: Callable[..., Any]) -> None:
    """Let compiled kernels call ``function`` (numba compiles it where they do); it stays
    a plain Python function for the numpy paths. Nothing without numba."""
    numba = numba_module()
    if numba is not None:
        numba.extending.register_jitable(function)
