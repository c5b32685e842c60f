"""Command validation in one place: every command value from ROS 2 passes here before the
simulation sees it (no rclpy needed).

A value is **refused** (not stored, the previous command stays in force) when it cannot
be honoured at all: not finite, a thruster array of the wrong length, a negative speed for
a vehicle whose controller cannot reverse. A value outside the vehicle's envelope is
**clamped** to it: speed to ``[0, max_speed]`` (``[-max_speed, max_speed]`` when the
controller reverses), depth to ``[0, floor - clearance]``, thruster inputs to
``±thruster_limit``. Headings are wrapped to [0, 360) (not a rejection). The floor limit
depends on where the vehicle is when the command takes effect, so the simulation's side
applies it (:meth:`CommandValidator.depth_above_floor`) when it takes a depth command.
Every refusal and clamp is counted per topic and reason (:meth:`CommandValidator.counts`)
and reported to a log function, rate-limited per topic and reason (the first at once,
then at most one a ``log_period_s`` with how many of each value were suppressed): the
bridge hands
rclpy's logger here, so rejections appear on ``/rosout``.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import wrap_360
from uhrisim.dynamics.videoray import INPUT_LIMIT as THRUSTER_LIMIT  # ±150, dimensionless

#: Seconds between two log lines of one topic and reason (wall clock).
LOG_PERIOD_S = 5.0
#: Distinct suppressed values a report lists one by one (the rest are summed up).
LISTED_VALUES = 4


@dataclass(frozen=True)
class CommandEnvelope:
    """What one vehicle can be asked to do.

    ``max_speed`` (m/s, > 0; ``math.inf``: no limit); ``reverse``: its controller can hold
    a heading while backing up (negative desired speed); ``thruster_count`` and
    ``thruster_limit``: the length and range of ``cmd/thrusters``. The depth limit is not
    here: it depends on where the vehicle is (:meth:`CommandValidator.depth_above_floor`).
    """

    max_speed: float = math.inf
    reverse: bool = False
    thruster_count: int = 3
    thruster_limit: float = THRUSTER_LIMIT

    def __post_init__(self) -> None:
        if not self.max_speed > 0.0:
            raise ConfigError(f"must be > 0 m/s, got {self.max_speed!r}",
                              "CommandEnvelope.max_speed")
        if not (self.thruster_limit > 0.0 and math.isfinite(self.thruster_limit)):
            raise ConfigError(f"must be a finite number > 0, got {self.thruster_limit!r}",
                              "CommandEnvelope.thruster_limit")
        if self.thruster_count < 1:
            raise ConfigError(f"must be >= 1, got {self.thruster_count!r}",
                              "CommandEnvelope.thruster_count")


@dataclass
class _LogSlot:
    """One topic and reason's last report (wall time) and what was suppressed since:
    value (the report's detail) -> how many times."""

    t_wall: float
    suppressed: dict[str, int] = field(default_factory=dict)

    def summary(self) -> str:
        """`` (N more since the last report: 3× -5 m/s, 2× -7 m/s)``, or ``""``."""
        if not self.suppressed:
            return ""
        ranked = sorted(self.suppressed.items(), key=lambda kv: -kv[1])
        parts = [f"{n}× {detail}" for detail, n in ranked[:LISTED_VALUES]]
        rest = ranked[LISTED_VALUES:]
        if rest:
            parts.append(f"{sum(n for _, n in rest)}× {len(rest)} other values")
        total = sum(self.suppressed.values())
        return f" ({total} more since the last report: {', '.join(parts)})"


class CommandValidator:
    """Checks the commands of the agents of ``envelopes`` (ROS name -> envelope).

    ``log`` (settable) receives one line per reported rejection (the bridge sets its
    node's rclpy logger's ``warning``: the line goes to ``/rosout``). Thread-safe: the
    bridge's executor thread checks what arrives, the simulation thread the floor limit,
    and reads the counts. ``clock``: wall seconds (monotonic) for the reports' rate limit.
    """

    def __init__(self, envelopes: dict[str, CommandEnvelope],
                 log: Callable[[str], Any] | None = None,
                 log_period_s: float = LOG_PERIOD_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._envelopes = dict(envelopes)
        self._clock = clock  # wall seconds, for the reports' rate limit
        self.log = log
        self._log_period = log_period_s
        self._lock = threading.Lock()
        self._counts: dict[str, dict[str, int]] = {}
        self._logged: dict[tuple[str, str], _LogSlot] = {}
        self.refused = 0
        self.clamped = 0

    def counts(self) -> dict[str, dict[str, int]]:
        """Rejections so far: topic -> reason -> count (a copy)."""
        with self._lock:
            return {topic: dict(reasons) for topic, reasons in self._counts.items()}

    # ----------------------------------------------------------------- checks
    def desired(self, agent: str, key: str, value: float) -> float | None:
        """``value`` of ``/<agent>/cmd/<key>`` (``desired_heading`` compass deg,
        ``desired_speed`` m/s, ``desired_depth`` m down) as the simulation should take
        it, or None when refused."""
        topic = f"/{agent}/cmd/{key}"
        v = float(value)
        if not math.isfinite(v):
            return self._refuse(topic, "not finite", f"{v}")
        if key == "desired_heading":
            return float(wrap_360(v))
        if key == "desired_speed":
            env = self._envelopes[agent]
            if v < 0.0 and not env.reverse:
                return self._refuse(topic, "negative speed (the controller cannot reverse)",
                                    f"{v:g} m/s")
            lo = -env.max_speed if env.reverse else 0.0
            if not lo <= v <= env.max_speed:
                clamped = min(max(v, lo), env.max_speed)
                return self._clamp(topic, "outside the speed envelope", v, clamped, "m/s")
            return v
        if key == "desired_depth":
            return self._clamp(topic, "above the surface", v, 0.0, "m") if v < 0.0 else v
        raise ConfigError(f"unknown command {key!r}", "CommandValidator.desired")

    def depth_above_floor(self, agent: str, depth: float, deepest: float) -> float:
        """A desired depth (m, down, already checked by :meth:`desired`) of ``agent``
        clamped to ``deepest`` (m: the floor below it less the clearance; NaN: no floor
        known, no limit)."""
        if depth > deepest >= 0.0:
            return self._clamp(f"/{agent}/cmd/desired_depth",
                               "below the floor less the clearance", depth, deepest, "m")
        return depth

    def thrusters(self, agent: str, values: Sequence[float]) -> tuple[float, ...] | None:
        """The thruster inputs of ``/<agent>/cmd/thrusters`` as the simulation should take
        them (clamped to the limit), or None when refused."""
        topic = f"/{agent}/cmd/thrusters"
        env = self._envelopes[agent]
        vals = [float(x) for x in values]
        if len(vals) != env.thruster_count:
            return self._refuse(topic, "wrong length",
                                f"{len(vals)} values, need {env.thruster_count}")
        if not all(math.isfinite(x) for x in vals):
            return self._refuse(topic, "not finite", f"{vals}")
        lim = env.thruster_limit
        clipped = tuple(min(lim, max(-lim, x)) for x in vals)
        if clipped != tuple(vals):
            self._count(topic, "thruster input beyond the limit", clamped=True,
                        detail=f"{vals} -> within ±{lim:g}")
        return clipped

    # ----------------------------------------------------------------- bookkeeping
    def _refuse(self, topic: str, reason: str, detail: str) -> None:
        self._count(topic, reason, clamped=False, detail=detail)
        return None

    def _clamp(self, topic: str, reason: str, value: float, clamped: float,
               unit: str) -> float:
        self._count(topic, reason, clamped=True,
                    detail=f"{value:g} {unit} -> {clamped:g} {unit}")
        return clamped

    def _count(self, topic: str, reason: str, *, clamped: bool, detail: str) -> None:
        now = self._clock()
        with self._lock:
            reasons = self._counts.setdefault(topic, {})
            reasons[reason] = reasons.get(reason, 0) + 1
            if clamped:
                self.clamped += 1
            else:
                self.refused += 1
            slot = self._logged.get((topic, reason))
            if slot is not None and now - slot.t_wall < self._log_period:
                slot.suppressed[detail] = slot.suppressed.get(detail, 0) + 1
                return
            more = "" if slot is None else slot.summary()
            self._logged[(topic, reason)] = _LogSlot(now)
        if self.log is not None:
            verb = "clamped" if clamped else "refused"
            self.log(f"command on {topic} {verb}: {reason}: {detail}{more}")
