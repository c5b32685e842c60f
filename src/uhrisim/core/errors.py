"""Typed exceptions. Library code raises these; the CLI turns them into one-line messages."""

from __future__ import annotations

import logging
import warnings


class UhrisimError(Exception):
    """Base class of every error uhrisim raises on purpose."""


class ConfigError(UhrisimError, ValueError):
    """A scenario, parameter or command-line value is invalid.

    ``where`` names the file/field/line so the message points at the problem.
    """

    def __init__(self, message: str, where: str | None = None) -> None:
        self.where = where
        super().__init__(f"{where}: {message}" if where else message)


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


def warn_user(message: str, stacklevel: int = 2) -> None:
    """Tell the user a default or a correction was applied: logged (the command line shows
    it) and raised as a ``UserWarning`` (tests and callers can catch it)."""
    logging.getLogger("uhrisim").warning(message)
    warnings.warn(message, UserWarning, stacklevel=stacklevel + 1)
