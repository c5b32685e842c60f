"""The bridge node's ROS parameters: rates, frame names and QoS, set the ROS way.

Give them on the node's command line (``--ros-args -p odom_rate_hz:=20.0 -p
sensor_qos:=reliable``: ``Ros2Bridge(ros_args=...)``, the scenario's
``bridges.ros2.ros_args`` or ``uhrisim run --ros-args="..."``) or in a parameter file
(``--ros-args --params-file f.yaml``). They are read once, when the bridge starts; the
constructor's arguments are their defaults. docs/bridges-ros2.md lists them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from uhrisim.core.errors import ConfigError

#: Values of the ``sensor_qos`` and ``clock_qos`` parameters.
QOS_CHOICES = ("best_effort", "reliable")


@dataclass(frozen=True)
class BridgeParameters:
    """The bridge's parameters (0 for a rate: "as configured", see :func:`declare`)."""

    odom_rate_hz: float = 0.0
    sonar_rate_hz: float = 0.0
    clock_rate_hz: float = 0.0
    world_frame: str = "map"
    frame_prefix: str = ""
    sensor_qos: str = "best_effort"
    clock_qos: str = "best_effort"


#: What each parameter means (the node's parameter descriptors say the same).
DESCRIPTIONS = {
    "odom_rate_hz": "odometry, pose and /tf rate of every agent, simulated Hz (0: as "
                    "configured per agent)",
    "sonar_rate_hz": "sonar products' rate of every agent, simulated Hz (0: as configured)",
    "clock_rate_hz": "/clock rate, simulated Hz (0: every change of simulation time)",
    "world_frame": "the world frame of poses, /tf and markers (REP 105 map, ENU)",
    "frame_prefix": "prefix of every agent frame: <prefix><agent>/base_link, /odom, /sonar",
    "sensor_qos": "sonar images and points: best_effort (ROS sensor-data convention) or "
                  "reliable",
    "clock_qos": "/clock: best_effort (what rclpy's time source asks for) or reliable",
}


def declare(node: Any, defaults: BridgeParameters) -> BridgeParameters:
    """Declare the parameters on ``node`` with ``defaults`` and return their values
    (command-line overrides applied); a bad value is a ConfigError naming it."""
    from rcl_interfaces.msg import ParameterDescriptor

    values = {}
    for name, default in vars(defaults).items():
        try:
            param = node.declare_parameter(
                name, default, ParameterDescriptor(description=DESCRIPTIONS[name]))
        except Exception as exc:  # rclpy: a value of the wrong type (20 for 20.0 ...)
            raise ConfigError(f"{exc} (default {default!r})",
                              f"ROS parameter {name}") from None
        values[name] = param.value
    for name in ("odom_rate_hz", "sonar_rate_hz", "clock_rate_hz"):
        value = values[name]
        if not (isinstance(value, float) and math.isfinite(value) and value >= 0.0):
            raise ConfigError(f"must be a rate >= 0 Hz, got {value!r}",
                              f"ROS parameter {name}")
    for name in ("sensor_qos", "clock_qos"):
        if values[name] not in QOS_CHOICES:
            raise ConfigError(f"must be one of {list(QOS_CHOICES)}, got {values[name]!r}",
                              f"ROS parameter {name}")
    return BridgeParameters(**values)
