"""Reading the diver's gestures from the ROV's camera pictures.

**Per frame** (:func:`frame_descriptor`), from the 8-bit picture only (no label image):
the picture is binned to at most 320 columns; the water's veil (and the floor) is taken
as the running median along each row over :data:`BACKGROUND_PX` pixels, of every
:data:`BACKGROUND_STEP` th pixel (wider than a diver's body, and it follows the horizon's
curve), colour by colour, and the pixels that
differ from it in any colour by more than ``4·σ`` of that colour (σ from the median
absolute deviation) and at least 4 levels are the silhouette (the grey neoprene stands
out from the blue water by colour more than by brightness); an opening removes speckle;
parts less than :data:`GROUP_PX` pixels apart form a group, and the groups of at least
:data:`KEEP_SHARE` of the largest one's pixels are the diver (his body, limbs and shadow
on the floor).

Its scale is its median row width (the torso's, about; arms and head are few rows); its
pixels, measured down from its top (the head, or a raised hand) and sideways from its
median column, in that scale, fill a grid of :data:`GRID_ROWS` rows × :data:`GRID_COLS`
columns of |x| (the picture folded about the median column, so a gesture made with
either arm reads the same) — each cell's filled area — and three shape numbers: the
grid's filled area, its farthest |x| and its mean depth below the top. The grid ends
five torso widths down (about the hips), so the legs and his shadow on the floor, which
change with range, stay out of it. Nothing found: a row of NaN.

**Per window** (:func:`window_features`): the last ``window_s`` of frame descriptors
(a gesture's whole motion fits): their mean, their standard deviation, the mean of the
last second (the pose held at the end), and the motion — the mean frame-to-frame change
of the grid, the share of time it exceeds :data:`MOVING` (how long the arms moved) and
the number of its rises above :data:`MOVING` (strokes: beckons, pumps, counts).

**Classifier** (:class:`GestureClassifier`): Gaussian classes over those features with
one diagonal covariance shared by all (each feature's pooled within-class spread: with a
few dozen rendered episodes per class, per-class spreads overfit), equal priors; one
class per gesture (``bring_tool`` once per tool number: ``bring_tool:2`` is the
hammer's) and ``none`` (the diver at rest, or a gesture under way); the confidence is
the class's posterior. Parameters fitted on pictures the simulator
renders and labels (``uhrisim.experiments.gesture_classifier``), shipped in
``perception/data/gesture_classifier.json`` with their provenance.

**Streaming** (:class:`GestureReader`): fed every camera frame; every ``hop_s`` it
classifies the last window, and says a command when the same class wins with at least
``min_confidence`` twice in a row; then it stays quiet for a window (the same gesture is
not said twice).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from uhrisim.core.errors import ConfigError
from uhrisim.perception.gestures import GestureSet
from uhrisim.perception.signals import Command, RecognizedSignal, load_json

GRID_ROWS, GRID_COLS = 5, 3
#: grid extent in units of the silhouette's scale (its median row width, ~ the torso's):
#: |x| from the median column in [0, 3), y down from the top in [0, 5)
GRID_X, GRID_Y = (0.0, 3.0), (0.0, 5.0)
FRAME_FEATURES = GRID_ROWS * GRID_COLS + 3
MIN_AREA_PX = 12
GROUP_PX = 3
THRESHOLD_SIGMA, MIN_LEVELS = 4.0, 4.0
BACKGROUND_PX, BACKGROUND_STEP = 80, 8
KEEP_SHARE = 0.15
MAX_COLUMNS = 320
#: frame-to-frame grid change (summed absolute share) that counts as the arms moving
MOVING = 0.08
NONE = "none"


def _binned(rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
    """The picture as float, binned to at most MAX_COLUMNS columns."""
    image = rgb.astype(np.float32)
    factor = max(1, math.ceil(image.shape[1] / MAX_COLUMNS))
    if factor > 1:
        h, w = (image.shape[0] // factor) * factor, (image.shape[1] // factor) * factor
        image = image[:h, :w].reshape(h // factor, factor, w // factor, factor, -1).mean(
            axis=(1, 3))
    return image


def silhouette(rgb: NDArray[np.uint8]) -> NDArray[np.bool_]:
    """The diver's silhouette in the binned picture (module docstring); may be empty."""
    image = _binned(rgb)
    coarse = ndimage.median_filter(image[:, ::BACKGROUND_STEP],
                                   size=(1, BACKGROUND_PX // BACKGROUND_STEP + 1, 1),
                                   mode="nearest")
    background = np.repeat(coarse, BACKGROUND_STEP, axis=1)[:, :image.shape[1]]
    residual = np.abs(image - background)
    sigma = np.maximum(1.4826 * np.median(residual, axis=(0, 1)), 1.0)
    outlier = (residual > np.maximum(THRESHOLD_SIGMA * sigma, MIN_LEVELS)).any(axis=2)
    mask = ndimage.binary_opening(outlier)
    labels, n = ndimage.label(ndimage.binary_dilation(mask, iterations=GROUP_PX))
    if n == 0:
        return mask
    sizes = np.bincount(labels[mask], minlength=n + 1)
    keep = sizes >= max(MIN_AREA_PX, KEEP_SHARE * sizes[1:].max())
    keep[0] = False
    return mask & keep[labels]


def frame_descriptor(rgb: NDArray[np.uint8]) -> NDArray[np.float64]:
    """(FRAME_FEATURES,) grid fills and shape numbers of one picture; NaN if no diver."""
    mask = silhouette(rgb)
    rows, cols = np.nonzero(mask)
    if rows.size < MIN_AREA_PX:
        return np.full(FRAME_FEATURES, np.nan)
    widths = mask.sum(axis=1)
    scale = max(2.0, float(np.median(widths[widths > 0])))
    x = np.abs(cols - np.median(cols)) / scale
    y = (rows - rows.min()) / scale
    grid, _, _ = np.histogram2d(y, x, (GRID_ROWS, GRID_COLS), (GRID_Y, GRID_X))
    inside = y < GRID_Y[1]
    shape = [inside.sum() / scale ** 2, x[inside].max(), y[inside].mean()]
    return np.concatenate([grid.ravel() / scale ** 2, shape])


def window_features(descriptors: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    """Features of a window of frame descriptors ((n, FRAME_FEATURES), oldest first) at
    ``rate_hz`` (module docstring); NaN where the diver was seen in under half the frames."""
    d = np.asarray(descriptors, float)
    seen = ~np.isnan(d[:, 0])
    n_out = 3 * FRAME_FEATURES + 3
    if seen.sum() < max(2, 0.5 * len(d)):
        return np.full(n_out, np.nan)
    d = d[seen]
    last = d[-max(1, round(rate_hz)):]
    change = np.abs(np.diff(d[:, :GRID_ROWS * GRID_COLS], axis=0)).sum(axis=1)
    moving = change > MOVING
    strokes = int(np.count_nonzero(moving[1:] & ~moving[:-1]) + (moving[:1].sum()))
    return np.concatenate([d.mean(axis=0), d.std(axis=0), last.mean(axis=0),
                           [change.mean(), moving.mean(), strokes]])


def class_command(name: str, gestures: GestureSet) -> Command | None:
    """The command a class says (None for ``none``): ``bring_tool:3`` → bring_tool light."""
    if name == NONE:
        return None
    gesture, _, count = name.partition(":")
    command = gestures.gestures[gesture].command
    if not count:
        return Command(command)
    tools = [tool for tool, number in gestures.tool_numbers.items() if number == int(count)]
    return Command(command, tools[0]) if tools else None


@dataclass(frozen=True)
class GestureClassifier:
    """Gaussian naive Bayes over :func:`window_features` (module docstring)."""

    classes: tuple[str, ...]
    means: NDArray[np.float64]  # (classes, features)
    stds: NDArray[np.float64]  # (features,): shared
    window_s: float
    rate_hz: float
    provenance: str = ""

    def __post_init__(self) -> None:
        n = 3 * FRAME_FEATURES + 3
        for name, shape in (("means", (len(self.classes), n)), ("stds", (n,))):
            array = np.asarray(getattr(self, name), float)
            if array.shape != shape or not np.all(np.isfinite(array)):
                raise ConfigError(f"must be {' × '.join(map(str, shape))} finite numbers",
                                  f"GestureClassifier.{name}")
            object.__setattr__(self, name, array)
        if np.any(self.stds <= 0):
            raise ConfigError("standard deviations must be > 0", "GestureClassifier.stds")
        if NONE not in self.classes:
            raise ConfigError(f"the classes must include {NONE!r}", "GestureClassifier")

    @property
    def window_frames(self) -> int:
        return max(2, round(self.window_s * self.rate_hz))

    def log_posteriors(self, features: NDArray[np.float64]) -> NDArray[np.float64]:
        """Normalised log posteriors (equal priors) of one feature vector."""
        z = (np.asarray(features, float) - self.means) / self.stds
        log_l = -0.5 * np.sum(z * z, axis=1)
        return log_l - (log_l.max() + math.log(np.exp(log_l - log_l.max()).sum()))

    def classify(self, features: NDArray[np.float64]) -> tuple[str, float]:
        """(class, posterior) of a window's features; (``none``, 1) if the diver was not
        seen enough (NaN features)."""
        if np.any(np.isnan(features)):
            return NONE, 1.0
        lp = self.log_posteriors(features)
        best = int(np.argmax(lp))
        return self.classes[best], float(math.exp(lp[best]))

    # -- files ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {"method": "Gaussian classes with a shared diagonal covariance over window "
                          "features (perception/gesture_reader.py), equal priors",
                "window_s": self.window_s, "rate_hz": self.rate_hz,
                "std": [round(float(v), 6) for v in self.stds],
                "classes": {c: [round(float(v), 6) for v in m]
                            for c, m in zip(self.classes, self.means, strict=True)},
                "provenance": self.provenance}

    @classmethod
    def from_dict(cls, data: Any, where: str = "gesture classifier") -> GestureClassifier:
        try:
            classes = tuple(data["classes"])
            return cls(classes, np.array([data["classes"][c] for c in classes]),
                       np.array(data["std"]),
                       float(data["window_s"]), float(data["rate_hz"]),
                       str(data.get("provenance", "")))
        except (KeyError, TypeError, ValueError) as error:
            if isinstance(error, ConfigError):
                raise ConfigError(str(error).split(": ", 1)[-1], where) from None
            raise ConfigError(f"not a gesture classifier file: missing or bad {error}",
                              where) from None

    @classmethod
    def load(cls, path: str | Path | None = None) -> GestureClassifier:
        """The classifier in the JSON file ``path``, or the shipped one."""
        data, where = load_json(path, "gesture_classifier.json", "gesture classifier")
        return cls.from_dict(data, where)


@dataclass
class GestureReader:
    """Streams camera frames into gesture signals (module docstring)."""

    classifier: GestureClassifier = field(default_factory=GestureClassifier.load)
    gestures: GestureSet = field(default_factory=GestureSet.load)
    min_confidence: float = 0.9
    hop_s: float = 1.0
    _frames: list[tuple[float, NDArray[np.float64]]] = field(default_factory=list, init=False)
    _next_t: float = field(default=-math.inf, init=False)
    _quiet_until: float = field(default=-math.inf, init=False)
    _candidate: str = field(default=NONE, init=False)

    def feed(self, t: float, rgb: NDArray[np.uint8]) -> list[RecognizedSignal]:
        """Take one camera picture at time ``t`` (s); the signals recognized now."""
        period = 1.0 / self.classifier.rate_hz
        if self._frames and t < self._frames[-1][0] + period - 1e-6:
            return []  # frames come faster than the classifier's rate: skip
        self._frames.append((t, frame_descriptor(rgb)))
        self._frames = [(ti, d) for ti, d in self._frames if ti > t - self.classifier.window_s]
        if t < self._next_t or len(self._frames) < self.classifier.window_frames - 1:
            return []
        self._next_t = t + self.hop_s
        features = window_features(np.array([d for _, d in self._frames]),
                                   self.classifier.rate_hz)
        name, confidence = self.classifier.classify(features)
        said = name != NONE and name == self._candidate and confidence >= self.min_confidence
        self._candidate = name if confidence >= self.min_confidence else NONE
        if not said or t < self._quiet_until:
            return []
        self._quiet_until = t + self.classifier.window_s
        command = class_command(name, self.gestures)
        if command is None:
            return []
        return [RecognizedSignal(command, "gesture", confidence, t)]
