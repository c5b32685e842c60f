"""The ROV's camera and sonar on a signalling diver, for the assistant's kinematic world.

A scene (sand floor at 12 m, daylight) with the articulated diver (``world/diver_figure.
py``) and his slate; each helm tick the diver is put where the world's script has him,
posed by a :class:`~uhrisim.perception.signalling.SignalPerformer` (his gesture or the
ready pose, the slate held up in front of his chest or put away), and the ROV's
camera (VideoRay optics at 320 × 240, clear water, lamps on) renders him from the ROV's
pose; :class:`~uhrisim.perception.signal_readers.SignalReaders` reads the picture.
"""

from __future__ import annotations

import math

import numpy as np

from uhrisim.core.frames import rot_z
from uhrisim.dynamics.diver_body import DiverSkeleton
from uhrisim.perception.signal_readers import SignalReaders
from uhrisim.perception.signalling import SignalPerformer, slate_position
from uhrisim.perception.signals import RecognizedSignal
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.world import primitives as prim
from uhrisim.world.diver_figure import diver_figure, figure_transforms
from uhrisim.world.materials import NEOPRENE, SAND
from uhrisim.world.scene import Scene
from uhrisim.world.slate import MarkerSlate

HIDDEN = np.array([0.0, 0.0, 100.0])  # a slate put away: under the sea floor


class SignalEye:
    """Renders and reads the diver for a ``World`` (tests/support/assistant_world.py)."""

    def __init__(self, performer: SignalPerformer, water: str = "I", seed: int = 1) -> None:
        self.performer = performer
        self.readers = SignalReaders(sonar=None)
        self.skeleton = DiverSkeleton()
        self.scene = Scene()
        self.scene.add_static(prim.box((200.0, 200.0, 1.0), (0.0, 0.0, 12.5)), "seafloor", SAND)
        self.scene.add_dynamic("diver", diver_figure(self.skeleton), "diver", NEOPRENE)
        self.slates = {}
        for marker_id in sorted({p.marker_id for p in performer.issued
                                 if p.marker_id is not None}):
            slate = MarkerSlate(marker_id)
            self.scene.add_dynamic(f"slate{marker_id}", slate.mesh(), "slate", slate.material())
            self.slates[marker_id] = slate
        self.caster = self.scene.raycaster()
        self.camera = UnderwaterCamera(CameraConfig(width=320, height=240, water=jerlov(water),
                                                    lamps_on=True, tilt_deg=0.0),
                                       np.random.default_rng(seed))
        self.frames = 0

    def __call__(self, world, diver) -> tuple[RecognizedSignal, ...]:
        t = world.t
        heading = math.radians(diver.heading)
        body = rot_z(heading)
        self.scene.set_pose("diver", np.array(diver.position, float), body)
        q = self.skeleton.vector(self.performer.joints(t))
        self.scene.set_part_transforms("diver", figure_transforms(self.skeleton, q))
        held = self.performer.slate_id(t)
        for marker_id in self.slates:
            position = (slate_position(np.array(diver.position, float), heading)
                        if marker_id == held else HIDDEN)
            self.scene.set_pose(f"slate{marker_id}", position, body)
        frame = self.camera.capture(self.caster, world.rov.position.copy(),
                                    rot_z(math.radians(world.rov.heading)), t)
        self.frames += 1
        return tuple(self.readers.camera(frame))
