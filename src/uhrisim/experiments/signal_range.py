"""How far the ROV's camera reads the diver's slate: marker recognition against range,
water type and lamps (docs/hri.md, "Measured").

Each trial renders the VideoRay camera preset (640 × 480, 80°, two lamps, noise, forward
scatter, auto exposure) looking level at a diver who holds a slate (``world/slate.py``,
0.20 m marker) up to it at ``range_m``, in mid-water 8 m down over a sand floor at 12 m
in daylight. Every frame the diver's hand moves the slate a little — yaw and pitch drawn
uniformly within ±20° and ±15°, and ±5 cm across the view — and the sensor draws new
noise; the :class:`~uhrisim.perception.markers.MarkerReader` then reads the picture. A
frame counts as read when the slate's id is found (any other id found counts as false).

    python -m uhrisim.experiments.signal_range [--ranges 1 2 3 ...] [--waters I 3C 9C]
                                               [--seeds 1 2 3] [--frames 10]

prints the table of docs/hri.md. ``uhrisim figure signal-range`` (part 2) draws it with
the gesture and sonar channels beside it.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np

from uhrisim.core.frames import rot_z, rotation_zyx
from uhrisim.perception.markers import MarkerReader
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.world import primitives as prim
from uhrisim.world.materials import SAND
from uhrisim.world.paper_scenes import add_diver
from uhrisim.world.scene import Scene
from uhrisim.world.slate import MarkerSlate

CAMERA_DEPTH_M = 8.0
FLOOR_DEPTH_M = 12.0
SLATE_ID = 4
#: the hand's unsteadiness (assumed): slate yaw, pitch (deg) and sideways shift (m)
YAW_DEG, PITCH_DEG, SHIFT_M = 20.0, 15.0, 0.05


@dataclass(frozen=True)
class MarkerTrial:
    """Frames of one setting: how many, how many read the slate's id, how many read
    another id, and the confidences and range errors (m) of the good reads."""

    range_m: float
    water: str
    lamps: bool
    seed: int
    frames: int
    read: int
    false: int
    confidences: tuple[float, ...]
    range_errors_m: tuple[float, ...]

    @property
    def rate(self) -> float:
        return self.read / self.frames


def slate_scene(range_m: float, slate: MarkerSlate) -> Scene:
    """Sand floor, the diver facing the camera and its slate ``range_m`` north of a
    camera at (0, 0, CAMERA_DEPTH_M) that looks north."""
    scene = Scene()
    scene.add_static(prim.box((80.0, 80.0, 1.0), (0.0, 0.0, FLOOR_DEPTH_M + 0.5)), "seafloor",
                     SAND)
    add_diver(scene, "diver", (range_m + 1.2, 0.0, CAMERA_DEPTH_M + 0.35), 180.0)
    scene.add_dynamic("slate", slate.mesh(), "slate", slate.material(),
                      position_ned=(range_m, 0.0, CAMERA_DEPTH_M), rotation=rot_z(math.pi))
    return scene


def marker_trial(range_m: float, water: str, lamps: bool, seed: int, frames: int = 10,
                 width: int = 640, height: int = 480) -> MarkerTrial:
    """Render ``frames`` frames of one setting and read them (module docstring)."""
    slate = MarkerSlate(SLATE_ID)
    scene = slate_scene(range_m, slate)
    caster = scene.raycaster()
    motion, noise = np.random.default_rng(np.random.SeedSequence([seed, 2026])).spawn(2)
    camera = UnderwaterCamera(CameraConfig(width=width, height=height, water=jerlov(water),
                                           lamps_on=lamps, tilt_deg=0.0), noise)
    reader = MarkerReader()
    read = false = 0
    confidences, errors = [], []
    for k in range(frames):
        yaw, pitch = (math.radians(float(motion.uniform(-a, a))) for a in (YAW_DEG, PITCH_DEG))
        shift = float(motion.uniform(-SHIFT_M, SHIFT_M))
        position = np.array([range_m, shift, CAMERA_DEPTH_M])
        rotation = rotation_zyx(0.0, pitch, math.pi + yaw)
        scene.set_pose("slate", position, rotation)
        frame = camera.capture(caster, np.array([0.0, 0.0, CAMERA_DEPTH_M]), np.eye(3), 0.1 * k)
        found = reader.read(frame)
        hits = [d for d in found if d.marker_id == SLATE_ID]
        false += sum(d.marker_id != SLATE_ID for d in found)
        if hits:
            read += 1
            confidences.append(hits[0].confidence)
            face = position + rotation @ (0.5 * slate.thickness_m, 0.0, 0.0)
            errors.append(hits[0].range_m - float(np.linalg.norm(face - frame.position_ned)))
    return MarkerTrial(range_m, water, lamps, seed, frames, read, false, tuple(confidences),
                       tuple(errors))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ranges", type=float, nargs="+", default=[1, 2, 3, 4, 5, 6, 8, 10])
    parser.add_argument("--waters", nargs="+", default=["I", "3C", "9C"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--frames", type=int, default=10)
    args = parser.parse_args(argv)
    print("| water | lamps | " + " | ".join(f"{r:g} m" for r in args.ranges) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in args.ranges) + " |")
    for water in args.waters:
        for lamps in (True, False):
            cells = []
            for r in args.ranges:
                trials = [marker_trial(r, water, lamps, s, args.frames) for s in args.seeds]
                read = sum(t.read for t in trials)
                total = sum(t.frames for t in trials)
                false = sum(t.false for t in trials)
                cells.append(f"{100 * read / total:.0f} %" + (f" ({false} false)" if false else ""))
            print(f"| {water} | {'on' if lamps else 'off'} | " + " | ".join(cells) + " |",
                  flush=True)


if __name__ == "__main__":
    main()
