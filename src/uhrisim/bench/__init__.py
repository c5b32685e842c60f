"""Benchmarks: each module ``uhrisim.bench.<name>`` exposes ``run(quick=False) -> dict``.

They print rates and ratios (``uhrisim bench NAME [--json]``, ``make bench``); speed
targets live here, never as wall-clock asserts in tests.
"""

from __future__ import annotations

import importlib
import pkgutil
import time
from collections.abc import Callable
from typing import Any


def available() -> list[str]:
    """Names of the benchmark modules in this package."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


def run_benchmark(name: str, quick: bool = False) -> dict[str, Any]:
    """Import ``uhrisim.bench.<name>`` and run it."""
    if name not in available():
        raise KeyError(f"unknown benchmark {name!r}; available: {', '.join(available())}")
    module = importlib.import_module(f"{__name__}.{name}")
    return module.run(quick=quick)


def best_rate(work: Callable[[], object], repeats: int, min_time: float = 0.2) -> float:
    """Calls per second of ``work``: best of a few timed batches of ``repeats`` calls."""
    best = 0.0
    deadline = time.perf_counter() + max(min_time, 0.0)
    while True:
        start = time.perf_counter()
        for _ in range(repeats):
            work()
        elapsed = time.perf_counter() - start
        best = max(best, repeats / elapsed if elapsed > 0 else float("inf"))
        if time.perf_counter() >= deadline:
            return best


class Stopwatch:
    """A method of one object, timed in CPU seconds of this thread as it is called."""

    def __init__(self, method: Callable[..., Any]) -> None:
        self.method, self.seconds, self.calls = method, 0.0, 0

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        start = time.thread_time()
        try:
            return self.method(*args, **kwargs)
        finally:
            self.seconds += time.thread_time() - start
            self.calls += 1
