"""Sonar perception of one vehicle, ping by ping: detect → blobs → track → classify.

:class:`SonarPerception` takes :class:`~uhrisim.sensors.sonar.ping.SonarPing` objects
(the polar image, its beam angles and bin ranges, and the sonar's pose from own
navigation) and returns a :class:`PerceptionFrame`: the blobs, every track and which
track it takes for the diver. It knows nothing of the simulation; the simulation turns
the diver track into contact reports (``uhrisim.sim.sonar_contacts``).

Diver selection: among confirmed tracks with P(diver) ≥ ``diver_probability``, the one
held last ping is kept while it stays confirmed with P(diver) ≥ ``keep_probability``
(hysteresis: the identity does not flip between two similar tracks); otherwise the most
probable one is taken.

Robustness: non-finite cells are treated as "no echo" and counted in the frame's
``bad_cells`` (the caller logs them); a ping with no detections only ages the tracks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from uhrisim.core.errors import ConfigError
from uhrisim.perception.blobs import BlobImage, BlobParams, extract_blobs
from uhrisim.perception.classify import DiverClassifier
from uhrisim.perception.detect import (
    BackgroundModel,
    DetectorParams,
    block_grid,
    cfar_mask,
    clean_level,
    horizontal_pose,
)
from uhrisim.perception.tracker import FanView, MultiTargetTracker, Track, TrackerParams
from uhrisim.sensors.sonar.ping import SonarPing


@dataclass(frozen=True)
class PerceptionParams:
    """All perception settings; the defaults suit a P900-class sonar at 2–20 m.

    ``background_alpha``: background update weight per ping; ``diver_probability`` /
    ``keep_probability``: P(diver) to take / keep a track as the diver; ``classifier``:
    None = the shipped parameters.
    """

    detector: DetectorParams = field(default_factory=DetectorParams)
    blobs: BlobParams = field(default_factory=BlobParams)
    tracker: TrackerParams = field(default_factory=TrackerParams)
    background_alpha: float = 0.05
    diver_probability: float = 0.6
    keep_probability: float = 0.3
    classifier: DiverClassifier | None = None

    def __post_init__(self) -> None:
        if not 0.0 < self.keep_probability <= self.diver_probability < 1.0:
            raise ConfigError("need 0 < keep_probability <= diver_probability < 1, got "
                              f"{self.keep_probability}, {self.diver_probability}",
                              "PerceptionParams.diver_probability")


@dataclass(frozen=True)
class TrackReport:
    """A track as seen after one ping (local NED, m, m/s)."""

    id: int
    confirmed: bool
    north: float
    east: float
    v_north: float
    v_east: float
    position_std_m: float
    diver_probability: float
    visible: bool
    blob: int  # index of this ping's blob it took, −1 when coasting
    age_s: float
    coast_s: float

    @property
    def speed(self) -> float:
        return math.hypot(self.v_north, self.v_east)


@dataclass(frozen=True)
class PerceptionFrame:
    """What perception made of one ping.

    ``view``: where the sonar looked; ``blobs``: blobs and their cells; ``tracks``: every
    live track; ``diver``: the id of the track taken for the diver (None: none);
    ``bad_cells``: non-finite cells found in the ping.
    """

    t: float
    view: FanView
    blobs: BlobImage
    tracks: tuple[TrackReport, ...]
    diver: int | None
    bad_cells: int = 0

    @property
    def diver_track(self) -> TrackReport | None:
        return next((tr for tr in self.tracks if tr.id == self.diver), None)


class SonarPerception:
    """Perception state of one sonar (background, tracks, diver identity)."""

    def __init__(self, params: PerceptionParams | None = None) -> None:
        self.params = params if params is not None else PerceptionParams()
        self.classifier = self.params.classifier or DiverClassifier.load()
        self.tracker = MultiTargetTracker(self.params.tracker)
        self._background: BackgroundModel | None = None
        self._shape: tuple[int, int] | None = None
        self.diver: int | None = None

    def process(self, ping: SonarPing) -> PerceptionFrame:
        """Run every stage on ``ping`` (module docstring)."""
        p = self.params
        level, bad = clean_level(ping.polar)
        if level.shape != self._shape:
            self._background = BackgroundModel(ping.bin_ranges_m, ping.beam_angles_rad,
                                               block_grid(level.shape, p.detector),
                                               p.background_alpha)
            self._shape = level.shape
        assert self._background is not None
        pose = horizontal_pose(ping.position_ned, ping.rotation_ned_from_sonar)
        mask, smooth, blocks, background = cfar_mask(level, ping.bin_ranges_m, p.detector)
        contrast = self._background.update(blocks, pose)
        blobs = extract_blobs(mask, smooth, contrast, background, ping.bin_ranges_m,
                              ping.beam_angles_rad,
                              ping.position_ned, ping.rotation_ned_from_sonar,
                              p.detector.edge_beams, p.blobs)
        half = 0.5 * float(ping.beam_angles_rad[-1] - ping.beam_angles_rad[0])
        view = FanView(pose[0], pose[1], pose[2], float(ping.bin_ranges_m[0]),
                       float(ping.bin_ranges_m[-1]), half)
        pairs = self.tracker.step(ping.t, blobs.blobs, view)
        probs = {}
        for tr in self.tracker.tracks:
            probs[tr.id] = (self.classifier.update(tr) if tr.id in pairs
                            else self.classifier.probability(tr))
        self.diver = self._choose_diver(probs)
        reports = tuple(self._report(tr, ping.t, probs[tr.id], pairs.get(tr.id, -1))
                        for tr in self.tracker.tracks)
        return PerceptionFrame(ping.t, view, blobs, reports, self.diver, bad)

    def _choose_diver(self, probs: dict[int, float]) -> int | None:
        p = self.params
        alive = {tr.id: tr for tr in self.tracker.tracks if tr.confirmed}
        if self.diver in alive and probs[self.diver] >= p.keep_probability:
            return self.diver
        best = [(probs[i], -i) for i in alive if probs[i] >= p.diver_probability]
        return -max(best)[1] if best else None

    @staticmethod
    def _report(tr: Track, t: float, prob: float, blob: int) -> TrackReport:
        return TrackReport(tr.id, tr.confirmed, float(tr.x[0]), float(tr.x[1]),
                           float(tr.x[2]), float(tr.x[3]), tr.position_std_m, prob,
                           tr.visible, blob, t - tr.t_born, t - tr.t_last_hit)

