"""Reading the diver's gestures from the ROV's camera pictures.

**Per frame** (:func:`frame_descriptor`), from the 8-bit picture only (no label image):
the picture is binned to at most :data:`MAX_COLUMNS` columns; the water's veil (and the
floor) is taken as the running median along each row over :data:`BACKGROUND_PX` pixels, of
every :data:`BACKGROUND_STEP` th pixel (wider than a diver's body, and it follows the
horizon's curve), colour by colour, and the pixels that differ from it in any colour by
more than ``4·σ`` of that colour (σ from the median absolute deviation) and at least 4
levels are the silhouette (it does not depend on the suit's colour, only on its contrast
with the water), σ the larger of the picture's and the row's own (a row of rippled sand
spreads more than the water: its texture is not the diver); parts less than
:data:`GROUP_PX` pixels apart form a group, and the groups of at least :data:`KEEP_SHARE`
of the largest one's pixels are the diver (his body, limbs and shadow on the floor). No
opening: at 160 columns an arm at 3 m is 1–2 px wide. The descriptor drops the groups that
are thin and wide (:data:`MIN_GROUP_ROWS`, :data:`MIN_HEIGHT_SHARE`): the floor's edge when
the camera turns, never a diver.

Its scale is its median row width (the torso's, about: arms and head are few rows); its
pixels, measured down from its top (the head, or a raised hand) and sideways from its
median column in that scale, fill a grid of :data:`GRID_ROWS` × :data:`GRID_COLS` cells
(each cell's filled area), and for each side the arm's reach — the farthest pixel outside
the torso's column band (:data:`BAND`), how far out and how far down from the top, and
the area outside the band — plus the logarithm of the scale over the picture's width (the
apparent size: the range). Nothing found: a row of NaN.

**Per window** (:func:`window_features`): the last ``window_s`` of frame descriptors,
mirrored when the left side moved more (a gesture made with either arm reads the same):
their means over time bins counted back from the window's end (:data:`TIME_BINS_S`: the
pose held at the end, the motion before it), their standard deviations, and the motion —
the frame-to-frame change of the grid and the reaches — per second back from the end
(when the big moves happened: ``bring_tool``'s count is how long the arm stroked
before it dropped).

**Classifier** (:class:`GestureClassifier`): a network of one hidden layer of ``tanh``
units and a softmax over the standardised window features, one class per gesture
(``bring_tool`` once per tool number: ``bring_tool:2`` is the hammer's) and ``none`` (the
diver at rest, or a gesture under way); the confidence is the class's probability. A
window whose diver looks nearer or farther than any the network was fitted on (his
apparent size beyond :data:`SIZE_SPREADS` training spreads) is ``none``: the ROV at arm's
reach sees his trunk fill the picture, a view the training never showed; so is one whose
diver is not upright at its end (:data:`UPRIGHT_FILL`: he swims or works prone).
Parameters fitted on pictures the simulator renders and labels
(``uhrisim.experiments.gesture_classifier``), shipped in
``perception/data/gesture_classifier.json`` with their provenance.

**Streaming** (:class:`GestureReader`): fed every camera frame; every ``hop_s`` it
classifies the last window, and says a command when the same class wins ``votes`` times
in a row, each time with at least ``min_confidence``, and the diver is in the newest
picture (nothing is said while the camera looks away); then it stays quiet for a window
(the same gesture is not said twice). A picture in which the ROV's own track does not put
the diver counts as one without him. ``uhrisim.experiments.gesture_classifier
--evaluate --stream`` counts what a rule recognizes, misses and says falsely on held-out
streams (docs/hri.md).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.perception.gestures import GestureSet
from uhrisim.perception.signals import Command, RecognizedSignal, load_json

GRID_ROWS, GRID_COLS = 6, 6
#: grid extent in units of the silhouette's scale (its median row width, ~ the torso's):
#: x from the median column in [-3, 3) (left negative), y down from the top in [-2, 4)
#: (above the top: a raised hand)
GRID_X, GRID_Y = (-3.0, 3.0), (-2.0, 4.0)
#: half-width of the torso's column band (scale units): pixels beyond it are an arm's
BAND = 0.75
#: half-width of the band whose top is the head's (scale units), and the shoulders'
#: depth below it
HEAD_BAND, SHOULDER_Y = 0.4, 1.0
#: per side: reach (scale units out of the median column), the reach's depth below the
#: head, the arm's highest and mean depth, its area
SIDE_FEATURES = 5
GRID_CELLS = GRID_ROWS * GRID_COLS
FRAME_FEATURES = GRID_CELLS + 2 * SIDE_FEATURES + 2
MIN_AREA_PX = 12
#: a silhouette with more than this share of isolated pixels is the sensor's noise
NOISE_SHARE = 0.25
GROUP_PX = 2
#: a group of the silhouette (grown by GROUP_PX each side) fewer rows tall than this, or
#: than this share of its width, is a line of the floor or the horizon, not a diver (the
#: floor's edge: 1-3 px high, 20-60 wide; the diver: 30-70 rows at 2.5-4.5 m)
MIN_GROUP_ROWS, MIN_HEIGHT_SHARE = 12, 0.5
THRESHOLD_SIGMA, MIN_LEVELS = 4.0, 4.0
#: the version of :func:`silhouette`'s rule, stored with cached silhouettes: 2 since the
#: tenth session (each row's own spread); a cache of another version renders again
SILHOUETTE_VERSION = 2
BACKGROUND_PX, BACKGROUND_STEP = 40, 4
KEEP_SHARE = 0.15
MAX_COLUMNS = 160
#: time bins of a window's means, seconds back from its end
TIME_BINS_S = (0.0, 1.0, 2.0, 3.5, 5.0, 7.0, 10.0, 14.0)
#: seconds back from the end over which the motion is summed, one number per second
MOTION_S = 14
WINDOW_FEATURES = (len(TIME_BINS_S) - 1) * FRAME_FEATURES + FRAME_FEATURES + MOTION_S
NONE = "none"
#: a window whose apparent size (the diver's range) lies farther than this many training
#: spreads from the training mean, in any time bin, is a range the network was not fitted
#: on (its training windows lie within ±3.6): read as ``none``
SIZE_SPREADS = 4.0
#: a window whose standardised features lie farther than this from the training mean,
#: root-mean-square over the features, is a view the network was never fitted on (the
#: held-out clear-water windows at 2-4.5 m: at most 4.8, a two-arm wave at 2 m; the 9C
#: salvage's false gestures, the diver within 1-1.5 m half lost in the murk or seen side
#: on: 8-4000): read as ``none``
NOVELTY_RMS = 6.0
#: where the apparent size sits in a window's features: the last of each time bin's means
_SIZES = np.arange(len(TIME_BINS_S) - 1) * FRAME_FEATURES + FRAME_FEATURES - 1
#: a diver signals upright, facing the camera (he gets ready so: perception/signalling.py):
#: a window whose diver fills less than UPRIGHT_FILL (scale² units) of the grid's rows
#: from UPRIGHT_BELOW scale units below his top down (his hips and legs), in the mean
#: picture of either of its last UPRIGHT_BINS time bins (the last 2 s), is ``none`` — he
#: swims or works prone, a wide and low silhouette. Every training window of a gesture
#: fills at least 1.31 (shipped fit, docs/hri.md); prone at his work in the assisted
#: salvage: 0.0-0.3
UPRIGHT_FILL, UPRIGHT_BELOW, UPRIGHT_BINS = 0.6, 2.0, 2
_UPRIGHT_CELLS = np.array([
    row * GRID_COLS + col for row in range(GRID_ROWS) for col in range(GRID_COLS)
    if GRID_Y[0] + row * (GRID_Y[1] - GRID_Y[0]) / GRID_ROWS >= UPRIGHT_BELOW])
#: the streaming reader's decision rule (:class:`GestureReader`): every 0.5 s, the same
#: class three times in a row with >= 0.7 each time (chosen on validation streams:
#: docs/hri.md)
HOP_S, VOTES, MIN_CONFIDENCE = 0.5, 3, 0.7


def _binned(rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
    """The picture as float, binned to at most MAX_COLUMNS columns: each bin's mean, its
    integer sum over the factor² pixels divided once (exact sums: the same float32 as
    numpy's mean of the float32 pixels, in any order)."""
    factor = max(1, math.ceil(rgb.shape[1] / MAX_COLUMNS))
    if factor == 1:
        return rgb.astype(np.float32)
    h, w = (rgb.shape[0] // factor) * factor, (rgb.shape[1] // factor) * factor
    total = np.zeros((h // factor, w // factor, rgb.shape[2]), np.uint32)
    for row in range(factor):
        for col in range(factor):
            total += rgb[row:h:factor, col:w:factor]
    return total.astype(np.float32) / np.float32(factor * factor)


def _running_median(image: NDArray[np.float32], size: int) -> NDArray[np.float32]:
    """The median of ``size`` (odd) neighbours along each row, the edge pixels repeated
    past the ends (``scipy.ndimage.median_filter(size=(1, size, 1), mode="nearest")``):
    one of the values, so exactly the same."""
    half = size // 2
    padded = np.pad(image, ((0, 0), (half, half), (0, 0)), mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, size, axis=1)
    return np.partition(windows, half, axis=-1)[..., half]


#: the neighbours a silhouette's parts grow into to join a group (4-connected)
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


def silhouette(rgb: NDArray[np.uint8]) -> NDArray[np.bool_]:
    """The diver's silhouette in the binned picture (module docstring); may be empty."""
    image = _binned(rgb)
    coarse = _running_median(image[:, ::BACKGROUND_STEP], BACKGROUND_PX // BACKGROUND_STEP + 1)
    background = np.repeat(coarse, BACKGROUND_STEP, axis=1)[:, :image.shape[1]]
    residual = np.abs(image - background)
    sigma = np.maximum(1.4826 * np.median(residual, axis=(0, 1)), 1.0)
    # rows of textured floor (sand ripples) spread more than the water: each row's own
    # spread, where it is the larger (the diver fills well under half of a row)
    sigma = np.maximum(sigma, 1.4826 * np.median(residual, axis=1, keepdims=True))
    mask = (residual > np.maximum(THRESHOLD_SIGMA * sigma, MIN_LEVELS)).any(axis=2)
    grown = cv2.dilate(mask.view(np.uint8), _CROSS, iterations=GROUP_PX)
    n, labels = cv2.connectedComponents(grown, connectivity=4, ltype=cv2.CV_32S)
    if n == 1:
        return mask
    sizes = np.bincount(labels[mask], minlength=n)
    keep = sizes >= max(MIN_AREA_PX, KEEP_SHARE * sizes[1:].max())
    keep[0] = False
    return mask & keep[labels]


def frame_descriptor(rgb: NDArray[np.uint8]) -> NDArray[np.float64]:
    """(FRAME_FEATURES,) grid fills, the arms' reaches and the apparent size of one
    picture (module docstring); NaN if no diver."""
    return silhouette_descriptor(silhouette(rgb))


def silhouette_descriptor(mask: NDArray[np.bool_]) -> NDArray[np.float64]:
    """:func:`frame_descriptor` of a silhouette; its pixels without a neighbour (noise
    along the horizon) left out, and nothing found where more than :data:`NOISE_SHARE`
    of them have none (the camera's noise in turbid water, not a diver)."""
    neighbours = cv2.boxFilter(mask.astype(np.uint8), -1, (3, 3), normalize=False,
                               borderType=cv2.BORDER_CONSTANT)
    isolated = np.count_nonzero(mask & (neighbours < 2))
    mask = _without_thin_groups(mask & (neighbours >= 2))
    rows, cols = np.nonzero(mask)
    if rows.size < MIN_AREA_PX or isolated > NOISE_SHARE * (rows.size + isolated):
        return np.full(FRAME_FEATURES, np.nan)
    widths = mask.sum(axis=1)
    scale = max(2.0, float(np.median(widths[widths > 0])))
    x = (cols - np.median(cols)) / scale
    core = np.abs(x) < HEAD_BAND
    y = (rows - (rows[core].min() if core.any() else rows.min())) / scale
    grid, _, _ = np.histogram2d(y, x, (GRID_ROWS, GRID_COLS), (GRID_Y, GRID_X))
    sides = []
    for sign in (-1.0, 1.0):
        out = sign * x > BAND
        if out.any():
            far = int(np.argmax(np.where(out, sign * x, -np.inf)))
            sides += [sign * x[far], y[far], y[out].min(), y[out].mean(),
                      out.sum() / scale ** 2]
        else:
            sides += [BAND, SHOULDER_Y, SHOULDER_Y, SHOULDER_Y, 0.0]
    above = np.count_nonzero(y < 0) / scale ** 2
    size = math.log(scale / mask.shape[1])
    return np.concatenate([grid.ravel() / scale ** 2, sides, [above, size]])


def _without_thin_groups(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """``mask`` without its groups (parts within :data:`GROUP_PX` pixels, grown by it) that
    are fewer than :data:`MIN_GROUP_ROWS` rows tall or than :data:`MIN_HEIGHT_SHARE` of
    their width: the edge of the floor or the horizon where the camera turns, never a
    diver."""
    grown = cv2.dilate(mask.view(np.uint8), _CROSS, iterations=GROUP_PX)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(grown, connectivity=4,
                                                           ltype=cv2.CV_32S)
    height = stats[:, cv2.CC_STAT_HEIGHT]
    tall = height >= np.maximum(MIN_GROUP_ROWS, MIN_HEIGHT_SHARE * stats[:, cv2.CC_STAT_WIDTH])
    tall[0] = False
    return mask & tall[labels]


def _mirrored(d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Frame descriptors (n, FRAME_FEATURES) of the mirror image: the grid's columns
    reversed, the sides swapped."""
    grid = d[:, :GRID_CELLS].reshape(-1, GRID_ROWS, GRID_COLS)[:, :, ::-1]
    left = d[:, GRID_CELLS:GRID_CELLS + SIDE_FEATURES]
    right = d[:, GRID_CELLS + SIDE_FEATURES:GRID_CELLS + 2 * SIDE_FEATURES]
    return np.concatenate([grid.reshape(len(d), -1), right, left, d[:, -2:]], axis=1)


def window_features(descriptors: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    """Features of a window of frame descriptors ((n, FRAME_FEATURES), oldest first) at
    ``rate_hz`` (module docstring); NaN where the diver was seen in under half the frames."""
    d = np.asarray(descriptors, float)
    seen = ~np.isnan(d[:, 0])
    if seen.sum() < max(2, 0.5 * len(d)):
        return np.full(WINDOW_FEATURES, np.nan)
    age = (len(d) - 1 - np.flatnonzero(seen)) / rate_hz  # s before the window's end
    d = d[seen]
    left_area = d[:, GRID_CELLS + SIDE_FEATURES - 1]
    right_area = d[:, GRID_CELLS + 2 * SIDE_FEATURES - 1]
    if left_area.mean() + left_area.std() > right_area.mean() + right_area.std():
        d = _mirrored(d)
    means = []
    for lo, hi in itertools.pairwise(TIME_BINS_S):
        inside = (age >= lo) & (age < hi)
        means.append(d[inside].mean(axis=0) if inside.any() else d.mean(axis=0))
    change = np.abs(np.diff(d[:, :GRID_CELLS + 2 * SIDE_FEATURES], axis=0)).sum(axis=1)
    motion = np.bincount(np.minimum(age[1:], MOTION_S - 1).astype(int), change,
                         minlength=MOTION_S)[:MOTION_S] / rate_hz
    return np.concatenate([*means, d.std(axis=0), motion])


def upright_fill(features: NDArray[np.float64]) -> float:
    """The least fill of the grid's rows from :data:`UPRIGHT_BELOW` scale units below the
    diver's top down, over a window's last :data:`UPRIGHT_BINS` time bins (scale² units;
    :data:`UPRIGHT_FILL`); NaN for a window in which he was not seen enough."""
    return min(float(features[b * FRAME_FEATURES + _UPRIGHT_CELLS].sum())
               for b in range(UPRIGHT_BINS))


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
    """A small neural network over standardised :func:`window_features` (module
    docstring): one hidden layer of ``tanh`` units, then a softmax over the classes."""

    classes: tuple[str, ...]
    center: NDArray[np.float64]  # (features,): subtracted from a window's features
    spread: NDArray[np.float64]  # (features,): then divided by this
    hidden_weights: NDArray[np.float64]  # (hidden, features)
    hidden_bias: NDArray[np.float64]  # (hidden,)
    weights: NDArray[np.float64]  # (classes, hidden)
    bias: NDArray[np.float64]  # (classes,)
    window_s: float
    rate_hz: float
    provenance: str = ""

    def __post_init__(self) -> None:
        n, k = WINDOW_FEATURES, len(self.classes)
        h = np.shape(self.hidden_bias)[0] if np.ndim(self.hidden_bias) == 1 else -1
        for name, shape in (("center", (n,)), ("spread", (n,)), ("hidden_weights", (h, n)),
                            ("hidden_bias", (h,)), ("weights", (k, h)), ("bias", (k,))):
            array = np.asarray(getattr(self, name), float)
            if h < 1 or array.shape != shape or not np.all(np.isfinite(array)):
                raise ConfigError(f"must be {' × '.join(map(str, shape))} finite numbers",
                                  f"GestureClassifier.{name}")
            object.__setattr__(self, name, array)
        if np.any(self.spread <= 0):
            raise ConfigError("spreads must be > 0", "GestureClassifier.spread")
        if NONE not in self.classes:
            raise ConfigError(f"the classes must include {NONE!r}", "GestureClassifier")

    @property
    def window_frames(self) -> int:
        return max(2, round(self.window_s * self.rate_hz))

    def log_posteriors(self, features: NDArray[np.float64]) -> NDArray[np.float64]:
        """Normalised log probabilities of the classes for one feature vector."""
        x = (np.asarray(features, float) - self.center) / self.spread
        logits = self.weights @ np.tanh(self.hidden_weights @ x + self.hidden_bias) + self.bias
        return logits - (logits.max() + math.log(np.exp(logits - logits.max()).sum()))

    def classify(self, features: NDArray[np.float64]) -> tuple[str, float]:
        """(class, probability) of a window's features; (``none``, 1) if the diver was
        not seen enough (NaN features), is not upright (:data:`UPRIGHT_FILL`), is nearer
        or farther than the network was fitted on (:data:`SIZE_SPREADS`) or looks like
        nothing it was fitted on (:data:`NOVELTY_RMS`)."""
        if np.any(np.isnan(features)) or upright_fill(features) < UPRIGHT_FILL or np.any(
                np.abs(features[_SIZES] - self.center[_SIZES])
                > SIZE_SPREADS * self.spread[_SIZES]) or math.sqrt(np.mean(
                    ((features - self.center) / self.spread) ** 2)) > NOVELTY_RMS:
            return NONE, 1.0
        lp = self.log_posteriors(features)
        best = int(np.argmax(lp))
        return self.classes[best], float(math.exp(lp[best]))

    # -- files ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        def numbers(a: NDArray[np.float64]) -> list[float]:
            return [float(f"{v:.6g}") for v in a]

        return {"method": "one hidden layer of tanh units and a softmax over standardised "
                          "window features (perception/gesture_reader.py)",
                "window_s": self.window_s, "rate_hz": self.rate_hz,
                "center": numbers(self.center), "spread": numbers(self.spread),
                "hidden": [{"bias": float(f"{b:.6g}"), "weights": numbers(w)}
                           for b, w in zip(self.hidden_bias, self.hidden_weights, strict=True)],
                "classes": {c: {"bias": float(f"{b:.6g}"), "weights": numbers(w)}
                            for c, b, w in zip(self.classes, self.bias, self.weights,
                                               strict=True)},
                "provenance": self.provenance}

    @classmethod
    def from_dict(cls, data: Any, where: str = "gesture classifier") -> GestureClassifier:
        try:
            classes = tuple(data["classes"])
            return cls(classes, np.array(data["center"]), np.array(data["spread"]),
                       np.array([unit["weights"] for unit in data["hidden"]]),
                       np.array([unit["bias"] for unit in data["hidden"]]),
                       np.array([data["classes"][c]["weights"] for c in classes]),
                       np.array([data["classes"][c]["bias"] for c in classes]),
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
    min_confidence: float = MIN_CONFIDENCE
    hop_s: float = HOP_S
    votes: int = VOTES
    _frames: list[tuple[float, NDArray[np.float64]]] = field(default_factory=list, init=False)
    _next_t: float = field(default=-math.inf, init=False)
    _quiet_until: float = field(default=-math.inf, init=False)
    _last: list[tuple[str, float]] = field(default_factory=list, init=False)

    def feed(self, t: float, rgb: NDArray[np.uint8], diver_in_view: bool = True
             ) -> list[RecognizedSignal]:
        """Take one camera picture at time ``t`` (s); the signals recognized now.
        ``diver_in_view`` False (the ROV's own track puts him outside the picture): the
        picture is taken as one without him, whatever its silhouette is (a lift bag
        rising, a valve: not his gestures)."""
        if not self.takes(t):
            return []  # frames come faster than the classifier's rate: skip
        return self.feed_descriptor(t, frame_descriptor(rgb) if diver_in_view
                                    else np.full(FRAME_FEATURES, np.nan))

    def takes(self, t: float) -> bool:
        """Whether a picture at ``t`` (s) is one the classifier's frame rate takes."""
        period = 1.0 / self.classifier.rate_hz
        return not self._frames or t >= self._frames[-1][0] + period - 1e-6

    def feed_descriptor(self, t: float, descriptor: NDArray[np.float64]
                        ) -> list[RecognizedSignal]:
        """:meth:`feed` with the picture's :func:`frame_descriptor` already computed."""
        if not self.takes(t):
            return []
        self._frames.append((t, descriptor))
        self._frames = [(ti, d) for ti, d in self._frames if ti > t - self.classifier.window_s]
        if t < self._next_t or len(self._frames) < self.classifier.window_frames - 1:
            return []
        self._next_t = t + self.hop_s
        features = window_features(np.array([d for _, d in self._frames]),
                                   self.classifier.rate_hz)
        self._last = [*self._last, self.classifier.classify(features)][-self.votes:]
        name, confidence = self._last[-1]
        in_view = not np.isnan(descriptor[0])  # no diver in this picture: nobody to obey
        said = in_view and name != NONE and len(self._last) == self.votes and all(
            c == name and p >= self.min_confidence for c, p in self._last)
        if not said or t < self._quiet_until:
            return []
        self._quiet_until = t + self.classifier.window_s
        command = class_command(name, self.gestures)
        if command is None:
            return []
        return [RecognizedSignal(command, "gesture", confidence, t)]
