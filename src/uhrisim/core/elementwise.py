"""Elementwise math that one kernel can run on plain floats or on numpy arrays.

The physics and control kernels (``dynamics/``, ``control/``) are written once, over the
components of N vehicles' states; they take an :class:`Elementwise` and run on Python
floats for one vehicle (:data:`FLOATS`, no numpy call per operation) or on (N,) arrays
for many (:data:`ARRAYS`). The arithmetic operators and ``abs`` work on both already;
this holds the rest. Both sets round every operation the same way (IEEE 754 double),
except that :data:`ARRAYS` ``remainder`` is ``x - tau·rint(x/tau)`` where :data:`FLOATS`
uses the exact ``math.remainder`` (a difference of one rounding, ~1e-16 rad).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np


class Elementwise(NamedTuple):
    """The functions a kernel calls by name: trigonometry, ``clip(v, low, high)``,
    ``where(condition, a, b)`` (both computed), ``sqrt``, ``copysign`` and the IEEE
    ``remainder(x, y)`` (result in [-y/2, y/2]); ``batched``: the values are (N,) arrays
    (a kernel may take a shortcut on one float that an array cannot)."""

    cos: Callable[[Any], Any]
    sin: Callable[[Any], Any]
    clip: Callable[[Any, Any, Any], Any]
    where: Callable[[Any, Any, Any], Any]
    sqrt: Callable[[Any], Any]
    copysign: Callable[[Any, Any], Any]
    remainder: Callable[[Any, Any], Any]
    batched: bool


def _clip_float(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


def _clip_array(value: np.ndarray, low: float, high: float) -> np.ndarray:
    """``np.clip``'s values (NaN stays NaN) by two ufuncs: np.clip's own dispatch costs
    more than its work on a few thousand rows."""
    return np.minimum(np.maximum(value, low), high)


def _where_float(condition: bool, a: float, b: float) -> float:
    return a if condition else b


def _remainder_array(x: np.ndarray, y: float) -> np.ndarray:
    return x - y * np.rint(x / y)


def _remainder_float(x: float, y: float) -> float:
    """:data:`ARRAYS`' remainder on one float (``round`` rounds half to even, as np.rint)."""
    return x - y * round(x / y)


FLOATS = Elementwise(math.cos, math.sin, _clip_float, _where_float, math.sqrt, math.copysign,
                     math.remainder, False)
ARRAYS = Elementwise(np.cos, np.sin, _clip_array, np.where, np.sqrt, np.copysign, _remainder_array,
                     True)
#: The float functions numba compiles a kernel with (:func:`uhrisim.core.compiled.floats`):
#: as :data:`FLOATS`, but with :data:`ARRAYS`' remainder, so that a compiled kernel run row by
#: row gives what the numpy one gives on the rows together.
FLOATS_AS_ARRAYS = FLOATS._replace(remainder=_remainder_float)
