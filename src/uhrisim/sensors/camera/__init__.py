"""Underwater optical camera: pinhole geometry, Jaffe–McGlamery image formation, water types.

Public API::

    from uhrisim.sensors.camera import UnderwaterCamera, CameraConfig, jerlov
    camera = UnderwaterCamera(CameraConfig(water=jerlov("1C")), component_rng(seed, "rov/camera0"))
    frame = camera.capture(scene.raycaster(), position_ned, rotation_body_to_ned, t,
                           exclude=frozenset({"videoray"}))

See ``docs/camera.md`` for the stages, parameters and sources.
"""

from uhrisim.sensors.camera.camera import CameraFrame, UnderwaterCamera
from uhrisim.sensors.camera.config import PRESETS, CameraConfig, CameraSpec, Lamp
from uhrisim.sensors.camera.water import JERLOV_TYPES, WaterOptics, jerlov, measured

__all__ = [
    "JERLOV_TYPES",
    "PRESETS",
    "CameraConfig",
    "CameraFrame",
    "CameraSpec",
    "Lamp",
    "UnderwaterCamera",
    "WaterOptics",
    "jerlov",
    "measured",
]
