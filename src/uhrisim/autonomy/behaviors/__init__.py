"""IvP behaviors: ConstantDepth, ConstantHeading, ConstantSpeed, MaxSpeed, Loiter, Trail,
AvoidCollision, Waypoint, StationKeep."""

from __future__ import annotations

from uhrisim.autonomy.behaviors.avoid_collision import AvoidCollision
from uhrisim.autonomy.behaviors.base import (
    Behavior,
    BehaviorContext,
    CommonParams,
    ContactInfo,
    OwnNav,
)
from uhrisim.autonomy.behaviors.constant_depth import ConstantDepth
from uhrisim.autonomy.behaviors.constant_heading import ConstantHeading
from uhrisim.autonomy.behaviors.constant_speed import ConstantSpeed
from uhrisim.autonomy.behaviors.loiter import Loiter
from uhrisim.autonomy.behaviors.max_speed import MaxSpeed
from uhrisim.autonomy.behaviors.station_keep import StationKeep
from uhrisim.autonomy.behaviors.trail import Trail
from uhrisim.autonomy.behaviors.waypoint import Waypoint
from uhrisim.core.errors import ConfigError

REGISTRY: dict[str, type[Behavior]] = {
    cls.KIND: cls for cls in (ConstantDepth, ConstantHeading, ConstantSpeed, MaxSpeed, Loiter,
                              Trail, AvoidCollision, Waypoint, StationKeep)
}


def behavior_class(kind: str, where: str = "behavior", exact: bool = False) -> type[Behavior]:
    """Class for ``BHV_Loiter`` / ``Loiter`` (any case); ``exact``: only ``BHV_Loiter``, as
    pHelmIvP reads kinds (BFactoryStatic.cpp). Unknown -> ConfigError."""
    given = str(kind).strip()
    if exact and given in REGISTRY:
        return REGISTRY[given]
    k = given.lower()
    k = k if k.startswith("bhv_") else "bhv_" + k
    for name, cls in REGISTRY.items():
        if name.lower() == k:
            if exact:
                raise ConfigError(f"unknown behavior {given!r}: pHelmIvP knows {name}", where)
            return cls
    raise ConfigError(f"unknown behavior {kind!r} (known: {', '.join(sorted(REGISTRY))})", where)


__all__ = [
    "REGISTRY",
    "AvoidCollision",
    "Behavior",
    "BehaviorContext",
    "CommonParams",
    "ConstantDepth",
    "ConstantHeading",
    "ConstantSpeed",
    "ContactInfo",
    "Loiter",
    "MaxSpeed",
    "OwnNav",
    "StationKeep",
    "Trail",
    "Waypoint",
    "behavior_class",
]
