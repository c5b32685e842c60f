"""Statistics of 8-bit fan images with label images: what tells a simulated frame from a
real one (issue 14; the numbers of real frames are in ``docs/sonar.md``).

Per frame, over the in-fan pixels:

* background speckle contrast: std/mean of the background pixels (label 0);
* object/background: mean of the object pixels (label > 0) over the background mean;
* the fraction of in-fan pixels that are exactly 0;
* brightness profiles of the background against range (distance from the apex) and
  bearing, each relative to the frame's background mean.

Images follow the display convention of ``docs/conventions.md`` for fans: apex at the
bottom centre of the image, forward up. Label images hold 0 for background (floor,
water, shadow) and a positive id per object. :func:`load_frames` reads a folder of
``*_fan.png`` / ``*_labels.png`` pairs (labels as 8- or 16-bit PNG), with an optional
``fan_mask.png`` (non-zero inside the fan); without it the fan is the set of pixels that
are non-zero in some frame.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError


@dataclass(frozen=True)
class FrameStats:
    """Statistics of one frame (see the module docstring)."""

    background_cv: float
    object_ratio: float | None  # None: no object pixel in the fan
    zero_fraction: float
    in_fan_px: int
    object_px: int


def frame_stats(
    fan: NDArray[np.uint8], labels: NDArray[np.integer], mask: NDArray[np.bool_]
) -> FrameStats:
    """Statistics of one 8-bit fan image with its label image over the pixels of ``mask``."""
    if fan.shape != labels.shape or fan.shape != mask.shape:
        raise ConfigError(
            f"fan {fan.shape}, labels {labels.shape} and mask {mask.shape} differ in shape",
            where="sonar-stats",
        )
    v = fan[mask].astype(np.float64)
    lab = labels[mask]
    bg = v[lab == 0]
    obj = v[lab > 0]
    bg_mean = float(bg.mean()) if bg.size else float("nan")
    cv = float(bg.std() / bg_mean) if bg.size and bg_mean > 0 else float("nan")
    ratio = float(obj.mean() / bg_mean) if obj.size and bg_mean > 0 else None
    zero = float(np.count_nonzero(v == 0) / max(v.size, 1))
    return FrameStats(cv, ratio, zero, int(v.size), int(obj.size))


def apex_polar_coordinates(
    shape: tuple[int, int],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(range in pixels from the apex, bearing in degrees, > 0 right) of every pixel of a
    fan image whose apex is at the bottom centre."""
    h, w = shape
    cols = np.arange(w) - (w - 1) / 2.0
    rows = (h - 0.5) - np.arange(h)
    x, y = np.meshgrid(cols, rows)
    return np.hypot(x, y), np.degrees(np.arctan2(x, y))


def brightness_profile(
    fans: list[NDArray[np.uint8]],
    labels: list[NDArray[np.integer]],
    mask: NDArray[np.bool_],
    coordinate: NDArray[np.float64],
    n_bins: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Background brightness against ``coordinate`` (per pixel), over all frames, relative
    to the overall background mean: (bin centres, relative mean; NaN in empty bins)."""
    c = coordinate[mask]
    edges = np.linspace(c.min(), c.max(), n_bins + 1)
    which = np.clip(np.digitize(c, edges) - 1, 0, n_bins - 1)
    sums = np.zeros(n_bins)
    counts = np.zeros(n_bins)
    for fan, lab in zip(fans, labels, strict=True):
        bg = lab[mask] == 0
        sums += np.bincount(which[bg], weights=fan[mask][bg].astype(np.float64), minlength=n_bins)
        counts += np.bincount(which[bg], minlength=n_bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
        rel = mean / (sums.sum() / counts.sum())
    return 0.5 * (edges[:-1] + edges[1:]), rel


def image_stats(
    fans: list[NDArray[np.uint8]],
    labels: list[NDArray[np.integer]],
    mask: NDArray[np.bool_],
    n_range_bins: int = 20,
    n_bearing_bins: int = 15,
    px_per_m: float | None = None,
) -> dict:
    """Per-frame statistics, their medians over the frames and the range and bearing
    profiles of the background (a JSON-ready dict; ranges in pixels from the apex and,
    with the fans' ``px_per_m``, in metres; bearings in degrees)."""
    if not fans:
        raise ConfigError("no frames", where="sonar-stats")
    frames = [frame_stats(f, lab, mask) for f, lab in zip(fans, labels, strict=True)]
    ratios = [f.object_ratio for f in frames if f.object_ratio is not None]
    rng, brg = apex_polar_coordinates(mask.shape)
    r_c, r_prof = brightness_profile(fans, labels, mask, rng, n_range_bins)
    b_c, b_prof = brightness_profile(fans, labels, mask, brg, n_bearing_bins)

    def clean(a: NDArray[np.float64]) -> list[float | None]:
        return [None if not math.isfinite(x) else round(float(x), 4) for x in a]

    return {
        "frames": len(frames),
        "median_background_cv": float(np.median([f.background_cv for f in frames])),
        "median_object_ratio": float(np.median(ratios)) if ratios else None,
        "frames_with_objects": len(ratios),
        "median_zero_fraction": float(np.median([f.zero_fraction for f in frames])),
        "max_zero_fraction": float(max(f.zero_fraction for f in frames)),
        "range_profile": {"range_px": clean(r_c), "relative_brightness": clean(r_prof)}
        | ({} if px_per_m is None else {"range_m": clean(r_c / px_per_m)}),
        "bearing_profile": {"bearing_deg": clean(b_c), "relative_brightness": clean(b_prof)},
        "per_frame": [
            {
                "background_cv": round(f.background_cv, 4),
                "object_ratio": None if f.object_ratio is None else round(f.object_ratio, 4),
                "zero_fraction": round(f.zero_fraction, 6),
                "object_px": f.object_px,
            }
            for f in frames
        ],
    }


def object_label_image(label_fan: NDArray[np.int16], background: set[int]) -> NDArray[np.uint16]:
    """A simulated label image in the convention above: 0 for no return and for the
    ``background`` scene labels (e.g. the sea floor), scene label id + 1 for objects."""
    out = label_fan.astype(np.int32) + 1
    out[label_fan < 0] = 0
    for b in background:
        out[label_fan == b] = 0
    return out.astype(np.uint16)


#: The file beside fan images that gives their scale: ``{"px_per_m": ...}``.
GEOMETRY_FILE = "fan_geometry.json"


def write_fan_geometry(folder: Path, ping) -> Path:
    """Write :data:`GEOMETRY_FILE` for the fans of ``ping``'s sonar into ``folder``; where
    fans of another scale were written there before, ``px_per_m`` becomes null (ranges
    then stay in pixels)."""
    path = Path(folder) / GEOMETRY_FILE
    scale: float | None = float(ping.fan_px_per_m)
    if path.is_file() and load_px_per_m(folder) != scale:
        scale = None
    path.write_text(json.dumps({"px_per_m": scale}) + "\n")
    return path


def load_px_per_m(folder: Path) -> float | None:
    """The fans' pixels per metre from ``folder``'s :data:`GEOMETRY_FILE`, None without
    one; a one-line error when it is unreadable."""
    path = Path(folder) / GEOMETRY_FILE
    if not path.is_file():
        return None
    try:
        value = json.loads(path.read_text())["px_per_m"]
        if value is None:  # fans of several scales
            return None
        value = float(value)
    except (ValueError, KeyError, TypeError) as error:
        raise ConfigError(f"not a fan geometry file ({error})", where=str(path)) from None
    if not (math.isfinite(value) and value > 0):
        raise ConfigError(f"px_per_m must be > 0, got {value!r}", where=str(path))
    return value


def load_frames(
    folder: Path,
) -> tuple[list[NDArray[np.uint8]], list[NDArray[np.integer]], NDArray[np.bool_]]:
    """Read ``*_fan.png`` / ``*_labels.png`` pairs and the optional ``fan_mask.png`` from
    ``folder`` (module docstring); ConfigError naming the file when something is off."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ConfigError(f"{folder} is not a folder", where="sonar-stats DIR")
    fan_paths = sorted(folder.glob("*_fan.png"))
    if not fan_paths:
        raise ConfigError(f"no *_fan.png images in {folder}", where="sonar-stats DIR")
    fans, labels = [], []
    for path in fan_paths:
        lab_path = path.with_name(path.name[: -len("_fan.png")] + "_labels.png")
        fan = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        lab = cv2.imread(str(lab_path), cv2.IMREAD_UNCHANGED) if lab_path.is_file() else None
        if fan is None:
            raise ConfigError("not a readable image", where=str(path))
        if lab is None:
            raise ConfigError("missing or unreadable label image", where=str(lab_path))
        if lab.ndim != 2:
            raise ConfigError("label image must have one channel", where=str(lab_path))
        fans.append(fan)
        labels.append(lab)
    mask_path = folder / "fan_mask.png"
    if mask_path.is_file():
        m = cv2.imread(str(mask_path), cv2.IMREAD_GRAYSCALE)
        if m is None:
            raise ConfigError("not a readable image", where=str(mask_path))
        mask = m > 0
    else:
        mask = np.logical_or.reduce([f > 0 for f in fans])
    return fans, labels, mask
