"""Forward-looking imaging sonar: presets, acoustics, config, image formation.

Public API::

    from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, SonarPing, PRESETS
    sonar = ImagingSonar(SonarConfig(preset="P900-45"), component_rng(seed, "rov/sonar"))
    ping = sonar.ping(scene.raycaster(), position_ned, rotation_body_to_ned, t,
                      exclude=frozenset({"videoray"}))
"""

from __future__ import annotations

from uhrisim.core.lazy import lazy_exports

#: Each exported name -> its module (imported at first use: image formation needs OpenCV
#: and the ray caster trimesh, the configuration does not).
_HOMES = {
    "SonarCloud": "cloud", "COLORMAPS": "config", "ECHOES_ONLY": "config",
    "SonarConfig": "config", "image_2013": "fan", "mount_rotation": "geometry",
    "SonarInfo": "ping", "SonarPing": "ping", "PRESETS": "presets", "SonarSpec": "presets",
    "get_preset": "presets", "ImagingSonar": "sonar",
}

__all__ = sorted(_HOMES)
__getattr__ = lazy_exports(__name__, _HOMES)
