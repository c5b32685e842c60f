"""A time bound on a block of test code: past it the test fails (no hang of the suite)."""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator

import pytest


@contextlib.contextmanager
def time_limit(seconds: int, what: str) -> Iterator[None]:
    """Fail the running test if the block takes longer than ``seconds`` (SIGALRM: main
    thread only). The failure is raised from inside the block, past any ``except
    Exception`` of the code under test."""

    def alarm(signum, frame):
        pytest.fail(f"no answer within {seconds} s for {what}")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
