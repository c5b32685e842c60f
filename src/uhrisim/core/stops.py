"""Stop signals of the command line: SIGINT (Ctrl-C), SIGTERM (``timeout``, systemd, Ray,
``ros2 launch``) and SIGHUP (a closed terminal).

A stop raises where it lands — :class:`KeyboardInterrupt` for Ctrl-C,
:class:`~uhrisim.core.errors.StopRequested` for the others — so that what runs cleans up
(recording closed, metrics written). Some libraries swallow an exception raised inside
their callbacks (a schema validator built during start-up can), so every stop is also
remembered until it is handled: the simulation loop raises a remembered stop at its next
tick (:func:`raise_pending_stop`) and the command line at its end
(:func:`pending_stop`). A stop that lands while the JIT compiler (numba or llvmlite) is
on the stack is only remembered: raised inside llvmlite's ctypes callbacks it leaves the
object-cache buffer unset (a run stopped so once died of a segmentation fault), and
raised inside numba's unpickling of a cached kernel's constants (a callback from C) it
ends the run with a SystemError instead of the stop. Without
:func:`catch_stop_signals` (a library user, the tests) nothing is remembered and nothing
changes.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from uhrisim.core.errors import StopRequested

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_pending: list[int] = []  # the signals received and not yet handled, in order


def stop_exception(signum: int) -> BaseException:
    """What a stop signal raises: KeyboardInterrupt for SIGINT, StopRequested otherwise."""
    return KeyboardInterrupt() if signum == signal.SIGINT else StopRequested(signum)


#: The JIT compiler's packages, whose Python code C calls back (module docstring).
JIT_PACKAGES = ("llvmlite", "numba")


def _inside_the_jit_compiler(frame: FrameType | None) -> bool:
    """Whether numba's or llvmlite's code is on the stack below ``frame``."""
    packages = tuple(os.path.dirname(module.__file__) + os.sep for name in JIT_PACKAGES
                     if (module := sys.modules.get(name)) is not None
                     and module.__file__ is not None)
    while packages and frame is not None:
        if frame.f_code.co_filename.startswith(packages):
            return True
        frame = frame.f_back
    return False


def _on_stop(signum: int, frame: FrameType | None) -> None:
    _pending.append(signum)
    if not _inside_the_jit_compiler(frame):
        raise stop_exception(signum)


def catch_stop_signals() -> None:
    """Stop signals raise and are remembered (call from the main thread)."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, _on_stop)


@contextmanager
def handlers_kept() -> Iterator[None]:
    """The stop signals' handlers as they were, once the block ends: a command run in
    the process of its caller (a test, a notebook) leaves its signal handling as found."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    kept = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    try:
        yield
    finally:
        for signum, handler in kept.items():
            signal.signal(signum, handler)


@contextmanager
def stop_signals_deferred() -> Iterator[None]:
    """While a stopped run writes its recording and metrics (main thread only): another
    SIGINT, SIGTERM or SIGHUP is noted, not raised; afterwards the first is raised as
    :class:`StopRequested`, the handlers in force before being back."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived: list[int] = []
    with handlers_kept():
        for signum in STOP_SIGNALS:
            signal.signal(signum, lambda signum, _frame: arrived.append(signum))
        yield
    if arrived:
        raise StopRequested(arrived[0])


def stop_signum(stop: KeyboardInterrupt | StopRequested) -> int:
    """The signal a stop came from (Ctrl-C: SIGINT)."""
    return stop.signum if isinstance(stop, StopRequested) else signal.SIGINT


def pending_stop() -> int | None:
    """The first stop signal received and not yet handled, or None."""
    return _pending[0] if _pending else None


def stop_handled() -> None:
    """The stop was handled (its exception reached the command line): forget it."""
    _pending.clear()


def stop_message(signum: int) -> str:
    """The command line's words for a stop: ``interrupted`` or ``stopped by SIGTERM``."""
    return "interrupted" if signum == signal.SIGINT else str(StopRequested(signum))


def raise_pending_stop() -> None:
    """Raise a stop that was received but swallowed on its way (until it is handled)."""
    signum = pending_stop()
    if signum is not None:
        raise stop_exception(signum)
