"""Fit and measure the camera's gesture classifier (``uhrisim.perception.gesture_reader``)
on pictures the simulator renders and labels.

An **episode** renders the articulated diver (``world/diver_figure.py``) upright in
mid-water, 8 m down over a sand floor at 12 m in daylight, facing the ROV's camera
(VideoRay preset optics at 320 × 240, noise, forward scatter, auto exposure) from
``range_m`` with his body turned ``heading_deg`` off it; he holds the ``signal_ready``
pose, makes the gesture (joint angles interpolated linearly between the keyframes of
``perception/data/gestures.json``, the signalling arm drawn at random) and holds its
last pose; his arms sway a little throughout (each arm joint ±6°, periods 3–6 s). The
camera sees the window that ends 0.2–1 s after the gesture does, at the classifier's
frame rate. The label is the script's truth (the gesture, ``bring_tool:<count>``), and
the same frames give a ``none`` sample: the window that ends half-way through the
gesture. Episodes of class ``none`` are the diver at rest.

    python -m uhrisim.experiments.gesture_classifier OUT.json [--episodes 6] [--seed 1]
    python -m uhrisim.experiments.gesture_classifier --evaluate [--range 3] [--water I]

The first wrote the shipped ``perception/data/gesture_classifier.json`` (Jerlov I water
at 1.5–7 m or coastal 3C at 1–2.5 m, lamps on or off); the second prints the
accuracy and confusion matrix of the shipped classifier on held-out episodes.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.frames import rot_z
from uhrisim.dynamics.diver_body import DiverSkeleton
from uhrisim.perception.gesture_reader import (
    NONE,
    GestureClassifier,
    frame_descriptor,
    window_features,
)
from uhrisim.perception.gestures import Gesture, GestureSet, pose_at
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.world import primitives as prim
from uhrisim.world.diver_figure import diver_figure, figure_transforms
from uhrisim.world.materials import NEOPRENE, SAND
from uhrisim.world.scene import Scene

CAMERA_DEPTH_M = 8.0
FLOOR_DEPTH_M = 12.0
FLOOR_SIZE_M = 2000.0  # its edge beyond sight: no horizon line for the silhouette to catch
#: the hip centre sits this far below the camera (the camera level with his chest)
HIP_BELOW_CAMERA_M = 0.35
WINDOW_S, RATE_HZ = 10.0, 4.0
SWAY_DEG = 6.0
STD_FLOOR = 0.01
ARM_KINDS = ("shoulder_flex", "shoulder_abd", "elbow", "wrist")


def gesture_classes(gestures: GestureSet) -> list[str]:
    """Every class: each gesture, ``bring_tool:<n>`` per tool number, and ``none``."""
    out = []
    for name, g in gestures.gestures.items():
        if g.count_period_s is None:
            out.append(name)
        else:
            out += [f"{name}:{n}" for n in sorted(set(gestures.tool_numbers.values()))]
    return [*out, NONE]


@dataclass(frozen=True)
class GestureEpisode:
    """One rendered performance (module docstring)."""

    klass: str
    range_m: float
    heading_deg: float
    water: str
    lamps: bool
    seed: int


class EpisodeRenderer:
    """Renders episodes (module docstring); one scene and ray caster, reused."""

    def __init__(self, gestures: GestureSet | None = None) -> None:
        self.gestures = gestures or GestureSet.load()
        self.skeleton = DiverSkeleton()
        self.scene = Scene()
        floor = prim.box((FLOOR_SIZE_M, FLOOR_SIZE_M, 1.0), (0.0, 0.0, FLOOR_DEPTH_M + 0.5))
        self.scene.add_static(floor, "seafloor", SAND)
        self.scene.add_dynamic("diver", diver_figure(self.skeleton), "diver", NEOPRENE,
                               position_ned=(3.0, 0.0, CAMERA_DEPTH_M + HIP_BELOW_CAMERA_M))
        self.caster = self.scene.raycaster()

    def frames(self, ep: GestureEpisode, extra_s: float = 0.0
               ) -> Iterator[tuple[float, NDArray[np.uint8]]]:
        """(t, picture) of the window ending after the gesture (t = 0 at its start),
        and ``extra_s`` more of him holding its last pose."""
        rng = np.random.default_rng(np.random.SeedSequence([ep.seed, 26, len(ep.klass)]))
        motion, noise = rng.spawn(2)
        side = "left" if motion.random() < 0.5 else "right"
        name, _, count = ep.klass.partition(":")
        gesture: Gesture = self.gestures.gestures["ok" if name == NONE else name]
        frames = gesture.timeline(side, int(count) if count else None)
        duration = 0.0 if name == NONE else frames[-1].t
        end = duration + float(motion.uniform(0.2, 1.0))
        sway = [(self.skeleton.index(f"{s}_{k}"), float(motion.uniform(3.0, 6.0)),
                 float(motion.uniform(0, 2 * math.pi))) for s in ("left", "right")
                for k in ARM_KINDS]
        camera = UnderwaterCamera(CameraConfig(width=320, height=240, water=jerlov(ep.water),
                                               lamps_on=ep.lamps, tilt_deg=0.0), noise)
        self.scene.set_pose("diver", (ep.range_m, 0.0, CAMERA_DEPTH_M + HIP_BELOW_CAMERA_M),
                            rot_z(math.pi + math.radians(ep.heading_deg)))
        n = round((WINDOW_S + extra_s) * RATE_HZ)
        for t in end - WINDOW_S + (np.arange(n) + 1) / RATE_HZ:
            joints = pose_at(frames, t) if name != NONE else dict(frames[0].joints)
            q = self.skeleton.vector(joints)
            for index, period, phase in sway:
                q[index] += math.radians(SWAY_DEG) * math.sin(2 * math.pi * t / period + phase)
            self.scene.set_part_transforms("diver", figure_transforms(self.skeleton,
                                                                      self.skeleton.clip(q)))
            frame = camera.capture(self.caster, np.array([0.0, 0.0, CAMERA_DEPTH_M]),
                                   np.eye(3), float(t))
            yield float(t), frame.rgb

    def descriptors(self, ep: GestureEpisode) -> tuple[NDArray[np.float64], int]:
        """(frame descriptors of the window ending after the gesture, the index of the
        frame half-way through the gesture)."""
        times, out = [], []
        for t, rgb in self.frames(ep):
            times.append(t)
            out.append(frame_descriptor(rgb))
        name, _, count = ep.klass.partition(":")
        duration = 0.0 if name == NONE else self.gestures.gestures[name].duration_s(
            int(count) if count else None)
        return np.array(out), int(np.searchsorted(times, 0.5 * duration))


def episode_samples(renderer: EpisodeRenderer, ep: GestureEpisode
                    ) -> list[tuple[str, NDArray[np.float64]]]:
    """(label, window features) samples of one episode: the whole gesture, and for a
    gesture the ``none`` window that ends half-way through it (padded at its start with
    the first frame, the diver at rest)."""
    d, half = renderer.descriptors(ep)
    samples = [(ep.klass, window_features(d, RATE_HZ))]
    if ep.klass != NONE:
        shift = len(d) - 1 - half
        padded = np.concatenate([np.repeat(d[:1], shift, axis=0), d[:half + 1]])
        samples.append((NONE, window_features(padded, RATE_HZ)))
    return samples


#: training settings: water type -> (its share of the episodes, range interval m)
TRAINING_WATERS = {"I": (0.75, (1.5, 7.0)), "3C": (0.25, (1.0, 2.5))}


def training_episodes(classes: list[str], per_class: int, seed: int) -> list[GestureEpisode]:
    """Random settings (module docstring): Jerlov I at 1.5–7 m or coastal 3C at 1–2.5 m
    (where the camera still sees him), headings ±35°, lamps on or off."""
    rng = np.random.default_rng(seed)
    waters = list(TRAINING_WATERS)
    shares = [TRAINING_WATERS[w][0] for w in waters]
    out = []
    for c in classes:
        for _ in range(per_class):
            water = str(rng.choice(waters, p=shares))
            out.append(GestureEpisode(c, float(rng.uniform(*TRAINING_WATERS[water][1])),
                                      float(rng.uniform(-35, 35)), water,
                                      bool(rng.random() < 0.5), int(rng.integers(1 << 30))))
    return out


def fit(per_class: int, seed: int) -> GestureClassifier:
    renderer = EpisodeRenderer()
    classes = gesture_classes(renderer.gestures)
    rows: dict[str, list[NDArray[np.float64]]] = {c: [] for c in classes}
    for ep in training_episodes(classes, per_class, seed):
        for label, features in episode_samples(renderer, ep):
            if not np.any(np.isnan(features)):
                rows[label].append(features)
    missing = [c for c in classes if not rows[c]]
    if missing:
        raise RuntimeError(f"no usable episode of {', '.join(missing)}: more episodes")
    means = np.array([np.mean(rows[c], axis=0) for c in classes])
    within = np.concatenate([np.asarray(rows[c]) - m for c, m in zip(classes, means, strict=True)])
    stds = np.maximum(np.sqrt(np.mean(within ** 2, axis=0)), STD_FLOOR)
    counts = ", ".join(f"{c} {len(rows[c])}" for c in classes)
    return GestureClassifier(
        tuple(classes), means, stds, WINDOW_S, RATE_HZ,
        provenance=(f"fitted by uhrisim.experiments.gesture_classifier: {per_class} rendered "
                    f"episodes per class (seed {seed}; Jerlov I at 1.5-7 m or coastal 3C at "
                    f"1-2.5 m, headings +-35 deg, lamps on or off); samples: {counts}"))


def confusion(classifier: GestureClassifier, episodes: list[GestureEpisode],
              renderer: EpisodeRenderer | None = None) -> tuple[list[str], NDArray[np.int64]]:
    """(classes, counts[true, predicted]) of the whole-gesture windows of ``episodes``
    (a window whose diver was not seen enough is predicted ``none``)."""
    renderer = renderer or EpisodeRenderer()
    classes = list(classifier.classes)
    matrix = np.zeros((len(classes), len(classes)), np.int64)
    for ep in episodes:
        label, features = episode_samples(renderer, ep)[0]
        predicted, _ = classifier.classify(features)
        matrix[classes.index(label), classes.index(predicted)] += 1
    return classes, matrix


def held_out_episodes(classes: list[str], range_m: float, water: str, lamps: bool,
                      seeds: list[int]) -> list[GestureEpisode]:
    """One episode per class and seed at one setting, headings drawn within ±35°."""
    return [GestureEpisode(c, range_m, float(np.random.default_rng([s, i]).uniform(-35, 35)),
                           water, lamps, 1_000_000 + 97 * s + i)
            for s in seeds for i, c in enumerate(classes)]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?")
    parser.add_argument("--episodes", type=int, default=6, help="training episodes per class")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--evaluate", action="store_true")
    parser.add_argument("--range", type=float, default=3.0)
    parser.add_argument("--water", default="I")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args(argv)
    if args.evaluate:
        classifier = GestureClassifier.load(args.out)
        held = held_out_episodes(list(classifier.classes), args.range, args.water, True,
                                 args.seeds)
        classes, matrix = confusion(classifier, held)
        print(f"accuracy {np.trace(matrix) / matrix.sum():.2f} at {args.range:g} m, "
              f"water {args.water}, lamps on")
        for c, row in zip(classes, matrix, strict=True):
            print(f"{c:>14} " + " ".join(f"{v:2d}" for v in row))
        return
    if args.out is None:
        parser.error("OUT.json is needed to fit")
    classifier = fit(args.episodes, args.seed)
    args.out.write_text(json.dumps(classifier.to_dict(), indent=1) + "\n")
    print(classifier.provenance)


if __name__ == "__main__":
    main()
