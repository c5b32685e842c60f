"""The assistant's parameters: its guards, speeds and distances (docs/hri.md).

Distances are from the ROV's centre (m). The guards are hard limits the tree never lets
the ROV break by its own motion: ``body_guard_m`` from the diver's body (the segment
from the pelvis up to the neck) and ``head_guard_m`` from the head. A handover needs
the ROV at arm's reach — its jaws at the diver's hand, which a 1.75 m diver holds about
0.6 m ahead of the body at chest height — so the defaults leave room for that: the ROV's
centre then sits about 0.9 m from the body and the head. The diver's hands are not
guarded: touching the ROV at arm's reach is the point of a handover.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

from uhrisim.core.errors import ConfigError
from uhrisim.perception.signals import CHANNELS, COMMANDS


@dataclass(frozen=True)
class AssistantConfig:
    """Parameters (SI units; module docstring). ``default_task``: what the ROV does with
    no command in hand ("idle": hold where it is, facing the diver; or a command such
    as "follow_me")."""

    body_guard_m: float = 0.6
    head_guard_m: float = 0.7
    trigger_margin_m: float = 0.15  # back off when closer than a guard + this
    clearance_m: float = 0.2  # a target near the diver keeps a guard + this
    backoff_to_m: float = 0.5  # back off until a guard + this
    backoff_speed: float = 0.2  # m/s astern, plus the diver's closing speed (at most
    # cruise_speed): a diver swimming at the ROV is outrun
    guard_lookahead_s: float = 2.0  # the guard also looks this far ahead along his track
    slow_radius_m: float = 1.5  # within it the ROV moves at most near_speed ...
    slow_lead_m: float = 1.4  # ... and the ceiling lowered this much farther out: from
    # cruise_speed, a 1 s speed time constant and a 0.25 s helm tick need about that
    near_speed: float = 0.2
    cruise_speed: float = 0.5
    creep_speed: float = 0.08  # the last approach to a grasp or a hand
    carry_speed: float = 0.3  # transits at most this while the gripper holds something:
    # with the lift bag the VideoRay's thrust runs out at 0.48 m/s, both thrusters
    # saturated and nothing left to steer with (docs/hri.md)
    max_closing_speed: float = 0.3  # within slow_radius: faster closing, stop
    lost_after_s: float = 3.0  # a track older than this is lost
    lost_standoff_m: float = 2.5  # back off this far from where the diver was last seen
    min_confidence: float = 0.6  # signals below it are ignored (and logged)
    obey: tuple[str, ...] = CHANNELS  # the channels whose signals it acts on (the others
    # are logged): e.g. only the slate, where a reader says commands nobody made
    follow_range_m: float = 3.0  # beyond slow_radius_m + slow_lead_m: free to keep up
    standoff_m: float = 2.0  # waiting distance in front of the diver before a handover
    reach_m: float = 1.0  # come here: the ROV's centre from the diver's body, at arm's reach
    light_standoff_m: float = 1.5  # light here: horizontal distance from the work
    light_above_m: float = 0.4  # ... and height above it
    basket_standoff_m: float = 1.0  # where a grasp's last approach starts
    handover_gap_m: float = 0.1  # the jaws stop this short of the diver's hand
    handover_wait_s: float = 30.0  # then back off and offer again
    grasp_tolerance_m: float = 0.025  # jaws to grasp point before closing
    position_tolerance_m: float = 0.3
    depth_tolerance_m: float = 0.15
    heading_tolerance_deg: float = 5.0
    redrive_m: float = 0.3  # holding a station: drive back when pushed off this far
    surface_depth_m: float = 0.5  # go up: the depth to rise to
    fetch_attempts: int = 3
    ask_after_s: float = 15.0  # idle, the diver hovering within ask_range_m, nothing read
    # for this long: ask him to say it again (the "say again?" cue, docs/hri.md)
    ask_range_m: float = 4.0
    ask_max: int = 3  # asks in a row without a signal read in between
    wag_deg: float = 20.0  # the cue: the lamps swung off him this far and back, twice
    depth_trim_rate: float = 0.3  # holding a tool: depth trim per s per m of sag (1/s)
    depth_trim_max_m: float = 4.0  # ... at most this much shallower
    jaw_frd: tuple[float, float, float] = (0.25, 0.0, 0.14)  # the gripper's jaw centre
    default_task: str = "idle"
    watch_range_m: float | None = None  # idle: keep this far (horizontally) from the
    # diver, on his side towards the ROV, at his chest's depth, facing him — level, at the
    # ranges the gesture reader was fitted on (2-4.5 m), as an operator waiting for a
    # signal holds the camera on him; None: idle holds where it is

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "jaw_frd":
                if len(v) != 3 or not all(math.isfinite(float(c)) for c in v):
                    raise ConfigError(f"must be 3 finite numbers, got {v!r}",
                                      "assistant.jaw_frd")
            elif f.name == "default_task":
                if v not in ("idle", *COMMANDS) or v in ("bring_tool", "ok", "done"):
                    raise ConfigError(f"must be idle or a command without an argument, got "
                                      f"{v!r}", "assistant.default_task")
            elif f.name == "obey":
                if isinstance(v, str) or not v or not set(v) <= set(CHANNELS):
                    raise ConfigError(f"must be a list of one or more of {', '.join(CHANNELS)}"
                                      f", got {v!r}", "assistant.obey")
            elif f.name == "watch_range_m" and v is None:
                continue
            elif f.name in ("fetch_attempts", "ask_max"):
                if not (isinstance(v, int) and v >= 1):
                    raise ConfigError(f"must be an integer >= 1, got {v!r}",
                                      f"assistant.{f.name}")
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not (
                    math.isfinite(v) and v > 0.0):
                raise ConfigError(f"must be a finite number > 0, got {v!r}",
                                  f"assistant.{f.name}")
        if self.clearance_m <= self.trigger_margin_m:
            raise ConfigError("must exceed trigger_margin_m, or the ROV's own targets would "
                              "set off its guard", "assistant.clearance_m")
        if self.backoff_to_m <= self.clearance_m:
            raise ConfigError("must exceed clearance_m", "assistant.backoff_to_m")
        if self.near_speed > self.cruise_speed or self.creep_speed > self.near_speed:
            raise ConfigError("need creep_speed <= near_speed <= cruise_speed", "assistant")
        reach = max(self.body_guard_m, self.head_guard_m) + self.backoff_to_m
        if self.watch_range_m is not None and self.watch_range_m <= reach:
            raise ConfigError(f"must exceed the larger guard + backoff_to_m ({reach:g} m), or "
                              "watching would drive the ROV into its own back-off",
                              "assistant.watch_range_m")

    @staticmethod
    def from_mapping(data: Mapping[str, object] | None, where: str = "assistant"
                     ) -> AssistantConfig:
        """From a scenario's mapping; unknown keys and bad values name the field."""
        data = dict(data or {})
        known = {f.name for f in fields(AssistantConfig)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"unknown parameter(s) {unknown}", where)
        for name in ("jaw_frd", "obey"):
            if name in data and isinstance(data[name], (list, tuple)):
                data[name] = tuple(data[name])  # type: ignore[arg-type]
        try:
            return AssistantConfig(**data)  # type: ignore[arg-type]
        except ConfigError as error:  # "assistant.field: ..." -> "<where>.field: ..."
            raise ConfigError(str(error).replace("assistant", where, 1)) from None
