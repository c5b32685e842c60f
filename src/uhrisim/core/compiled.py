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
