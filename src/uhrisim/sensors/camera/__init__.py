"""Underwater optical camera: pinhole geometry, Jaffe–McGlamery image formation, water types.

Public API::

    from uhrisim.sensors.camera import UnderwaterCamera, CameraConfig, jerlov
    camera = UnderwaterCamera(CameraConfig(water=jerlov("1C")), component_rng(seed, "rov/camera0"))
    frame = camera.capture(scene.raycaster(), position_ned, rotation_body_to_ned, t,
                           exclude=frozenset({"videoray"}))

See ``docs/camera.md`` for the stages, parameters and sources.
"""

from __future__ import annotations

from uhrisim.core.lazy import lazy_exports

#: Each exported name -> its module (imported at first use: the camera needs OpenCV and
#: trimesh, its configuration does not).
_HOMES = {
    "CameraFrame": "camera", "UnderwaterCamera": "camera",
    "PRESETS": "config", "CameraConfig": "config", "CameraSpec": "config", "Lamp": "config",
    "JERLOV_TYPES": "water", "WaterOptics": "water", "jerlov": "water", "measured": "water",
}

__all__ = sorted(_HOMES)
__getattr__ = lazy_exports(__name__, _HOMES)
