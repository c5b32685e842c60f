"""Diver/clutter classification of tracks.

Method: a two-class Gaussian naive Bayes on track features, accumulated over the track's
life as a leaky log-likelihood ratio — the forward recursion of a two-state hidden Markov
model whose state (diver or clutter) rarely changes, in the log-odds form

    L_k = clip(λ·L_{k−1} + Σ_f clip(log N(f; μ_d, σ_d) − log N(f; μ_c, σ_c), ±c), ±L_max)

with λ < 1 the leak (a state change probability, so old evidence fades) and each
feature's vote clipped to ±c (one odd ping cannot flip a track). P(diver) = σ(L + L₀).
DeMarco et al.'s follow-up on real BlueView data used an HMM on cluster trajectories;
this is the same idea with continuous Gaussian emissions of the features below.

Features of a track after a hit (:func:`track_features`): speed over ground from the
Kalman filter (m/s: a piling is still, bubbles rise and drift slowly, a diver swims),
log cross-range and range extents (m), mean level above the local background (so a
gain or noise-floor change does not move it), level flicker (σ of the level over
hits: fins kick, bubbles burst), motion contrast against the ego-compensated background
and the number of parts merged into the blob. The per-class means and σ are fitted on
simulator runs whose label images say which blobs are the diver
(``uhrisim.experiments.diver_classifier``) and shipped in
``perception/data/diver_classifier.json``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.perception.tracker import Track

FEATURES = ("speed", "log_cross_extent", "log_range_extent", "excess_level", "flicker",
            "contrast", "parts")
_EXTENT_FLOOR_M = 0.05  # m: keeps the log finite for a one-cell blob


def track_features(track: Track) -> NDArray[np.float64]:
    """The feature vector (order of :data:`FEATURES`) of ``track`` now."""
    f = track.features
    return np.array([
        track.speed,
        math.log(f.cross_extent_m + _EXTENT_FLOOR_M),
        math.log(f.range_extent_m + _EXTENT_FLOOR_M),
        f.excess_level,
        math.sqrt(max(f.level_var, 0.0)),
        f.contrast,
        f.parts,
    ])


@dataclass(frozen=True)
class DiverClassifier:
    """Per-class Gaussian parameters and the accumulation settings (module docstring)."""

    diver_mean: tuple[float, ...]
    diver_std: tuple[float, ...]
    clutter_mean: tuple[float, ...]
    clutter_std: tuple[float, ...]
    prior_log_odds: float = 0.0
    leak: float = 0.9
    vote_clip: float = 3.0
    max_log_odds: float = 12.0
    provenance: str = ""

    def __post_init__(self) -> None:
        n = len(FEATURES)
        for name in ("diver_mean", "diver_std", "clutter_mean", "clutter_std"):
            v = getattr(self, name)
            if len(v) != n or not all(math.isfinite(x) for x in v):
                raise ConfigError(f"needs {n} finite numbers ({', '.join(FEATURES)})",
                                  f"DiverClassifier.{name}")
        if min(self.diver_std + self.clutter_std) <= 0:
            raise ConfigError("standard deviations must be > 0", "DiverClassifier")
        if not 0.0 <= self.leak < 1.0:
            raise ConfigError(f"must be in [0, 1), got {self.leak}", "DiverClassifier.leak")

    def vote(self, features: NDArray[np.float64]) -> float:
        """Clipped log-likelihood ratio diver : clutter of one feature vector."""
        md, sd = np.asarray(self.diver_mean), np.asarray(self.diver_std)
        mc, sc = np.asarray(self.clutter_mean), np.asarray(self.clutter_std)
        llr = (np.log(sc / sd) - 0.5 * ((features - md) / sd) ** 2
               + 0.5 * ((features - mc) / sc) ** 2)
        return float(np.sum(np.clip(llr, -self.vote_clip, self.vote_clip)))

    def update(self, track: Track) -> float:
        """Fold the track's current features into its log-odds; return P(diver)."""
        lo = self.leak * track.diver_log_odds + self.vote(track_features(track))
        track.diver_log_odds = float(np.clip(lo, -self.max_log_odds, self.max_log_odds))
        return self.probability(track)

    def probability(self, track: Track) -> float:
        z = track.diver_log_odds + self.prior_log_odds
        return 1.0 / (1.0 + math.exp(-z))

    # -- files ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {"method": "two-class Gaussian naive Bayes, leaky log-odds accumulation",
                "features": list(FEATURES),
                "diver": {"mean": list(self.diver_mean), "std": list(self.diver_std)},
                "clutter": {"mean": list(self.clutter_mean), "std": list(self.clutter_std)},
                "prior_log_odds": self.prior_log_odds, "leak": self.leak,
                "vote_clip": self.vote_clip, "max_log_odds": self.max_log_odds,
                "provenance": self.provenance}

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "classifier") -> DiverClassifier:
        try:
            if list(d["features"]) != list(FEATURES):
                raise ConfigError(f"features must be {list(FEATURES)}, got {d['features']}",
                                  where)
            return cls(tuple(map(float, d["diver"]["mean"])), tuple(map(float, d["diver"]["std"])),
                       tuple(map(float, d["clutter"]["mean"])),
                       tuple(map(float, d["clutter"]["std"])),
                       float(d.get("prior_log_odds", 0.0)), float(d.get("leak", 0.9)),
                       float(d.get("vote_clip", 3.0)), float(d.get("max_log_odds", 12.0)),
                       str(d.get("provenance", "")))
        except (KeyError, TypeError, ValueError) as error:
            if isinstance(error, ConfigError):
                raise
            raise ConfigError(f"not a diver classifier file: {error!r}", where) from None

    @classmethod
    def load(cls, path: str | Path | None = None) -> DiverClassifier:
        """The classifier in ``path``, or the shipped one."""
        if path is None:
            text = resources.files("uhrisim.perception").joinpath(
                "data/diver_classifier.json").read_text()
            where = "uhrisim/perception/data/diver_classifier.json"
        else:
            try:
                text = Path(path).read_text()
            except OSError as error:
                raise ConfigError(f"cannot read: {error.strerror or error}", str(path)) from None
            where = str(path)
        try:
            data = json.loads(text)
        except json.JSONDecodeError as error:
            raise ConfigError(f"not JSON: {error}", where) from None
        return cls.from_dict(data, where)
