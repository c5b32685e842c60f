"""A bound on the work a call does that holds on a busy machine: its peak Python memory.

Wall-clock bounds fail when other work takes the cores; the memory a refusal allocates
does not depend on the load. A scene or document built before it is refused (ten million
polygon points, a YAML alias bomb expanded) allocates hundreds of megabytes; one refused
up front a few.
"""

from __future__ import annotations

import contextlib
import tracemalloc
from collections.abc import Iterator
from dataclasses import dataclass


@dataclass
class PeakMemory:
    """The peak of Python allocations (bytes) inside a :func:`peak_memory` block."""

    bytes: int = 0

    @property
    def mib(self) -> float:
        return self.bytes / 2**20


@contextlib.contextmanager
def peak_memory() -> Iterator[PeakMemory]:
    """Measure the peak of Python allocations inside the block (tracemalloc)."""
    peak = PeakMemory()
    tracemalloc.start()
    try:
        yield peak
    finally:
        peak.bytes = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
