"""Typed exceptions. Library code raises these; the CLI turns them into one-line messages."""

from __future__ import annotations

import logging
import signal
import warnings

#: The most characters of a message that quotes a value: a bad value of 1.5 million
#: characters is quoted by its start and its length, not repeated whole.
MESSAGE_LIMIT = 400


def shortened(text: str, limit: int = MESSAGE_LIMIT) -> str:
    """``text``, or its first ``limit`` characters and how many there were."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text)} characters in all)"


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (at most 200 characters), or its type name
    when the message is empty: for one-line error messages that wrap a library's error."""
    text = str(exc).strip()
    return text.splitlines()[0][:200] if text else type(exc).__name__


class UhrisimError(Exception):
    """Base class of every error uhrisim raises on purpose."""


class ConfigError(UhrisimError, ValueError):
    """A scenario, parameter or command-line value is invalid.

    ``where`` names the file/field/line so the message points at the problem;
    ``problem`` is the message without it.
    """

    def __init__(self, message: str, where: str | None = None) -> None:
        self.where = where
        self.problem = message = shortened(message)
        super().__init__(f"{shortened(where)}: {message}" if where else message)


class NumericalError(UhrisimError, ArithmeticError):
    """A state became NaN/inf, or an integration step would be unstable."""

    def __init__(self, message: str, vehicle: str | None = None, t: float | None = None) -> None:
        self.vehicle = vehicle
        self.t = t
        parts = []
        if vehicle is not None:
            parts.append(f"vehicle {vehicle!r}")
        if t is not None:
            parts.append(f"t={t:.3f} s")
        prefix = (", ".join(parts) + ": ") if parts else ""
        super().__init__(prefix + message)


class AssetError(UhrisimError, OSError):
    """A mesh or data file is missing, unreadable or corrupt."""


class MissingExtraError(UhrisimError, ImportError):
    """A feature in use needs an optional extra that is not installed (the message names
    the ``pip install "uhrisim[extra]"`` to run)."""


class BridgeError(UhrisimError, ConnectionError):
    """A ROS 2 / MOOS peer is unreachable or spoke something we cannot accept."""


class StopRequested(BaseException):
    """A stop signal (SIGTERM from ``timeout``, systemd, Ray or ``ros2 launch``; SIGHUP
    from a closed terminal) ends the run as Ctrl-C does: what runs cleans up (recording
    closed, metrics.json written with ``completed: false`` and the reason); the command
    exits with 128 + the signal's number. A BaseException, like KeyboardInterrupt, so
    that nothing catching ``Exception`` swallows it."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(f"stopped by {signal.Signals(self.signum).name}")


class UhrisimWarning(UserWarning):
    """A warning of uhrisim's own (:func:`warn_user`): logged as well, so the command line
    shows the log line and not the warning a second time."""


def warn_user(message: str, stacklevel: int = 2) -> None:
    """Tell the user a default or a correction was applied: logged (the command line shows
    it) and raised as an :class:`UhrisimWarning`, a ``UserWarning`` (tests and callers can
    catch it)."""
    logging.getLogger("uhrisim").warning(message)
    warnings.warn(message, UhrisimWarning, stacklevel=stacklevel + 1)
