"""ROS 2 bridge: simulation state out to ROS 2 topics, external commands in.

Needs the ``ros2`` extra (``pip install "uhrisim[ros2]"``) for :class:`Ros2Bridge`;
the specs, the pure conversions and :class:`Pacer` import without ROS. See
docs/bridges-ros2.md for topics, frames, units, rates and QoS.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from uhrisim.core.errors import MissingExtraError
from uhrisim.sim.pacing import Pacer, PacerStats

from .spec import (
    COMMAND_GROUPS,
    ENV_DEFAULTS,
    AgentBridgeSpec,
    AgentCommands,
    apply_env_defaults,
)

if TYPE_CHECKING:
    from .bridge import Ros2Bridge
    from .hook import Ros2BridgeHook

__all__ = [
    "COMMAND_GROUPS",
    "ENV_DEFAULTS",
    "AgentBridgeSpec",
    "AgentCommands",
    "Pacer",
    "PacerStats",
    "Ros2Bridge",
    "Ros2BridgeHook",
    "apply_env_defaults",
]


def __getattr__(name: str) -> Any:
    if name in ("Ros2Bridge", "Ros2BridgeHook"):
        try:
            from .bridge import Ros2Bridge
        except ImportError as exc:
            raise MissingExtraError(
                f"the ROS 2 bridge needs ROS 2 ({exc.name or 'rclpy'} is missing): "
                'pip install "uhrisim[ros2]"'
            ) from None
        if name == "Ros2BridgeHook":
            from .hook import Ros2BridgeHook

            return Ros2BridgeHook
        return Ros2Bridge
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
