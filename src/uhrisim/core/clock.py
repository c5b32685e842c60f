"""Simulation time is integer ticks of the physics step (docs/design.md habit 4).

Every rate (sonar, helm, controller, contacts, recorder) is a whole number of ticks,
checked when the simulation is built: :func:`ticks_for_rate` is that check.
"""

from __future__ import annotations

from uhrisim.core.errors import ConfigError


def ticks_for_rate(rate_hz: float, dt: float, where: str) -> int:
    """Whole number of physics steps of ``dt`` (s) per period of ``rate_hz`` (Hz);
    ConfigError naming ``where`` otherwise."""
    ticks = 1.0 / (rate_hz * dt)
    whole = round(ticks)
    if whole < 1 or abs(ticks - whole) > 1e-6 * max(1.0, ticks):
        raise ConfigError(
            f"rate {rate_hz:g} Hz is not a whole number of physics steps of {dt:g} s "
            f"({ticks:.4g} steps); choose a rate that divides the physics rate "
            f"{1.0 / dt:g} Hz", where=where)
    return whole
