"""How far the ROV reads the diver: recognition of the slate's markers, of gestures
(camera) and of the two-arm wave (sonar) against range, water type and lamps
(docs/hri.md, "Measured").

Each trial renders the VideoRay camera preset (640 × 480, 80°, two lamps, noise, forward
scatter, auto exposure) looking level at a diver who holds a slate (``world/slate.py``,
0.20 m marker) up to it at ``range_m``, in mid-water 8 m down over a sand floor at 12 m
in daylight. Every frame the diver's hand moves the slate a little — yaw and pitch drawn
uniformly within ±20° and ±15°, and ±5 cm across the view — and the sensor draws new
noise; the :class:`~uhrisim.perception.markers.MarkerReader` then reads the picture. A
frame counts as read when the slate's id is found (any other id found counts as false).

    python -m uhrisim.experiments.signal_range [--ranges 1 2 3 ...] [--waters I 3C 9C]
                                               [--seeds 1 2 3] [--frames 10]

prints the markers' table of docs/hri.md.

**Gestures** (:func:`gesture_trial`): one rendered episode of every gesture class at the
setting (``uhrisim.experiments.gesture_classifier``: the articulated diver facing the
camera within ±35°, the same water, floor and daylight, 320 × 240); the share the
shipped classifier names right. **Sonar** (:func:`sonar_trial`): a P900-90 (level, 15°
... 20 m window) pinging at 5 Hz at the diver making the wave and, separately, each
other gesture; the wave counts as read when :class:`~uhrisim.perception.sonar_wave.
SonarWaveReader` says ``come_here`` while he waves, and every other gesture it says
``come_here`` for counts as false. Sound does not care about turbidity or lamps.

``uhrisim figure signal-range`` (:func:`make_signal_range`) runs all three over the
issue's grid — ranges 1–15 m, Jerlov I, coastal 3C and 9C, lamps on and off, 3 seeds —
and draws recognition against range (``signal_range.png``, numbers in
``signal_range.json``); it takes of the order of an hour on one core.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from uhrisim.core.frames import rot_z, rotation_zyx
from uhrisim.experiments.gesture_classifier import (
    HIP_BELOW_CAMERA_M,
    EpisodeRenderer,
    GestureEpisode,
    confusion,
    gesture_classes,
)
from uhrisim.perception.gesture_reader import NONE, GestureClassifier
from uhrisim.perception.gestures import pose_at
from uhrisim.perception.markers import MarkerReader
from uhrisim.perception.sonar_wave import SonarWaveReader
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.sensors.sonar import ImagingSonar, SonarConfig
from uhrisim.viz.figures import subplots
from uhrisim.world import primitives as prim
from uhrisim.world.diver_figure import figure_transforms
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


@dataclass(frozen=True)
class ChannelTrial:
    """One channel at one setting: attempts, how many were read right, how many said a
    wrong command (or, for the sonar, a wave that was not made)."""

    channel: str
    range_m: float
    water: str
    lamps: bool
    seed: int
    attempts: int
    read: int
    false: int

    @property
    def rate(self) -> float:
        return self.read / self.attempts


def gesture_trial(range_m: float, water: str, lamps: bool, seed: int,
                  classifier: GestureClassifier | None = None,
                  renderer: EpisodeRenderer | None = None,
                  classes: Sequence[str] | None = None) -> ChannelTrial:
    """Every gesture class (or ``classes``) once at the setting, classified by the shipped
    classifier."""
    classifier = classifier or GestureClassifier.load()
    renderer = renderer or EpisodeRenderer()
    if classes is None:
        classes = [c for c in gesture_classes(renderer.gestures) if c != NONE]
    episodes = [GestureEpisode(c, range_m, float(np.random.default_rng([seed, i]).uniform(-35, 35)),
                               water, lamps, 2_000_000 + 131 * seed + i)
                for i, c in enumerate(classes)]
    names, matrix = confusion(classifier, episodes, renderer)
    read = int(np.trace(matrix))
    said_none = int(matrix[:, names.index(NONE)].sum())
    return ChannelTrial("gesture", range_m, water, lamps, seed, len(episodes), read,
                        len(episodes) - read - said_none)


SONAR_RATE_HZ = 5.0


def sonar_trial(range_m: float, seed: int, renderer: EpisodeRenderer | None = None,
                names: Sequence[str] | None = None) -> ChannelTrial:
    """The wave and every other gesture (or those ``names``) once in front of a level
    P900-90 at ``range_m`` (module docstring); the result holds for any water and lamps."""
    renderer = renderer or EpisodeRenderer()
    gestures = renderer.gestures
    read = false = 0
    for i, (name, gesture) in enumerate(gestures.gestures.items()):
        if names is not None and name not in names:
            continue
        count = 2 if gesture.count_period_s is not None else None
        frames = gesture.timeline("right", count)
        sonar = ImagingSonar(SonarConfig(preset="P900-90", range_min_m=1.0, range_max_m=20.0,
                                         tilt_deg=0.0, mount_position_frd=(0.0, 0.0, 0.0)),
                             np.random.default_rng([seed, i, 7]))
        heading = float(np.random.default_rng([seed, i]).uniform(-20, 20))
        renderer.scene.set_pose("diver", (range_m, 0.0, CAMERA_DEPTH_M + HIP_BELOW_CAMERA_M),
                                rot_z(math.pi + math.radians(heading)))
        reader = SonarWaveReader()
        said = False
        for k in range(round((frames[-1].t + 3.0) * SONAR_RATE_HZ)):
            t = k / SONAR_RATE_HZ - 1.0
            q = renderer.skeleton.vector(pose_at(frames, t))
            renderer.scene.set_part_transforms("diver", figure_transforms(renderer.skeleton, q))
            ping = sonar.ping(renderer.caster, np.array([0.0, 0.0, CAMERA_DEPTH_M]), np.eye(3), t)
            said |= bool(reader.feed(ping, range_m, 0.0))
        if name == "wave_both_arms":
            read += said
        else:
            false += said
    return ChannelTrial("sonar", range_m, "any", True, seed, 1, read, false)


FIGURE_RANGES = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0)
FIGURE_WATERS = ("I", "3C", "9C")


@dataclass(frozen=True)
class SignalRangeGrid:
    """The settings of the figure: ranges (m), waters, lamps, seeds, the marker frames per
    trial, and the gesture classes and sonar gestures tried (None: all)."""

    ranges: Sequence[float] = FIGURE_RANGES
    waters: Sequence[str] = FIGURE_WATERS
    lamps: Sequence[bool] = (True, False)
    seeds: Sequence[int] = (1, 2, 3)
    marker_frames: int = 10
    gesture_classes: Sequence[str] | None = None
    sonar_gestures: Sequence[str] | None = None


def signal_range_trials(grid: SignalRangeGrid) -> list[ChannelTrial | MarkerTrial]:
    """Every channel's trials over the grid (module docstring)."""
    renderer = EpisodeRenderer()
    classifier = GestureClassifier.load()
    trials: list[ChannelTrial | MarkerTrial] = []
    for r in grid.ranges:
        for seed in grid.seeds:
            trials.append(sonar_trial(r, seed, renderer, grid.sonar_gestures))
            for water in grid.waters:
                for lamps in grid.lamps:
                    trials.append(marker_trial(r, water, lamps, seed, grid.marker_frames))
                    trials.append(gesture_trial(r, water, lamps, seed, classifier, renderer,
                                                grid.gesture_classes))
    return trials


def recognition_rates(trials) -> dict[str, dict[str, list[tuple[float, float]]]]:
    """channel -> "<water> lamps on|off" -> [(range m, share read)] (pooled over seeds)."""
    pooled: dict[tuple[str, str, float], list[int]] = {}
    for tr in trials:
        channel = getattr(tr, "channel", "marker")
        key = "sound (any water)" if channel == "sonar" else \
            f"{tr.water} lamps {'on' if tr.lamps else 'off'}"
        attempts = tr.frames if channel == "marker" else tr.attempts
        cell = pooled.setdefault((channel, key, tr.range_m), [0, 0])
        cell[0] += tr.read
        cell[1] += attempts
    out: dict[str, dict[str, list[tuple[float, float]]]] = {}
    for (channel, key, r), (read, attempts) in sorted(pooled.items()):
        out.setdefault(channel, {}).setdefault(key, []).append((r, read / attempts))
    return out


def make_signal_range(out_dir: Path, grid: SignalRangeGrid | None = None) -> list[Path]:
    """Recognition against range for markers, gestures and the sonar wave (module
    docstring): ``signal_range.png`` and ``signal_range.json``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    grid = grid or SignalRangeGrid()
    seeds = grid.seeds
    trials = signal_range_trials(grid)
    rates = recognition_rates(trials)
    fig, axes = subplots(1, 3, figsize=(15.0, 4.5), sharey=True)
    for ax, channel, title in zip(axes, ("marker", "gesture", "sonar"),
                                  ("slate markers (camera)", "gestures (camera)",
                                   "two-arm wave (P900-90 sonar)"), strict=True):
        for key, points in rates.get(channel, {}).items():
            r, rate = zip(*points, strict=True)
            ax.plot(r, [100 * v for v in rate], "o-" if "on" in key else "s--", label=key)
        ax.set_title(title)
        ax.set_xlabel("range (m)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel(f"recognized (%), seeds {', '.join(map(str, seeds))}")
    png, data = out / "signal_range.png", out / "signal_range.json"
    fig.savefig(png, dpi=110, bbox_inches="tight")
    data.write_text(json.dumps({"rates": rates, "trials": [
        {"channel": getattr(t, "channel", "marker"), **{k: v for k, v in asdict(t).items()
                                                         if not isinstance(v, tuple)}}
        for t in trials]}, indent=1) + "\n")
    return [png, data]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ranges", type=float, nargs="+", default=[1, 2, 3, 4, 5, 6, 8, 10])
    parser.add_argument("--waters", nargs="+", default=["I", "3C", "9C"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--figure", type=Path, metavar="OUT",
                        help="all three channels over --ranges, --waters, --seeds: the figure")
    args = parser.parse_args(argv)
    if args.figure is not None:
        grid = SignalRangeGrid(args.ranges, args.waters, seeds=args.seeds,
                               marker_frames=args.frames)
        for path in make_signal_range(args.figure, grid):
            print(f"wrote {path}")
        return
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
