"""A stopped run's clean-up is not cut by another stop signal (issue 30: ``ros2 launch``
and impatient users send a second one): inside ``stop_signals_deferred`` SIGINT and
SIGTERM are noted, and the first is raised as StopRequested once the block is done; the
handlers in force before are back afterwards."""

from __future__ import annotations

import os
import signal

import pytest

from uhrisim.core.errors import StopRequested
from uhrisim.core.stops import stop_signals_deferred


def test_a_second_signal_waits_for_the_clean_up() -> None:
    before = {signum: signal.getsignal(signum) for signum in (signal.SIGTERM, signal.SIGINT)}
    finished = []
    with pytest.raises(StopRequested) as stop, stop_signals_deferred():
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGINT)
        finished.append("recording closed")  # reached: neither signal raised here
    assert finished == ["recording closed"] and stop.value.signum == signal.SIGTERM
    assert {signum: signal.getsignal(signum) for signum in before} == before


def test_no_signal_no_stop() -> None:
    with stop_signals_deferred():
        pass
