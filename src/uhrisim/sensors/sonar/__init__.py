"""Forward-looking imaging sonar: presets, acoustics, config, image formation.

Public API::

    from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, SonarPing, PRESETS
    sonar = ImagingSonar(SonarConfig(preset="P900-45"), component_rng(seed, "rov/sonar"))
    ping = sonar.ping(scene.raycaster(), position_ned, rotation_body_to_ned, t,
                      exclude=frozenset({"videoray"}))
"""

from uhrisim.sensors.sonar.cloud import SonarCloud
from uhrisim.sensors.sonar.config import COLORMAPS, ECHOES_ONLY, SonarConfig
from uhrisim.sensors.sonar.fan import image_2013
from uhrisim.sensors.sonar.geometry import mount_rotation
from uhrisim.sensors.sonar.ping import SonarInfo, SonarPing
from uhrisim.sensors.sonar.presets import PRESETS, SonarSpec, get_preset
from uhrisim.sensors.sonar.sonar import ImagingSonar

__all__ = [
    "COLORMAPS",
    "ECHOES_ONLY",
    "PRESETS",
    "ImagingSonar",
    "SonarCloud",
    "SonarConfig",
    "SonarInfo",
    "SonarPing",
    "SonarSpec",
    "get_preset",
    "image_2013",
    "mount_rotation",
]
