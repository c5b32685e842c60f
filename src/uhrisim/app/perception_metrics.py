"""Perception metrics of a sonar-contacts run (``metrics.json`` → ``perception``).

Scored per ping of the observer's sonar against the label images (``labels: true`` on
the sonar) and the target's true position (NED, horizontal, m):

* **detection precision**: blobs whose cells are mostly labelled with an object other
  than the sea floor / all blobs (speckle and sea-floor blobs are false);
* **detection recall (target)**: pings in which the target shows (≥ ``MIN_TARGET_CELLS``
  labelled cells) and some blob covers at least one of its cells / pings in which it
  shows;
* **held**: pings at which the track perception takes for the diver lies within
  ``hold_radius_m`` of the target's centre / pings from the first such ping on (the time
  to that first hold is ``first_held_s``);
* **identity switches**: changes of the id of the track that holds the target between
  held pings (a re-acquisition under a new id is a switch too);
* **track position error**: distance diver track → target centre over the pings with a
  diver track (mean, RMS, max);
* **false diver tracks per minute** (over the whole run): distinct track ids taken for
  the diver while farther than ``hold_radius_m`` from the target; **clutter tracks per
  minute**: distinct confirmed track ids never within ``hold_radius_m`` of the target.

Without label images, the detection figures are ``null``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from uhrisim.sim.hooks import BaseHook, TickFrame, sensor_key

if TYPE_CHECKING:
    from uhrisim.sim.simulation import Simulation

MIN_TARGET_CELLS = 10


class PerceptionMetrics(BaseHook):
    """Scores the perception of ``observer`` on ``target`` (agent names), from the pings
    of the observer's sonar named ``sonar``."""

    def __init__(self, observer: str, target: str, hold_radius_m: float = 1.0,
                 sonar: str = "sonar") -> None:
        self.observer, self.target = observer, target
        self.key = sensor_key(observer, sonar)
        self.hold_radius_m = hold_radius_m
        self._target_label: int | None = None
        self._floor_label: int | None = None
        self.pings = 0
        self.blobs = 0
        self.object_blobs = 0
        self.target_shown = 0
        self.target_found = 0
        self.labelled = False
        self.counted = 0
        self.held = 0
        self.switches = 0
        self._holder: int | None = None
        self._errors: list[float] = []
        self._false_diver_ids: set[int] = set()
        self._matched_ids: set[int] = set()
        self._confirmed_ids: set[int] = set()
        self._t0: float | None = None
        self._t1 = 0.0

    def on_start(self, sim: Simulation) -> None:
        labels = sim.scene.labels
        body = sim.scene.bodies[sim.scene.body_names.index(self.target)]
        self._target_label = labels.index(body.label)
        self._floor_label = labels.index("seafloor") if "seafloor" in labels else -2

    def on_tick(self, frame: TickFrame) -> None:
        seen = frame.perception.get(self.key)
        if seen is None:
            return
        ping = frame.pings[self.key]
        self.pings += 1
        self._score_detections(seen, ping)
        target = frame.agents[self.target].nav.position_ned
        self._t1 = frame.t
        for tr in seen.tracks:
            if tr.confirmed:
                self._confirmed_ids.add(tr.id)
                if math.hypot(tr.north - target[0], tr.east - target[1]) <= self.hold_radius_m:
                    self._matched_ids.add(tr.id)
        diver = seen.diver_track
        error = math.inf if diver is None else math.hypot(diver.north - target[0],
                                                          diver.east - target[1])
        if self._t0 is None and error <= self.hold_radius_m:
            self._t0 = frame.t
        if self._t0 is None:
            return
        self.counted += 1
        if diver is None:
            return
        self._errors.append(error)
        if error > self.hold_radius_m:
            self._false_diver_ids.add(diver.id)
            return
        self.held += 1
        if self._holder is not None and diver.id != self._holder:
            self.switches += 1
        self._holder = diver.id

    def _score_detections(self, seen: Any, ping: Any) -> None:
        """Count this ping's blobs against its label image."""
        labels = ping.label_polar
        if not (labels >= 0).any():
            return
        target_cells = labels == self._target_label
        self.labelled = True
        image = seen.blobs
        n_blobs = len(image.blobs)
        self.blobs += n_blobs
        if n_blobs:
            cells = image.components > 0
            blob = image.blob_of_component[image.components[cells]]
            lab = labels[cells].astype(np.int64)
            ok = (blob >= 0) & (lab >= 0)
            n_labels = int(labels.max()) + 1
            votes = np.bincount(blob[ok] * n_labels + lab[ok],
                                minlength=n_blobs * n_labels).reshape(n_blobs, n_labels)
            best = np.where(votes.sum(axis=1) > 0, votes.argmax(axis=1), -1)
            self.object_blobs += int(np.count_nonzero((best >= 0) & (best != self._floor_label)))
        if np.count_nonzero(target_cells) >= MIN_TARGET_CELLS:
            self.target_shown += 1
            if np.any(target_cells & (image.components > 0)):
                self.target_found += 1

    def summary(self) -> dict[str, Any]:
        minutes = max(self._t1, 1e-9) / 60.0
        errors = np.array(self._errors)

        def ratio(a: float, b: float) -> float | None:
            return a / b if b else None

        return {"perception": {
            "observer": self.observer, "target": self.target,
            "hold_radius_m": self.hold_radius_m, "pings": self.pings,
            "labelled": self.labelled,
            "detection_precision": ratio(self.object_blobs, self.blobs) if self.labelled
            else None,
            "detection_recall_target": ratio(self.target_found, self.target_shown)
            if self.labelled else None,
            "first_held_s": self._t0,
            "held_pct": 100.0 * self.held / self.counted if self.counted else None,
            "identity_switches": self.switches,
            "track_error_m": {
                "mean": float(errors.mean()) if errors.size else None,
                "rms": float(math.sqrt(np.mean(errors ** 2))) if errors.size else None,
                "max": float(errors.max()) if errors.size else None},
            "false_diver_tracks_per_min": len(self._false_diver_ids) / minutes,
            "clutter_tracks_per_min": len(self._confirmed_ids - self._matched_ids) / minutes,
        }}
