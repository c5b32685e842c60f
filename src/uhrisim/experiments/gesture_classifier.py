"""Fit and measure the camera's gesture classifier (``uhrisim.perception.gesture_reader``)
on pictures the simulator renders and labels.

An **episode** renders the articulated diver (``world/diver_figure.py``) upright in
mid-water, 8 m down over a sand floor at 12 m in daylight, facing the ROV's camera
(VideoRay preset optics at 160 × 120 — the reader bins bigger pictures to 160 columns —
noise, forward scatter, auto exposure) from ``range_m`` with his body turned
``heading_deg`` off it, in a suit and with a cylinder of the episode's colours; he holds
the ``signal_ready`` pose, makes the gesture (joint angles interpolated linearly between
the keyframes of ``perception/data/gestures.json``, the signalling arm drawn at random)
and holds its last pose; his arms sway a little throughout (each arm joint ±6°, periods
3–6 s). The camera sees the window that ends 0.2–1 s after the gesture does
(:data:`END_AFTER_S`), at the classifier's frame rate. The label is the script's truth
(the gesture, ``bring_tool:<count>``). A training episode is rendered twice: held (1 s
more: every window that ends within 0.2–1 s of the gesture is a sample, and the window
that ends half-way through its moves a ``none`` sample) and as a stream, the diver back
in his ready pose the moment the gesture ends, as ``SignalPerformer``'s diver is in the
loop (every window that ends up to :data:`STREAM_LABEL_S` after the gesture is a sample
of it, every one that ends while he is still moving a ``none`` sample:
:func:`stream_samples`). Episodes of class ``none`` are the diver at rest.

A **worksite view** (:class:`WorksiteView`, ``--views N`` of them per class, drawn with
their own seed after the mid-water episodes, which stay as they were) shows him as the
assisted salvage's ROV does: standing or kneeling on rippled sand or just above it
(:data:`VIEW_GAP_M`), the camera :data:`VIEW_CAMERA_ABOVE_M` above his chest level at
:data:`VIEW_RANGE_M`, tilted 10° down as the VideoRay's, the sand filling the lower part
of the picture; some of the time a tool in his other hand (:data:`VIEW_TOOLS`) and a
worksite-like object beside him (:data:`VIEW_SITES`). A **work episode**
(:class:`WorkScript`, ``--work N`` of them, class ``none``, drawn with their own seed after
the worksite views) is such a view of the diver at his work instead of at rest: swimming
in prone and rising, bent over the work, rigging (both hands pulling
at a line), holding a tool (:data:`WORK_STATES`), turned up to ±90° from the camera.

    python -m uhrisim.experiments.gesture_classifier OUT.json [--episodes 20] [--seed 1]
                                                              [--views 0] [--work 0]
                                                              [--cache DIR]
                                                              [--render-part K/N]
    python -m uhrisim.experiments.gesture_classifier --evaluate [--range 3] [--water I]
                                                     [--worksite | --work]
                                                     [--stream [--hop S] [--votes N]
                                                      [--min-confidence P]] [--cache DIR]

The first fits a classifier (the shipped ``perception/data/gesture_classifier.json``
says how it was fitted; the network's size and L2 penalty, :data:`HIDDEN` and :data:`L2`,
were chosen on held-out episodes of seeds 101-104 at 3 m, never on the test's seeds);
``--cache`` keeps the rendered silhouettes, so that a change of the descriptors or of the
classifier refits without rendering; with ``--render-part K/N`` the command only renders
every N-th episode from the K-th into the cache (N processes fill it side by side) and
fits nothing. The second prints the
accuracy and confusion matrix of the shipped classifier (or ``OUT.json``'s) on held-out
episodes (with ``--worksite``: as worksite views; with ``--work``: work episodes, whose
every window is ``none``), or with ``--stream`` what the
streaming reader (its rule as given) recognizes, misses and says falsely on them as
streams (:func:`stream_counts`).
"""

from __future__ import annotations

import argparse
import hashlib
import itertools
import json
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import optimize

from uhrisim.core.frames import rot_z
from uhrisim.dynamics.diver_body import NAMED_POSES, DiverSkeleton
from uhrisim.perception.gesture_reader import (
    HOP_S,
    MIN_CONFIDENCE,
    NONE,
    SILHOUETTE_VERSION,
    VOTES,
    GestureClassifier,
    GestureReader,
    class_command,
    silhouette,
    silhouette_descriptor,
    window_features,
)
from uhrisim.perception.gestures import Gesture, GestureSet, pose_at
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.world import primitives as prim
from uhrisim.world.diver_figure import diver_figure, figure_transforms, posed_figure
from uhrisim.world.materials import ALUMINIUM, NEOPRENE, SAND, SAND_RIPPLED, STEEL
from uhrisim.world.raycast import RayCaster
from uhrisim.world.scene import Scene
from uhrisim.world.tools import make_tool
from uhrisim.world.worksites import steel_load

CAMERA_DEPTH_M = 8.0
FLOOR_DEPTH_M = 12.0
FLOOR_SIZE_M = 2000.0  # its edge beyond sight: no horizon line for the silhouette to catch
#: the hip centre sits this far below the camera (the camera level with his chest)
HIP_BELOW_CAMERA_M = 0.35
#: the rendered pictures (px): the reader bins bigger pictures down to this width
IMAGE_WIDTH, IMAGE_HEIGHT = 160, 120
WINDOW_S, RATE_HZ = 14.0, 2.0
#: the window the camera sees ends this long after the gesture (s)
END_AFTER_S = (0.2, 1.0)
#: a held-out stream (:func:`stream_counts`) starts this long (s) before the window that
#: ends after the gesture, and goes on this long after it
STREAM_LEAD_S, STREAM_AFTER_S = 6.0, 3.0
#: a training stream's windows that end up to this long (s) after the gesture are its class
STREAM_LABEL_S = 2.0
SWAY_DEG = 6.0
ARM_KINDS = ("shoulder_flex", "shoulder_abd", "shoulder_rot", "elbow", "wrist")
#: suit and cylinder colours (linear albedo) drawn in training: black, grey, blue and
#: red neoprene; aluminium, yellow and black cylinders
SUITS = (NEOPRENE.albedo_rgb, (0.25, 0.25, 0.27), (0.04, 0.08, 0.30), (0.45, 0.06, 0.05))
TANKS = (ALUMINIUM.albedo_rgb, (0.70, 0.55, 0.05), (0.04, 0.04, 0.04))
#: the network: hidden units, the L2 penalty on its weights (chosen on validation
#: episodes: module docstring) and the optimiser's iterations
HIDDEN, L2, MAX_ITERATIONS = 48, 0.001, 300
#: worksite views (:class:`WorksiteView`): his soles (or knees) above the rippled sand
#: (m), the camera above his chest level (m), its range (m) and tilt (° down), the tools
#: he may hold and the objects that may stand beside him (their size, m: the assisted
#: salvage's valve body and tool stand), each drawn half of the time
VIEW_GAP_M, VIEW_CAMERA_ABOVE_M = (0.0, 0.3), (0.0, 0.6)
VIEW_RANGE_M, VIEW_TILT_DEG = (2.0, 4.0), 10.0
VIEW_TOOLS = ("wrench", "light", "hammer")
VIEW_SITES = {"valve": (0.6, 0.5, 0.8), "stand": (0.5, 0.7, 0.8)}
#: a work episode's states (:class:`WorkScript`): joint angles (°; ``{s}`` his working
#: hand, which holds the tool if he has one, ``{o}`` the other; :data:`WORK_PRONE` set
#: every joint, the others keep his legs standing or kneeling): prone, standing, holding
#: the tool, bent over the work, working prone (both hands down at the work), rigging
#: (both hands pulling at a line); not reaching down to the work with one straight arm
#: (so made, it taught the network to ignore "light here", then pointed forward and down)
WORK_STATES: dict[str, dict[str, float]] = {
    "swim": NAMED_POSES["swim"],
    "stand": NAMED_POSES["stand"],
    "hold": NAMED_POSES["hold"],
    "bent over": {**NAMED_POSES["work"], "waist": 50.0, "neck_flex": 20.0},
    "prone work": {**{k: v for k, v in NAMED_POSES["swim"].items() if "{" not in k},
                   "{s}_shoulder_flex": 100.0, "{s}_elbow": 50.0, "{s}_fingers": 72.0,
                   "{o}_shoulder_flex": 100.0, "{o}_elbow": 40.0, "{o}_fingers": 72.0},
    "rig": {"{s}_shoulder_flex": 50.0, "{s}_elbow": 60.0, "{s}_fingers": 72.0,
            "{o}_shoulder_flex": 50.0, "{o}_elbow": 60.0, "{o}_fingers": 72.0,
            "waist": 30.0, "neck_flex": 20.0},
}
#: the joint that strokes (a wrench turned, a line pulled) in a work state, ± degrees
WORK_STROKES = {"bent over": ("{s}_elbow", 25.0), "prone work": ("{s}_elbow", 25.0),
                "rig": ("{s}_elbow", 30.0)}
#: the work states that set every joint (prone: his legs stretched out, as in ``swim``)
WORK_PRONE = frozenset({"swim", "prone work"})
#: a work episode: his moves from one state to the next take this long (s); they start
#: within this span of the frames' time (s; t = 0 about the window's end)
WORK_MOVE_S, WORK_CHANGES_S = 1.2, (-18.0, 2.0)
#: where the worksite scene keeps the tools and objects not in the episode (NED, m)
PARKED_NED = (-1000.0, 0.0, FLOOR_DEPTH_M)


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
class WorksiteView:
    """How a worksite view (module docstring) is set: ``kneeling`` or standing, his soles
    (knees) ``gap_m`` above the sand, the camera ``camera_above_m`` above his chest level,
    the ``tool`` kind in his other hand (None: empty-handed), the object beside him
    (:data:`VIEW_SITES`; None: none) ``site_right_m`` to his right as the camera sees it
    (negative: left) and ``site_behind_m`` farther from the camera than he is."""

    kneeling: bool
    gap_m: float
    camera_above_m: float
    tool: str | None
    site: str | None
    site_right_m: float
    site_behind_m: float


@dataclass(frozen=True)
class WorkScript:
    """A work episode's moves (module docstring): he holds ``states[0]``
    (:data:`WORK_STATES`), moves to ``states[i + 1]`` from ``starts_s[i]`` (the frames'
    time, s) over :data:`WORK_MOVE_S` and holds it; a state's stroke
    (:data:`WORK_STROKES`) has the period ``stroke_period_s``; when he starts prone he
    swims in head first at ``swim_speed_m_s`` (m/s) until his first move."""

    states: tuple[str, ...]
    starts_s: tuple[float, ...]
    stroke_period_s: float
    swim_speed_m_s: float


@dataclass(frozen=True)
class GestureEpisode:
    """One rendered performance (module docstring); ``suit`` and ``tank`` are the
    albedos of the diver's suit and cylinder; ``view``: a worksite view, None: mid-water;
    ``work``: a work episode's moves (class ``none``), None: a gesture or at rest."""

    klass: str
    range_m: float
    heading_deg: float
    water: str
    lamps: bool
    seed: int
    suit: tuple[float, float, float] = NEOPRENE.albedo_rgb
    tank: tuple[float, float, float] = ALUMINIUM.albedo_rgb
    view: WorksiteView | None = None
    work: WorkScript | None = None


def draw_work(rng: np.random.Generator) -> WorkScript:
    """A work episode's moves drawn at random: 3-5 states (half of the time he swims
    in first, at 0.3-0.6 m/s), each unlike the one before, the moves within
    :data:`WORK_CHANGES_S`."""
    at_site = [name for name in WORK_STATES if name != "swim"]
    states = ["swim" if rng.random() < 0.5 else str(rng.choice(at_site))]
    for _ in range(int(rng.integers(2, 5))):
        states.append(str(rng.choice([name for name in at_site if name != states[-1]])))
    starts = np.sort(rng.uniform(*WORK_CHANGES_S, len(states) - 1))
    return WorkScript(tuple(states), tuple(float(t) for t in starts),
                      float(rng.uniform(1.5, 3.0)), float(rng.uniform(0.3, 0.6)))


def draw_view(rng: np.random.Generator) -> WorksiteView:
    """A worksite view drawn at random (:data:`VIEW_GAP_M` … :data:`VIEW_SITES`)."""
    kneeling = bool(rng.random() < 0.3)
    gap = float(rng.uniform(*VIEW_GAP_M))
    above = float(rng.uniform(*VIEW_CAMERA_ABOVE_M))
    tool = str(rng.choice(VIEW_TOOLS)) if rng.random() < 0.5 else None
    site = str(rng.choice(list(VIEW_SITES))) if rng.random() < 0.5 else None
    right = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.7, 1.5))
    return WorksiteView(kneeling, gap, above, tool, site, right, float(rng.uniform(0.0, 1.0)))


class EpisodeRenderer:
    """Renders episodes (module docstring): one scene and ray caster per suit, one camera
    per water and lamps (its noise pool fixed by the setting, its draws by the episode)."""

    def __init__(self, gestures: GestureSet | None = None) -> None:
        self.gestures = gestures or GestureSet.load()
        self.skeleton = DiverSkeleton()
        self._scenes: dict[tuple, tuple[Scene, RayCaster]] = {}
        self._cameras: dict[tuple[str, bool, float], UnderwaterCamera] = {}
        self.tool_grasps = {kind: make_tool(kind, kind).grasp_offset() for kind in VIEW_TOOLS}
        self.scene, self.caster = self._scene(NEOPRENE.albedo_rgb, ALUMINIUM.albedo_rgb)

    def _scene(self, suit: tuple[float, float, float], tank: tuple[float, float, float],
               worksite: bool = False) -> tuple[Scene, RayCaster]:
        """The mid-water scene, or with ``worksite`` the worksite views' (rippled sand,
        the :data:`VIEW_TOOLS` and :data:`VIEW_SITES` as bodies parked out of sight)."""
        key = (tuple(suit), tuple(tank), worksite)
        if key not in self._scenes:
            scene = Scene()
            floor = prim.box((FLOOR_SIZE_M, FLOOR_SIZE_M, 1.0),
                             (0.0, 0.0, FLOOR_DEPTH_M + 0.5))
            scene.add_static(floor, "seafloor", SAND_RIPPLED if worksite else SAND)
            figure = diver_figure(self.skeleton, replace(ALUMINIUM, albedo_rgb=tank))
            scene.add_dynamic("diver", figure, "diver", replace(NEOPRENE, albedo_rgb=suit),
                              position_ned=(3.0, 0.0, CAMERA_DEPTH_M + HIP_BELOW_CAMERA_M))
            if worksite:
                for kind in VIEW_TOOLS:
                    scene.add_dynamic(kind, make_tool(kind, kind).mesh(), kind, ALUMINIUM,
                                      PARKED_NED)
                for name, size in VIEW_SITES.items():
                    parts = steel_load(name, 40.0, size).parts() if name == "valve" \
                        else prim.box(size)
                    scene.add_dynamic(name, parts, name, STEEL, PARKED_NED)
            self._scenes[key] = scene, scene.raycaster()
        return self._scenes[key]

    def _camera(self, water: str, lamps: bool, noise: np.random.Generator,
                tilt_deg: float = 0.0) -> UnderwaterCamera:
        key = (water, lamps, tilt_deg)
        if key not in self._cameras:
            pool = np.random.default_rng([26, *water.encode(), int(lamps)])
            self._cameras[key] = UnderwaterCamera(
                CameraConfig(width=IMAGE_WIDTH, height=IMAGE_HEIGHT, water=jerlov(water),
                             lamps_on=lamps, tilt_deg=tilt_deg), pool)
        camera = self._cameras[key]
        camera.rng = noise
        return camera

    def _place_worksite(self, scene: Scene, ep: GestureEpisode
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Sets ``ep``'s worksite view (:class:`WorksiteView`) in the worksite ``scene``:
        its object placed on the sand, the rest parked; returns (his legs' angles, his
        hip centre and the camera, NED m)."""
        view = ep.view
        assert view is not None
        legs = self.skeleton.zeros()
        if view.kneeling:
            for side in ("left", "right"):
                legs[self.skeleton.index(f"{side}_knee")] = math.radians(90.0)
        lowest = float(posed_figure(self.skeleton, legs).bounds[1][2])  # body z is down
        hip = np.array([ep.range_m, 0.0, FLOOR_DEPTH_M - lowest - view.gap_m])
        eye = np.array([0.0, 0.0, hip[2] - HIP_BELOW_CAMERA_M - view.camera_above_m])
        for name in (*VIEW_TOOLS, *VIEW_SITES):
            scene.set_pose(name, PARKED_NED, np.eye(3))
        if view.site is not None:
            height = VIEW_SITES[view.site][2]
            scene.set_pose(view.site, (ep.range_m + view.site_behind_m, view.site_right_m,
                                       FLOOR_DEPTH_M - 0.5 * height), np.eye(3))
        return legs, hip, eye

    def _hold(self, scene: Scene, kind: str, q: NDArray[np.float64], side: str,
              body: NDArray[np.float64]) -> None:
        """Poses tool ``kind`` in his ``side`` hand (its grasp point at the grip, its
        length across the fingers) for joint angles ``q`` and body pose ``body`` (4x4)."""
        hand = body @ self.skeleton.hand_frame(q, side)  # type: ignore[arg-type]
        rotation = hand[:3, :3] @ rot_z(math.pi / 2)
        grasp = self.tool_grasps[kind]
        scene.set_pose(kind, hand[:3, 3] - rotation @ grasp, rotation)

    def _work_pose(self, work: WorkScript, t: float, side: str, legs: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        """His joint angles (rad) at time ``t`` (s) of ``work``, ``side`` his working
        hand, ``legs`` the angles his legs keep (``swim`` sets its own)."""
        other = "right" if side == "left" else "left"

        def state(name: str) -> NDArray[np.float64]:
            angles = {k.format(s=side, o=other): math.radians(v)
                      for k, v in WORK_STATES[name].items()}
            if name in WORK_STROKES:
                joint, amplitude = WORK_STROKES[name]
                angles[joint.format(s=side, o=other)] += math.radians(amplitude) * math.sin(
                    2 * math.pi * t / work.stroke_period_s)
            return self.skeleton.vector(angles, None if name in WORK_PRONE else legs)

        q = state(work.states[0])
        for name, start in zip(work.states[1:], work.starts_s, strict=True):
            share = min(max((t - start) / WORK_MOVE_S, 0.0), 1.0)
            if share > 0.0:
                q = q + share * (state(name) - q)
        return q

    def frames(self, ep: GestureEpisode, extra_s: float = 0.0, stream: bool = False
               ) -> Iterator[tuple[float, NDArray[np.uint8]]]:
        """(t, picture) of the window ending after the gesture (t = 0 at its start) and
        ``extra_s`` more of him holding its last pose; a ``stream`` (what the streaming
        reader sees of ``SignalPerformer``'s diver: :func:`stream_counts`) starts
        :data:`STREAM_LEAD_S` earlier and has him back in the ready pose once the
        gesture ends."""
        rng = np.random.default_rng(np.random.SeedSequence([ep.seed, 26, len(ep.klass)]))
        motion, noise = rng.spawn(2)
        side = "left" if motion.random() < 0.5 else "right"
        name, _, count = ep.klass.partition(":")
        gesture: Gesture = self.gestures.gestures["ok" if name == NONE else name]
        frames = gesture.timeline(side, int(count) if count else None)
        duration = 0.0 if name == NONE else frames[-1].t
        end = duration + float(motion.uniform(*END_AFTER_S))
        sway = [(self.skeleton.index(f"{s}_{k}"), float(motion.uniform(3.0, 6.0)),
                 float(motion.uniform(0, 2 * math.pi))) for s in ("left", "right")
                for k in ARM_KINDS]
        view = ep.view
        scene, caster = self._scene(ep.suit, ep.tank, view is not None)
        camera = self._camera(ep.water, ep.lamps, noise,
                              0.0 if view is None else VIEW_TILT_DEG)
        if view is None:
            legs = self.skeleton.zeros()
            hip = np.array([ep.range_m, 0.0, CAMERA_DEPTH_M + HIP_BELOW_CAMERA_M])
            eye = np.array([0.0, 0.0, CAMERA_DEPTH_M])
        else:
            legs, hip, eye = self._place_worksite(scene, ep)
        body = np.eye(4)
        body[:3, :3] = rot_z(math.pi + math.radians(ep.heading_deg))
        body[:3, 3] = hip
        scene.set_pose("diver", hip, body[:3, :3])
        other = "right" if side == "left" else "left"
        lead_s = STREAM_LEAD_S if stream else 0.0
        n = round((WINDOW_S + extra_s + lead_s) * RATE_HZ)
        for t in end - WINDOW_S - lead_s + (np.arange(n) + 1) / RATE_HZ:
            if ep.work is not None:
                q = self._work_pose(ep.work, float(t), side, legs)
            else:
                making = name != NONE and not (stream and t > duration)
                joints = pose_at(frames, t) if making else dict(frames[0].joints)
                q = self.skeleton.vector(joints, legs)
            for index, period, phase in sway:
                q[index] += math.radians(SWAY_DEG) * math.sin(2 * math.pi * t / period + phase)
            q = self.skeleton.clip(q)
            scene.set_part_transforms("diver", figure_transforms(self.skeleton, q))
            if ep.work is not None and ep.work.states[0] == "swim":
                behind = ep.work.swim_speed_m_s * max(ep.work.starts_s[0] - float(t), 0.0)
                body[:3, 3] = hip - behind * body[:3, 0]  # swimming in head first (body x)
                scene.set_pose("diver", body[:3, 3], body[:3, :3])
            if view is not None and view.tool is not None:
                self._hold(scene, view.tool, q, other if ep.work is None else side, body)
            frame = camera.capture(caster, eye, np.eye(3), float(t))
            yield float(t), frame.rgb

    def silhouettes(self, ep: GestureEpisode, extra_s: float = 0.0, stream: bool = False
                    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """(silhouettes (frames, rows, columns), their times: t = 0 at the gesture's
        start) of :meth:`frames`."""
        times, masks = [], []
        for t, rgb in self.frames(ep, extra_s, stream):
            times.append(t)
            masks.append(silhouette(rgb))
        return np.array(masks), np.array(times)

    def descriptors(self, ep: GestureEpisode, extra_s: float = 0.0, stream: bool = False
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(frame descriptors, their times) of :meth:`silhouettes`."""
        masks, times = self.silhouettes(ep, extra_s, stream)
        return np.array([silhouette_descriptor(m) for m in masks]), times


class SilhouetteCache:
    """Rendered episodes' silhouettes on disk (``DIR/<episode hash>.npz``, bits packed:
    ~2.4 kB a frame), so that a change of the descriptors or of the classifier refits
    without rendering again; the hash covers the episode, its gesture (a changed motion
    renders again), the picture size, the frame rate and the window; a file holds the
    :data:`SILHOUETTE_VERSION` it was made with (none: 1), and one of another version
    renders again."""

    def __init__(self, renderer: EpisodeRenderer, folder: Path | None) -> None:
        self.renderer, self.folder = renderer, folder

    def path(self, ep: GestureEpisode, extra_s: float, stream: bool = False) -> Path | None:
        if self.folder is None:
            return None
        name = ep.klass.partition(":")[0]
        motion = self.renderer.gestures.gestures["ok" if name == NONE else name]
        # an episode keeps the key it had before worksite views and work episodes existed
        episode = repr(ep)
        for field_name, value in (("work", ep.work), ("view", ep.view)):
            if value is None:
                episode = episode.removesuffix(f", {field_name}=None)") + ")"
        key = f"({episode}, " + repr((extra_s, IMAGE_WIDTH, IMAGE_HEIGHT, RATE_HZ, WINDOW_S,
                                       motion))[1:]
        if stream:
            key += f" stream {STREAM_LEAD_S}"
        return self.folder / f"{hashlib.sha1(key.encode()).hexdigest()[:20]}.npz"

    def descriptors(self, ep: GestureEpisode, extra_s: float = 0.0, stream: bool = False
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`EpisodeRenderer.descriptors`, the silhouettes read from the cache or
        rendered and stored."""
        path = self.path(ep, extra_s, stream)
        stored = _cached_silhouettes(path)
        if stored is not None:
            masks, times = stored
        else:
            masks, times = self.renderer.silhouettes(ep, extra_s, stream)
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                np.savez_compressed(path, masks=np.packbits(masks, axis=-1), times=times,
                                    width=masks.shape[-1], silhouette=SILHOUETTE_VERSION)
        return np.array([silhouette_descriptor(m) for m in masks]), times


def _cached_silhouettes(path: Path | None
                        ) -> tuple[NDArray[np.bool_], NDArray[np.float64]] | None:
    """(silhouettes, times) stored at ``path`` by :class:`SilhouetteCache`; None when
    there is no such file or its silhouettes are of another :data:`SILHOUETTE_VERSION`."""
    if path is None or not path.exists():
        return None
    with np.load(path) as stored:
        version = int(stored["silhouette"]) if "silhouette" in stored.files else 1
        if version != SILHOUETTE_VERSION:
            return None
        width = int(stored["width"])
        return (np.unpackbits(stored["masks"], axis=-1)[..., :width].astype(bool),
                stored["times"])


def _none_end_s(gestures: GestureSet, klass: str) -> float:
    """When the ``none`` window of a gesture's episode ends: half-way through its moves
    before any count (a count's first strokes would be a smaller count's whole)."""
    name = klass.partition(":")[0]
    return 0.5 * gestures.gestures[name].keyframes[-1][0]


def episode_samples(renderer: EpisodeRenderer, ep: GestureEpisode, extra_s: float = 0.0
                    ) -> list[tuple[str, NDArray[np.float64]]]:
    """:func:`window_samples` of one rendered episode."""
    return window_samples(*renderer.descriptors(ep, extra_s), ep.klass, renderer.gestures)


def window_samples(d: NDArray[np.float64], times: NDArray[np.float64], klass: str,
                   gestures: GestureSet) -> list[tuple[str, NDArray[np.float64]]]:
    """(label, window features) samples of an episode's frame descriptors ``d`` at
    ``times``: the whole gesture (the window ending after it, and those of the frames
    after it that still end within :data:`END_AFTER_S` of it), and for a gesture the
    ``none`` window that ends half-way through its moves (padded at its start with the
    first frame, the diver at rest)."""
    n = round(WINDOW_S * RATE_HZ)
    name, _, count = klass.partition(":")
    duration = 0.0 if name == NONE else gestures.gestures[name].duration_s(
        int(count) if count else None)
    samples = [(klass, window_features(d[k + 1 - n:k + 1], RATE_HZ))
               for k in range(n - 1, len(d))
               if k == n - 1 or times[k] <= duration + END_AFTER_S[1]]
    if klass != NONE:
        half = int(np.searchsorted(times, _none_end_s(gestures, klass)))
        shift = n - 1 - half
        padded = np.concatenate([np.repeat(d[:1], shift, axis=0), d[:half + 1]])
        samples.append((NONE, window_features(padded, RATE_HZ)))
    return samples


def _last_move_end_s(gesture: Gesture, count: int | None) -> float:
    """When the gesture's last move ends (s from its start): the last keyframe that
    changes a joint; after it he holds the pose."""
    frames = gesture.timeline("right", count)
    moving = [b.t for a, b in itertools.pairwise(frames)
              if any(abs(b.joints[j] - a.joints.get(j, 0.0)) > 1e-9 for j in b.joints)]
    return moving[-1]


def stream_samples(d: NDArray[np.float64], times: NDArray[np.float64], klass: str,
                   gestures: GestureSet) -> list[tuple[str, NDArray[np.float64]]]:
    """(label, window features) samples of a rendered stream's frame descriptors ``d``
    at ``times`` (:meth:`EpisodeRenderer.frames` with ``stream``): every window that ends
    within :data:`STREAM_LABEL_S` after the gesture (the diver back in his ready pose) is
    the gesture, every one that ends before its last move has ended ``none`` (a gesture
    under way: a count not finished), those in between (the last pose held) none of
    them; a diver at rest is ``none`` throughout."""
    n = round(WINDOW_S * RATE_HZ)
    name, _, count = klass.partition(":")
    if name == NONE:
        duration = last_move = math.inf
    else:
        gesture = gestures.gestures[name]
        number = int(count) if count else None
        duration, last_move = gesture.duration_s(number), _last_move_end_s(gesture, number)
    samples = []
    for k in range(n - 1, len(d)):
        if duration < times[k] <= duration + STREAM_LABEL_S:
            label = klass
        elif times[k] < last_move:
            label = NONE
        else:
            continue
        samples.append((label, window_features(d[k + 1 - n:k + 1], RATE_HZ)))
    return samples


#: training settings: water type -> (its share of the episodes, range interval m)
TRAINING_WATERS = {"I": (1.0, (2.0, 4.5))}


def training_episodes(classes: list[str], per_class: int, seed: int, views: int = 0,
                      work: int = 0) -> list[GestureEpisode]:
    """Random settings (module docstring): :data:`TRAINING_WATERS`, headings ±35°, lamps
    on or off, suit and cylinder colours from :data:`SUITS` and :data:`TANKS`; drawn
    round by round over the classes, so that fewer episodes per class are the first
    rounds of more; then ``views`` worksite views per class (:func:`draw_view`, clear
    water at :data:`VIEW_RANGE_M`), drawn the same way from their own generator, so that
    the mid-water episodes do not depend on them; then ``work`` work episodes
    (:func:`work_episode`), from a generator of their own."""
    rng = np.random.default_rng(seed)
    waters = list(TRAINING_WATERS)
    shares = [TRAINING_WATERS[w][0] for w in waters]
    out = []
    for _ in range(per_class):  # round by round: fewer episodes draw the first rounds
        for c in classes:
            water = str(rng.choice(waters, p=shares))
            out.append(GestureEpisode(c, float(rng.uniform(*TRAINING_WATERS[water][1])),
                                      float(rng.uniform(-35, 35)), water,
                                      bool(rng.random() < 0.5), int(rng.integers(1 << 30)),
                                      SUITS[rng.integers(len(SUITS))],
                                      TANKS[rng.integers(len(TANKS))]))
    rng = np.random.default_rng([seed, 26])
    for _ in range(views):
        for c in classes:
            out.append(GestureEpisode(c, float(rng.uniform(*VIEW_RANGE_M)),
                                      float(rng.uniform(-35, 35)), "I",
                                      bool(rng.random() < 0.5), int(rng.integers(1 << 30)),
                                      SUITS[rng.integers(len(SUITS))],
                                      TANKS[rng.integers(len(TANKS))], draw_view(rng)))
    rng = np.random.default_rng([seed, 27])
    out += [work_episode(rng) for _ in range(work)]
    return out


def work_episode(rng: np.random.Generator, lamps: bool | None = None,
                 seed: int | None = None) -> GestureEpisode:
    """A work episode (module docstring) drawn at random: clear water at
    :data:`VIEW_RANGE_M`, turned up to ±90° from the camera, lamps on or off, suit and
    cylinder colours from :data:`SUITS` and :data:`TANKS` (``lamps`` and ``seed`` given:
    those, the black suit and aluminium cylinder)."""
    range_m, heading = float(rng.uniform(*VIEW_RANGE_M)), float(rng.uniform(-90, 90))
    if seed is None:
        lamps, seed = bool(rng.random() < 0.5), int(rng.integers(1 << 30))
        suit, tank = SUITS[rng.integers(len(SUITS))], TANKS[rng.integers(len(TANKS))]
    else:
        suit, tank = NEOPRENE.albedo_rgb, ALUMINIUM.albedo_rgb
    return GestureEpisode(NONE, range_m, heading, "I", bool(lamps), seed, suit, tank,
                          draw_view(rng), draw_work(rng))


def fit_network(features: NDArray[np.float64], labels: NDArray[np.int64], n_classes: int,
                hidden: int = HIDDEN, l2: float = L2, seed: int = 1
                ) -> tuple[NDArray[np.float64], ...]:
    """(hidden weights (hidden, features), hidden bias, weights (classes, hidden), bias) of
    a network of one ``tanh`` hidden layer and a softmax fitted to standardised
    ``features`` and ``labels`` (cross-entropy, every class weighted equally, an L2
    penalty on the weights; L-BFGS from weights drawn with ``seed``: deterministic)."""
    m = features.shape[1]
    onehot = np.eye(n_classes)[labels]
    weight = 1.0 / np.bincount(labels, minlength=n_classes)[labels]
    weight /= weight.sum()
    shapes = [(hidden, m), (hidden,), (n_classes, hidden), (n_classes,)]
    cuts = np.cumsum([int(np.prod(shape)) for shape in shapes])[:-1]

    def unpack(theta: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        return [part.reshape(shape) for part, shape in zip(np.split(theta, cuts), shapes,
                                                           strict=True)]

    def loss(theta: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        w1, b1, w2, b2 = unpack(theta)
        h = np.tanh(features @ w1.T + b1)
        logits = h @ w2.T + b2
        logits -= logits.max(axis=1, keepdims=True)
        p = np.exp(logits)
        p /= p.sum(axis=1, keepdims=True)
        nll = -np.sum(weight * np.log(np.maximum(np.sum(p * onehot, axis=1), 1e-300)))
        residual = weight[:, None] * (p - onehot)
        back = (residual @ w2) * (1.0 - h * h)
        grads = [back.T @ features + l2 * w1, back.sum(axis=0),
                 residual.T @ h + l2 * w2, residual.sum(axis=0)]
        penalty = 0.5 * l2 * (np.sum(w1 * w1) + np.sum(w2 * w2))
        return float(nll + penalty), np.concatenate([g.ravel() for g in grads])

    rng = np.random.default_rng(seed)
    start = np.concatenate([rng.normal(0.0, m ** -0.5, hidden * m), np.zeros(hidden),
                            rng.normal(0.0, hidden ** -0.5, n_classes * hidden),
                            np.zeros(n_classes)])
    result = optimize.minimize(loss, start, jac=True, method="L-BFGS-B",
                               options={"maxiter": MAX_ITERATIONS})
    return tuple(unpack(result.x))


def render_part(per_class: int, seed: int, views: int, work: int, cache: Path, part: int,
                parts: int) -> None:
    """Renders every ``parts``-th training episode from the ``part``-th into ``cache``
    (both renderings), so that ``parts`` processes fill it side by side."""
    renderer = EpisodeRenderer()
    store = SilhouetteCache(renderer, cache)
    episodes = training_episodes(gesture_classes(renderer.gestures), per_class, seed, views,
                                 work)
    for ep in episodes[part::parts]:
        store.descriptors(ep, END_AFTER_S[1])
        store.descriptors(ep, STREAM_AFTER_S, stream=True)


def training_samples(per_class: int, seed: int, cache: Path | None = None, views: int = 0,
                     work: int = 0) -> tuple[list[str], NDArray[np.float64], NDArray[np.int64]]:
    """(classes, window features, class indices) of the rendered training episodes, each
    rendered twice: the diver holding the gesture's last pose (:func:`window_samples`)
    and as a stream (:func:`stream_samples`); their silhouettes kept in ``cache`` when
    given."""
    renderer = EpisodeRenderer()
    store = SilhouetteCache(renderer, cache)
    classes = gesture_classes(renderer.gestures)
    rows, labels = [], []
    for ep in training_episodes(classes, per_class, seed, views, work):
        held = window_samples(*store.descriptors(ep, END_AFTER_S[1]), ep.klass,
                              renderer.gestures)
        streamed = stream_samples(*store.descriptors(ep, STREAM_AFTER_S, stream=True),
                                  ep.klass, renderer.gestures)
        for label, features in held + streamed:
            if not np.any(np.isnan(features)):
                rows.append(features)
                labels.append(classes.index(label))
    missing = [c for i, c in enumerate(classes) if i not in labels]
    if missing:
        raise RuntimeError(f"no usable episode of {', '.join(missing)}: more episodes")
    return classes, np.array(rows), np.array(labels)


def classifier_of(classes: list[str], x: NDArray[np.float64], y: NDArray[np.int64],
                  hidden: int = HIDDEN, l2: float = L2, provenance: str = ""
                  ) -> GestureClassifier:
    """The network fitted to window features ``x`` and class indices ``y``, the features
    standardised by their training mean and standard deviation."""
    center = x.mean(axis=0)
    spread = np.maximum(x.std(axis=0), 1e-6)
    w1, b1, w2, b2 = fit_network((x - center) / spread, y, len(classes), hidden, l2)
    return GestureClassifier(tuple(classes), center, spread, w1, b1, w2, b2, WINDOW_S,
                             RATE_HZ, provenance)


def fit(per_class: int, seed: int, cache: Path | None = None, views: int = 0, work: int = 0
        ) -> GestureClassifier:
    """The classifier fitted on ``per_class`` rendered mid-water episodes and ``views``
    worksite views per class, and ``work`` work episodes."""
    classes, x, y = training_samples(per_class, seed, cache, views, work)
    worksite = (f"; {views} worksite views per class (rippled sand, camera "
                f"{VIEW_CAMERA_ABOVE_M[0]:g}-{VIEW_CAMERA_ABOVE_M[1]:g} m above his chest "
                f"at {VIEW_RANGE_M[0]:g}-{VIEW_RANGE_M[1]:g} m, tilted {VIEW_TILT_DEG:g} deg, "
                f"standing or kneeling, a tool or an object beside him half of the time)"
                if views else "")
    if work:
        worksite += (f"; {work} work episodes, none (as those views, turned up to +-90 deg: "
                     f"{', '.join(WORK_STATES)})")
    counts = ", ".join(f"{c} {np.count_nonzero(y == i)}" for i, c in enumerate(classes))
    return classifier_of(
        classes, x, y,
        provenance=(f"fitted by uhrisim.experiments.gesture_classifier: {per_class} rendered "
                    f"episodes per class (seed {seed}; {IMAGE_WIDTH} x {IMAGE_HEIGHT} px at "
                    f"{RATE_HZ:g} Hz; Jerlov I at 2-4.5 m, "
                    f"headings +-35 deg, lamps on or off, {len(SUITS)} suit and "
                    f"{len(TANKS)} cylinder colours{worksite}; {HIDDEN} hidden units, "
                    f"L2 {L2:g}); "
                    f"samples: {counts}"))


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


def stream_counts(reader_of: Callable[[], GestureReader], episodes: list[GestureEpisode],
                  store: SilhouetteCache) -> dict[str, int]:
    """Each episode as a stream of frames (its gesture whole, from :data:`STREAM_LEAD_S`
    before the window that ends after it to :data:`STREAM_AFTER_S` after) through a
    fresh reader: gestures ``recognized`` (their command said) and ``missed``, and
    ``false`` recognitions (any other command said: a shorter count while the diver is
    still counting, a wrong gesture, anything said of a diver at rest)."""
    counts = {"recognized": 0, "missed": 0, "false": 0}
    for ep in episodes:
        d, times = store.descriptors(ep, STREAM_AFTER_S, stream=True)
        reader = reader_of()
        said = [s.command for t, x in zip(times, d, strict=True)
                for s in reader.feed_descriptor(float(t), x)]
        want = class_command(ep.klass, reader.gestures)
        right = want is not None and want in said
        counts["recognized"] += right
        counts["missed"] += want is not None and not right
        counts["false"] += len(said) - right
    return counts


def held_out_episodes(classes: list[str], range_m: float, water: str, lamps: bool,
                      seeds: list[int], worksite: bool = False) -> list[GestureEpisode]:
    """One episode per class and seed at one setting, headings drawn within ±35°; with
    ``worksite`` a worksite view drawn for each (:func:`draw_view`)."""
    out = []
    for s in seeds:
        for i, c in enumerate(classes):
            rng = np.random.default_rng([s, i])
            heading = float(rng.uniform(-35, 35))
            out.append(GestureEpisode(c, range_m, heading, water, lamps, 1_000_000 + 97 * s + i,
                                      view=draw_view(rng) if worksite else None))
    return out


def held_out_work(seeds: list[int], per_seed: int) -> list[GestureEpisode]:
    """``per_seed`` work episodes per seed (:func:`work_episode`), lamps on, the black
    suit, seeds the fit never draws."""
    return [work_episode(np.random.default_rng([s, 27, i]), True, 1_000_000 + 97 * s + 50 + i)
            for s in seeds for i in range(per_seed)]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?")
    parser.add_argument("--episodes", type=int, default=20, help="training episodes per class")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--evaluate", action="store_true")
    parser.add_argument("--range", type=float, default=3.0)
    parser.add_argument("--water", default="I")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--views", type=int, default=0,
                        help="worksite views per class, after the mid-water episodes")
    parser.add_argument("--work", type=int, default=0,
                        help="work episodes (class none), after the worksite views; with "
                        "--evaluate: that many held-out work episodes per seed instead")
    parser.add_argument("--worksite", action="store_true",
                        help="with --evaluate: the held-out episodes as worksite views")
    parser.add_argument("--render-part", help="K/N: only render every N-th episode from "
                        "the K-th into --cache")
    parser.add_argument("--cache", type=Path, help="keep the rendered silhouettes here")
    parser.add_argument("--stream", action="store_true",
                        help="with --evaluate: each episode as a stream through the reader")
    parser.add_argument("--hop", type=float, default=HOP_S)
    parser.add_argument("--votes", type=int, default=VOTES)
    parser.add_argument("--min-confidence", type=float, default=MIN_CONFIDENCE)
    args = parser.parse_args(argv)
    if args.evaluate:
        classifier = GestureClassifier.load(args.out)
        held = held_out_work(args.seeds, args.work) if args.work else held_out_episodes(
            list(classifier.classes), args.range, args.water, True, args.seeds, args.worksite)
        if args.stream:
            store = SilhouetteCache(EpisodeRenderer(), args.cache)
            counts = stream_counts(lambda: GestureReader(
                classifier, min_confidence=args.min_confidence, hop_s=args.hop,
                votes=args.votes), held, store)
            print(f"streams at {args.range:g} m, water {args.water}, lamps on (reader: every "
                  f"{args.hop:g} s, {args.votes} in a row, each >= {args.min_confidence:g}): "
                  + ", ".join(f"{k} {v}" for k, v in counts.items()))
            return
        classes, matrix = confusion(classifier, held)
        print(f"accuracy {np.trace(matrix) / matrix.sum():.2f} at {args.range:g} m, "
              f"water {args.water}, lamps on")
        for c, row in zip(classes, matrix, strict=True):
            print(f"{c:>14} " + " ".join(f"{v:2d}" for v in row))
        return
    if args.render_part:
        if args.cache is None:
            parser.error("--render-part needs --cache")
        part, parts = (int(v) for v in args.render_part.split("/"))
        render_part(args.episodes, args.seed, args.views, args.work, args.cache, part, parts)
        return
    if args.out is None:
        parser.error("OUT.json is needed to fit")
    start = time.perf_counter()
    classifier = fit(args.episodes, args.seed, args.cache, args.views, args.work)
    args.out.write_text(json.dumps(classifier.to_dict(), indent=1) + "\n")
    print(classifier.provenance)
    print(f"fitted in {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
