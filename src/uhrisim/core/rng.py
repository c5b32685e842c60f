"""Explicit, named randomness: one root seed, one Generator per component.

The stream of a component depends only on the root seed and the component's stable
name, so adding a sensor does not change the diver's noise (docs/design.md habit 5).
"""

from __future__ import annotations

import hashlib

import numpy as np


def _name_key(name: str) -> list[int]:
    digest = hashlib.sha256(name.encode("utf-8")).digest()
    return [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 16, 4)]


def component_rng(root_seed: int, name: str) -> np.random.Generator:
    """Generator for the component called ``name`` (e.g. "videoray/sonar") under ``root_seed``."""
    if root_seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {root_seed}")
    sequence = np.random.SeedSequence([root_seed, *_name_key(name)])
    return np.random.Generator(np.random.PCG64(sequence))
