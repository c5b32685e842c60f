"""How far one folder of 8-bit sonar frames is from another, measure by measure
(``uhrisim sonar-compare REAL SIM``; formulas and references in ``docs/sonar.md``).

Frames are fan images with the apex at the bottom centre, forward up (the display
convention of ``docs/conventions.md``). A folder holds ``*.png`` frames (only its
``*_fan.png`` if it has any, as ``uhrisim figure sonar-tank`` writes them beside other
images), optionally each
with an object mask ``<frame>_labels.png`` or ``<frame>_mask.png`` (non-zero: an object;
for ``<stem>_fan.png`` also ``<stem>_labels.png``, as ``uhrisim figure sonar-tank``
writes them) and optionally one ``fan_mask.png`` (non-zero inside the fan). Without a
fan mask the fan is the geometry's (field of view and range window) or, without that, the
pixels non-zero in some frame.

The measures, each per folder (pooled over its frames) and then REAL against SIM:

* intensity histograms of the in-fan pixels: Kullback–Leibler and Jensen–Shannon
  divergences (bits) and the earth mover's distance (grey levels);
* texture: histograms of rotation-invariant uniform local binary patterns (LBP, 8
  neighbours at radius 1), their Jensen–Shannon divergence;
* speckle: the background pixels divided by their local mean, taken as amplitude: the
  Rayleigh fit (scale of the raw values, Kolmogorov–Smirnov statistic) and the
  K-distribution fit (shape ν from log moments, KS statistic);
* speckle grain: the half-maximum width of the background's autocorrelation along range
  and across bearing, on the fan resampled to range × bearing, in metres (or pixels)
  and degrees, and in resolution cells (divided by the pulse's range resolution and the
  beam width) when the geometry gives them;
* brightness of the background across the fan and along range (relative to its mean);
* object-to-background contrast (with object masks);
* the fractions of in-fan pixels at exactly 0 and at 255.

Every measure gets a verdict from the spread of REAL itself: its even and odd frames are
compared the same way (the split-half baseline b); a SIM difference d is a "match" when
d ≤ max(2b, floor), "close" when d ≤ max(5b, 3·floor), else "differs" (floors per measure
in :data:`FLOORS`). A folder against itself gives d = 0 on every measure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import optimize, special

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.presets import get_preset

#: Files in a frame folder that are not frames.
_MASK_SUFFIXES = ("_labels.png", "_mask.png")
FAN_MASK_NAME = "fan_mask.png"
#: Sides of the boxes (pixels) of the local means the speckle measures divide by: the
#: speckle's distribution (trends out), and its grain (a box many grains wide, so that
#: dividing by it does not narrow the autocorrelation).
LOCAL_MEAN_PX = 31
GRAIN_MEAN_PX = 95
#: The grain is measured near the fan's centre line (|bearing| ≤ this, degrees), where a
#: fan image's columns run along range and its rows across; across bearing over the far
#: part of the fan (range ≥ GRAIN_FAR_FRACTION of the fan's), where pixels resolve most.
GRAIN_SECTOR_DEG = 15.0
GRAIN_FAR_FRACTION = 0.6
#: Bins of the brightness profiles across the fan and along range.
BEARING_BINS, RANGE_BINS = 15, 20
#: Lags (samples) of the autocorrelation searched for its half maximum.
MAX_LAG = 60
#: Absolute floors of the verdicts (module docstring): a difference this small matches
#: whatever the baseline; the units are each measure's own.
FLOORS = {
    "kl_divergence_bits": 0.02,
    "js_divergence_bits": 0.005,
    "emd_grey_levels": 1.0,
    "lbp_js_divergence_bits": 0.002,
    "rayleigh_scale": 0.03,
    "ks_rayleigh": 0.01,
    "k_shape_log": 0.1,
    "ks_k": 0.01,
    "grain_range": 0.05,
    "grain_bearing": 0.05,
    "bearing_profile_rms": 0.02,
    "range_profile_rms": 0.02,
    "object_contrast": 0.05,
    "zero_fraction": 0.001,
    "saturated_fraction": 0.001,
}


@dataclass(frozen=True)
class FanGeometry:
    """What is known of the sonar that made a folder: field of view (deg), range window
    (m, None: unknown, then range quantities stay in pixels), beam width (deg) and the
    pulse's range resolution (m) for the grain in resolution cells (None: unknown)."""

    fov_deg: float | None = None
    range_m: tuple[float, float] | None = None
    beam_width_deg: float | None = None
    range_resolution_m: float | None = None

    @staticmethod
    def from_preset(name: str, range_m: tuple[float, float] | None = None) -> FanGeometry:
        """A preset's field of view, beam width and range resolution (the range window
        is the frames', given or unknown)."""
        spec = get_preset(name)
        return FanGeometry(spec.fov_h_deg, range_m, spec.beam_width_h_deg,
                           spec.range_resolution_m)  # fmt: skip


@dataclass
class FrameSet:
    """A folder's frames (8-bit), their object masks (None: none given), the fan mask."""

    frames: list[NDArray[np.uint8]]
    objects: list[NDArray[np.bool_]] | None
    fan: NDArray[np.bool_]
    names: list[str] = field(default_factory=list)

    def subset(self, every: int, start: int) -> FrameSet:
        """Every ``every``-th frame from ``start`` (the split halves of the baseline)."""
        objects = None if self.objects is None else self.objects[start::every]
        return FrameSet(self.frames[start::every], objects, self.fan, self.names[start::every])

    def background(self, i: int) -> NDArray[np.bool_]:
        """In-fan pixels of frame ``i`` that are not objects."""
        return self.fan if self.objects is None else self.fan & ~self.objects[i]


def _read(path: Path, flags: int) -> NDArray:
    image = cv2.imread(str(path), flags)
    if image is None:
        raise ConfigError("not a readable image", where=str(path))
    return image


def load_frame_set(folder: Path, geometry: FanGeometry | None = None) -> FrameSet:
    """The frames, object masks and fan mask of ``folder`` (module docstring);
    ConfigError naming the file or folder when something is off."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ConfigError(f"{folder} is not a folder", where="sonar-compare")
    paths = sorted(folder.glob("*_fan.png")) or sorted(
        p for p in folder.glob("*.png")
        if p.name != FAN_MASK_NAME and not p.name.endswith(_MASK_SUFFIXES))  # fmt: skip
    if not paths:
        raise ConfigError(f"no *.png frames in {folder}", where="sonar-compare")
    frames, masks = [], []
    for path in paths:
        frame = _read(path, cv2.IMREAD_UNCHANGED)
        if frame.ndim != 2 or frame.dtype != np.uint8:
            raise ConfigError("must be an 8-bit single-channel image", where=str(path))
        if frames and frame.shape != frames[0].shape:
            (h, w), (h0, w0) = frame.shape, frames[0].shape
            raise ConfigError(f"is {w}×{h} px, the folder's first frame {w0}×{h0}",
                              where=str(path))  # fmt: skip
        frames.append(frame)
        stem = path.name[: -len("_fan.png")] if path.name.endswith("_fan.png") else path.stem
        candidates = [path.with_name(path.stem + s) for s in _MASK_SUFFIXES]
        candidates.append(path.with_name(stem + "_labels.png"))
        found = next((c for c in candidates if c.is_file()), None)
        masks.append(None if found is None else _read(found, cv2.IMREAD_UNCHANGED))
    given = [m for m in masks if m is not None]
    if given and len(given) != len(masks):
        missing = next(p for p, m in zip(paths, masks, strict=True) if m is None)
        raise ConfigError("has no object mask while other frames have one", where=str(missing))
    for path, m in zip(paths, masks, strict=True):
        if m is not None and m.shape[:2] != frames[0].shape:
            raise ConfigError("object mask is not the frame's size", where=str(path))
    objects = [np.asarray(m).reshape(frames[0].shape) > 0 for m in masks] if given else None
    fan_path = folder / FAN_MASK_NAME
    if fan_path.is_file():
        fan = _read(fan_path, cv2.IMREAD_GRAYSCALE) > 0
        if fan.shape != frames[0].shape:
            raise ConfigError("fan mask is not the frames' size", where=str(fan_path))
    elif geometry is not None and geometry.fov_deg is not None:
        fan = geometry_fan_mask(frames[0].shape, geometry)
    else:
        fan = np.logical_or.reduce([f > 0 for f in frames])
    if not fan.any():
        raise ConfigError("the fan is empty (every pixel 0)", where=str(folder))
    return FrameSet(frames, objects, fan, [p.name for p in paths])


# -- fan coordinates ------------------------------------------------------------------------------


def apex_coordinates(shape: tuple[int, int]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(range from the apex in pixels, bearing in degrees, > 0 right) of every pixel of a
    fan image with its apex at the bottom centre."""
    h, w = shape
    x, y = np.meshgrid(np.arange(w) - (w - 1) / 2.0, (h - 0.5) - np.arange(h))
    return np.hypot(x, y), np.degrees(np.arctan2(x, y))


def geometry_fan_mask(shape: tuple[int, int], geometry: FanGeometry) -> NDArray[np.bool_]:
    """The fan of ``geometry`` in an image of ``shape``: its field of view, and its range
    window when known (the image's top at the window's far end, as the fan is drawn)."""
    r, bearing = apex_coordinates(shape)
    inside = np.abs(bearing) <= 0.5 * float(geometry.fov_deg)
    if geometry.range_m is not None:
        near, far = geometry.range_m
        scale = shape[0] / far
        inside &= (r >= near * scale) & (r <= far * scale)
    return inside


def _fan_extent(fs: FrameSet) -> tuple[float, float]:
    """(half the field of view in degrees, the fan's far range in pixels) of a fan mask."""
    r, bearing = apex_coordinates(fs.fan.shape)
    return float(np.abs(bearing[fs.fan]).max()), float(r[fs.fan].max())


# -- the measures on one folder -----------------------------------------------------------------


def intensity_histogram(fs: FrameSet) -> NDArray[np.float64]:
    """Normalised 256-bin histogram of the in-fan pixels of every frame."""
    counts = sum(np.bincount(f[fs.fan], minlength=256) for f in fs.frames)
    return counts / counts.sum()


def lbp_riu2(image: NDArray[np.uint8]) -> NDArray[np.int64]:
    """Rotation-invariant uniform LBP codes (P = 8, R = 1; Ojala, Pietikäinen & Mäenpää
    2002): the 8 neighbours on a unit circle (diagonals bilinearly interpolated) thresholded
    at the centre; a pattern with at most 2 0/1 transitions around the circle gets its
    number of ones (0…8), any other 9. Border pixels get −1."""
    g = image.astype(np.float64)
    h, w = g.shape
    c = g[1:-1, 1:-1]
    d = math.sqrt(0.5)

    def at(dy: float, dx: float) -> NDArray[np.float64]:
        """The image sampled at offset (dy, dx) from each interior pixel (bilinear)."""
        y0, x0 = math.floor(dy), math.floor(dx)
        fy, fx = dy - y0, dx - x0
        out = np.zeros_like(c)
        for oy, wy in ((y0, 1 - fy), (y0 + 1, fy)):
            for ox, wx in ((x0, 1 - fx), (x0 + 1, fx)):
                if wy * wx > 0:
                    out += wy * wx * g[1 + oy : h - 1 + oy, 1 + ox : w - 1 + ox]
        return out

    offsets = [(0, 1), (-d, d), (-1, 0), (-d, -d), (0, -1), (d, -d), (1, 0), (d, d)]
    bits = np.stack([at(dy, dx) >= c - 1e-9 for dy, dx in offsets]).astype(np.int64)
    transitions = np.sum(bits != np.roll(bits, 1, axis=0), axis=0)
    code = np.where(transitions <= 2, bits.sum(axis=0), 9)
    out = np.full((h, w), -1, np.int64)
    out[1:-1, 1:-1] = code
    return out


def lbp_histogram(fs: FrameSet) -> NDArray[np.float64]:
    """Normalised 10-bin histogram of the LBP codes of the pixels whose whole 3×3
    neighbourhood is in the fan, over every frame."""
    inner = cv2.erode(fs.fan.astype(np.uint8), np.ones((3, 3), np.uint8),
                      borderType=cv2.BORDER_CONSTANT, borderValue=0) > 0  # fmt: skip
    counts = sum(np.bincount(lbp_riu2(f)[inner], minlength=10) for f in fs.frames)
    return counts / counts.sum()


def local_mean(
    values: NDArray[np.float64], valid: NDArray[np.bool_], side: int = LOCAL_MEAN_PX
) -> NDArray[np.float64]:
    """Mean of ``values`` over the valid pixels of a ``side``-pixel box around each pixel
    (normalised convolution)."""
    box = (side, side)
    num = cv2.boxFilter(np.where(valid, values, 0.0), -1, box, normalize=False)
    den = cv2.boxFilter(valid.astype(np.float64), -1, box, normalize=False)
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / den


def normalised_background(
    fs: FrameSet, side: int = LOCAL_MEAN_PX
) -> list[tuple[NDArray[np.float64], NDArray[np.bool_]]]:
    """Per frame: the pixel values over their local background mean (a ``side``-pixel
    box; 1 on average) and where that is defined (background with a non-zero mean)."""
    out = []
    for i, f in enumerate(fs.frames):
        valid = fs.background(i)
        values = f.astype(np.float64)
        mean = local_mean(values, valid, side)
        ok = valid & (mean > 0)
        out.append((np.where(ok, values / np.where(ok, mean, 1.0), 0.0), ok))
    return out


def rayleigh_fit(amplitude: NDArray[np.float64], discrete: bool) -> tuple[float, float]:
    """(scale σ, KS statistic) of the Rayleigh law p(a) = a/σ²·exp(−a²/2σ²) fitted by
    maximum likelihood, σ² = Σa²/(2N). ``discrete``: 8-bit values, compared with the law's
    CDF at v + ½ (continuity correction)."""
    a = np.sort(amplitude.ravel())
    sigma = math.sqrt(float(np.mean(a * a)) / 2.0)
    return sigma, ks_statistic(a, lambda x: -np.expm1(-x * x / (2.0 * sigma * sigma)), discrete)


def k_shape(intensity: NDArray[np.float64]) -> float:
    """Shape ν of a K-distributed intensity from its log moments (Blacknell & Tough):
    E[ln I] − ln E[I] = ψ(ν) − ln ν − γ, solved for ν (∞ when the data are no heavier than
    exponential: Rayleigh amplitude)."""
    i = intensity[intensity > 0]
    target = float(np.mean(np.log(i)) - math.log(float(np.mean(i))))
    gamma_e = 0.5772156649015329

    def f(nu: float) -> float:
        return float(special.digamma(nu) - math.log(nu) - gamma_e - target)

    if f(1e4) < 0.0:  # no heavier than exponential
        return math.inf
    if f(0.05) > 0.0:
        return 0.05
    return float(optimize.brentq(f, 0.05, 1e4, xtol=1e-6))


def k_amplitude_cdf(a: NDArray[np.float64], nu: float, mean_intensity: float) -> NDArray:
    """CDF of the K-distributed amplitude of shape ν and mean intensity μ:
    1 − 2/Γ(ν)·x^(ν/2)·K_ν(2√x), x = ν a²/μ."""
    x = nu * np.asarray(a, float) ** 2 / mean_intensity
    z = 2.0 * np.sqrt(x)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        log_k = np.log(np.maximum(special.kve(nu, z), 1e-300)) - z  # kve = K·e^z
        log_tail = math.log(2.0) - special.gammaln(nu) + 0.5 * nu * np.log(x) + log_k
    return np.where(x > 0, -np.expm1(log_tail), 0.0)


def ks_statistic(sorted_values: NDArray[np.float64], cdf, discrete: bool) -> float:
    """Kolmogorov–Smirnov statistic of sorted samples against ``cdf``; for integer-valued
    samples the empirical CDF's steps are compared with the law at v + ½."""
    x = sorted_values
    n = x.size
    if discrete:
        levels, counts = np.unique(x, return_counts=True)
        emp = np.cumsum(counts) / n
        return float(np.max(np.abs(emp - cdf(levels + 0.5))))
    f = cdf(x)
    return float(max(np.max(np.arange(1, n + 1) / n - f), np.max(f - np.arange(n) / n)))


def speckle_statistics(fs: FrameSet) -> dict[str, float]:
    """Rayleigh scale of the raw background values and, on the locally normalised
    amplitudes, the Rayleigh KS statistic, the K shape ν and its KS statistic."""
    raw = np.concatenate([f[fs.background(i)].astype(np.float64)
                          for i, f in enumerate(fs.frames)])  # fmt: skip
    sigma, _ = rayleigh_fit(raw, discrete=True)
    a = np.concatenate([v[ok] for v, ok in normalised_background(fs)])
    a = a[a > 0]
    rng = np.random.default_rng(0)  # the KS statistic on ≤ 200 k samples (deterministic)
    if a.size > 200_000:
        a = rng.choice(a, 200_000, replace=False)
    _, ks_r = rayleigh_fit(a, discrete=False)
    nu = k_shape(a * a)
    mu = float(np.mean(a * a))
    ks_k = ks_r if not math.isfinite(nu) else ks_statistic(
        np.sort(a), lambda x: k_amplitude_cdf(x, nu, mu), discrete=False)  # fmt: skip
    return {"rayleigh_scale": sigma, "ks_rayleigh": ks_r, "k_shape": nu, "ks_k": ks_k}


def autocorrelation(
    fields: list[NDArray[np.float64]], valid: list[NDArray[np.bool_]], axis: int
) -> NDArray[np.float64]:
    """Normalised autocorrelation of the zero-mean ``fields`` along ``axis`` at lags
    0…MAX_LAG, over the pairs of valid samples."""
    num = np.zeros(MAX_LAG + 1)
    den = np.zeros(MAX_LAG + 1)
    for f, v in zip(fields, valid, strict=True):
        mean = f[v].mean() if v.any() else 0.0
        g = np.where(v, f - mean, 0.0)
        for lag in range(MAX_LAG + 1):
            a = np.take(g, range(0, g.shape[axis] - lag), axis=axis)
            b = np.take(g, range(lag, g.shape[axis]), axis=axis)
            va = np.take(v, range(0, v.shape[axis] - lag), axis=axis)
            vb = np.take(v, range(lag, v.shape[axis]), axis=axis)
            both = va & vb
            num[lag] += float((a * b)[both].sum())
            den[lag] += float(both.sum())
    var = num[0] / max(den[0], 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (num / np.maximum(den, 1.0)) / var


def half_width(acf: NDArray[np.float64]) -> float:
    """Full width at half maximum (samples) of a normalised autocorrelation, linearly
    interpolated between lags (NaN when it never falls to one half)."""
    below = np.flatnonzero(acf < 0.5)
    if below.size == 0:
        return math.nan
    m = int(below[0])
    return 2.0 * ((m - 1) + (acf[m - 1] - 0.5) / (acf[m - 1] - acf[m]))


def speckle_grain(fs: FrameSet) -> dict[str, object]:
    """The grain's half-maximum widths along range (px) and across bearing (deg): the
    autocorrelation of the locally normalised background near the fan's centre line
    (|bearing| ≤ GRAIN_SECTOR_DEG), down the image's columns (along range) and along its
    rows (across) over the fan's far part, whose pixel lags are turned into degrees at
    the mean range of the pixels used."""
    norm = normalised_background(fs, GRAIN_MEAN_PX)
    r, bearing = apex_coordinates(fs.fan.shape)
    _, far = _fan_extent(fs)
    sector = np.abs(bearing) <= GRAIN_SECTOR_DEG
    outer = sector & (r >= GRAIN_FAR_FRACTION * far)
    fields = [v for v, _ in norm]
    acf_range = autocorrelation(fields, [ok & sector for _, ok in norm], axis=0)
    acf_bearing = autocorrelation(fields, [ok & outer for _, ok in norm], axis=1)
    used = np.any([ok & outer for _, ok in norm], axis=0)
    deg_per_px = math.degrees(1.0 / float(r[used].mean())) if used.any() else math.nan
    return {
        "range_px": half_width(acf_range), "bearing_deg": half_width(acf_bearing) * deg_per_px,
        "acf_range": acf_range, "acf_bearing": acf_bearing,
        "lag_px": 1.0, "lag_deg": deg_per_px,
    }  # fmt: skip


def brightness_profiles(fs: FrameSet) -> dict[str, NDArray[np.float64]]:
    """Background brightness relative to its mean against normalised bearing (−1…1, the
    fan's edges) and normalised range (0…1, the fan's far end): bin centres and values."""
    r, bearing = apex_coordinates(fs.fan.shape)
    half, far = _fan_extent(fs)
    out: dict[str, NDArray[np.float64]] = {}
    for key, coordinate, lo, hi, n in (("bearing", bearing / half, -1.0, 1.0, BEARING_BINS),
                                       ("range", r / far, 0.0, 1.0, RANGE_BINS)):  # fmt: skip
        edges = np.linspace(lo, hi, n + 1)
        sums, counts = np.zeros(n), np.zeros(n)
        for i, f in enumerate(fs.frames):
            bg = fs.background(i)
            which = np.clip(np.digitize(coordinate[bg], edges) - 1, 0, n - 1)
            sums += np.bincount(which, weights=f[bg].astype(np.float64), minlength=n)
            counts += np.bincount(which, minlength=n)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[key] = (sums / counts) / (sums.sum() / counts.sum())
        out[key + "_centres"] = 0.5 * (edges[:-1] + edges[1:])
    return out


def object_contrast(fs: FrameSet) -> float | None:
    """Median over frames of mean(object pixels)/mean(background pixels) inside the fan
    (None: no object masks, or no object in any frame)."""
    if fs.objects is None:
        return None
    ratios = []
    for i, f in enumerate(fs.frames):
        obj = fs.objects[i] & fs.fan
        bg = fs.background(i)
        if obj.any() and bg.any() and f[bg].mean() > 0:
            ratios.append(float(f[obj].mean() / f[bg].mean()))
    return float(np.median(ratios)) if ratios else None


def pixel_fractions(fs: FrameSet) -> tuple[float, float]:
    """(fraction of in-fan pixels exactly 0, fraction exactly 255), over every frame."""
    n = zero = full = 0
    for f in fs.frames:
        v = f[fs.fan]
        n += v.size
        zero += int(np.count_nonzero(v == 0))
        full += int(np.count_nonzero(v == 255))
    return zero / n, full / n


@dataclass
class FolderStatistics:
    """Everything measured on one folder (module docstring)."""

    histogram: NDArray[np.float64]
    lbp: NDArray[np.float64]
    speckle: dict[str, float]
    grain: dict[str, object]
    profiles: dict[str, NDArray[np.float64]]
    contrast: float | None
    zero_fraction: float
    saturated_fraction: float
    frames: int


def folder_statistics(fs: FrameSet) -> FolderStatistics:
    """The measures of one folder."""
    zero, full = pixel_fractions(fs)
    return FolderStatistics(intensity_histogram(fs), lbp_histogram(fs), speckle_statistics(fs),
                            speckle_grain(fs), brightness_profiles(fs), object_contrast(fs),
                            zero, full, len(fs.frames))  # fmt: skip


# -- divergences and differences ----------------------------------------------------------------


def kl_divergence(p: NDArray[np.float64], q: NDArray[np.float64], eps: float = 1e-6) -> float:
    """Kullback–Leibler divergence D(p‖q) in bits, both smoothed by ``eps`` per bin (an
    empty bin of q would make it infinite) and renormalised."""
    p = (p + eps) / (p + eps).sum()
    q = (q + eps) / (q + eps).sum()
    return float(np.sum(p * np.log2(p / q)))


def js_divergence(p: NDArray[np.float64], q: NDArray[np.float64]) -> float:
    """Jensen–Shannon divergence in bits (0 … 1): ½D(p‖m) + ½D(q‖m), m = (p + q)/2."""
    m = 0.5 * (p + q)

    def d(a: NDArray[np.float64]) -> float:
        nz = a > 0
        return float(np.sum(a[nz] * np.log2(a[nz] / m[nz])))

    return max(0.5 * d(p) + 0.5 * d(q), 0.0)


def emd_levels(p: NDArray[np.float64], q: NDArray[np.float64]) -> float:
    """Earth mover's distance between two histograms over unit-spaced levels (grey
    levels): Σ |CDF_p − CDF_q| (the 1-D Wasserstein-1 distance)."""
    return float(np.sum(np.abs(np.cumsum(p) - np.cumsum(q))))


def _profile_rms(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    both = np.isfinite(a) & np.isfinite(b)
    return float(np.sqrt(np.mean((a[both] - b[both]) ** 2))) if both.any() else math.nan


def _relative(a: float | None, b: float | None) -> float:
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return math.nan
    return abs(a - b) / abs(b)


def _log_ratio(a: float, b: float) -> float:
    """|ln(a/b)| with ∞ shapes (Rayleigh) capped at 100."""
    a, b = min(a, 100.0), min(b, 100.0)
    return abs(math.log(a / b))


def differences(
    a: FolderStatistics, b: FolderStatistics, units_a: dict[str, float], units_b: dict[str, float]
) -> dict:
    """The difference of every measure between two folders' statistics (units in
    ``docs/sonar.md``; ``units_a``/``units_b`` divide each folder's grain widths into
    resolution cells or metres where its geometry gives them)."""
    def grain(stats: FolderStatistics, key: str, units: dict[str, float]) -> float:
        return float(stats.grain[key]) / units[key]

    return {
        "kl_divergence_bits": kl_divergence(b.histogram, a.histogram),
        "js_divergence_bits": js_divergence(a.histogram, b.histogram),
        "emd_grey_levels": emd_levels(a.histogram, b.histogram),
        "lbp_js_divergence_bits": js_divergence(a.lbp, b.lbp),
        "rayleigh_scale": _relative(a.speckle["rayleigh_scale"], b.speckle["rayleigh_scale"]),
        "ks_rayleigh": abs(a.speckle["ks_rayleigh"] - b.speckle["ks_rayleigh"]),
        "k_shape_log": _log_ratio(a.speckle["k_shape"], b.speckle["k_shape"]),
        "ks_k": abs(a.speckle["ks_k"] - b.speckle["ks_k"]),
        "grain_range": _relative(grain(a, "range_px", units_a), grain(b, "range_px", units_b)),
        "grain_bearing": _relative(
            grain(a, "bearing_deg", units_a), grain(b, "bearing_deg", units_b)
        ),
        "bearing_profile_rms": _profile_rms(a.profiles["bearing"], b.profiles["bearing"]),
        "range_profile_rms": _profile_rms(a.profiles["range"], b.profiles["range"]),
        "object_contrast": _relative(a.contrast, b.contrast),
        "zero_fraction": abs(a.zero_fraction - b.zero_fraction),
        "saturated_fraction": abs(a.saturated_fraction - b.saturated_fraction),
    }


def verdict(difference: float, baseline: float, floor: float) -> str:
    """"match" (≤ max(2b, floor)), "close" (≤ max(5b, 3·floor)), "differs", or "n/a"."""
    if not math.isfinite(difference):
        return "n/a"
    b = baseline if math.isfinite(baseline) else 0.0
    if difference <= max(2.0 * b, floor):
        return "match"
    if difference <= max(5.0 * b, 3.0 * floor):
        return "close"
    return "differs"


def _grain_units(real: FrameSet, geometry: FanGeometry | None) -> tuple[dict, dict]:
    """(divisors of the grain widths, their unit names): pixels → metres with a range
    window, → resolution cells with the pulse's range resolution; degrees → cells with the
    beam width."""
    units = {"range_px": 1.0, "bearing_deg": 1.0}
    names = {"range_px": "px", "bearing_deg": "deg"}
    if geometry is None:
        return units, names
    if geometry.range_m is not None:
        px_per_m = real.fan.shape[0] / geometry.range_m[1]
        units["range_px"], names["range_px"] = px_per_m, "m"
        if geometry.range_resolution_m is not None:
            units["range_px"] = px_per_m * geometry.range_resolution_m
            names["range_px"] = "range resolution cells"
    if geometry.beam_width_deg is not None:
        units["bearing_deg"], names["bearing_deg"] = geometry.beam_width_deg, "beam widths"
    return units, names


def _summary(stats: FolderStatistics, units: dict[str, float]) -> dict[str, float | None]:
    return {
        "frames": stats.frames,
        "rayleigh_scale": stats.speckle["rayleigh_scale"],
        "ks_rayleigh": stats.speckle["ks_rayleigh"],
        "k_shape": stats.speckle["k_shape"] if math.isfinite(stats.speckle["k_shape"]) else None,
        "ks_k": stats.speckle["ks_k"],
        "grain_range": float(stats.grain["range_px"]) / units["range_px"],
        "grain_bearing": float(stats.grain["bearing_deg"]) / units["bearing_deg"],
        "object_contrast": stats.contrast,
        "zero_fraction": stats.zero_fraction,
        "saturated_fraction": stats.saturated_fraction,
    }


def compare_folders(
    real: Path,
    sim: Path,
    geometry: FanGeometry | None = None,
    sim_geometry: FanGeometry | None = None,
) -> tuple[dict, dict]:
    """Compare the frames in ``sim`` with those in ``real`` (module docstring); ``geometry``
    is the sonar of both folders, or of REAL alone when SIM's is ``sim_geometry``.

    Returns (report, curves): the report is JSON-ready — per measure REAL's and SIM's
    values where a measure has one, the difference, REAL's split-half baseline, the floor
    and the verdict; the curves (histograms, LBP histograms, autocorrelations, profiles)
    are what the figure draws."""
    sim_geometry = geometry if sim_geometry is None else sim_geometry
    real_set = load_frame_set(real, geometry)
    sim_set = load_frame_set(sim, sim_geometry)
    real_stats, sim_stats = folder_statistics(real_set), folder_statistics(sim_set)
    units, unit_names = _grain_units(real_set, geometry)
    sim_units, sim_unit_names = _grain_units(sim_set, sim_geometry)
    if sim_unit_names != unit_names:
        raise ConfigError(
            f"REAL's grain is in {unit_names} but SIM's in {sim_unit_names}: give both the "
            "same kind of geometry", where="sonar-compare")
    diff = differences(sim_stats, real_stats, sim_units, units)
    if len(real_set.frames) >= 2:
        halves = [folder_statistics(real_set.subset(2, k)) for k in (0, 1)]
        base = differences(halves[0], halves[1], units, units)
    else:
        base = {k: math.nan for k in diff}
    real_summary, sim_summary = _summary(real_stats, units), _summary(sim_stats, sim_units)
    measures = {}
    for key, d in diff.items():
        entry = {"difference": _clean(d), "real_baseline": _clean(base[key]),
                 "floor": FLOORS[key], "verdict": verdict(d, base[key], FLOORS[key])}  # fmt: skip
        value_key = "k_shape" if key == "k_shape_log" else key
        if value_key in real_summary:
            entry["real"] = _clean(real_summary[value_key])
            entry["sim"] = _clean(sim_summary[value_key])
        measures[key] = entry
    report = {
        "real": str(real), "sim": str(sim),
        "geometry": {"real": _geometry_dict(geometry), "sim": _geometry_dict(sim_geometry)},
        "grain_units": {"range": unit_names["range_px"], "bearing": unit_names["bearing_deg"]},
        "frames": {"real": len(real_set.frames), "sim": len(sim_set.frames)},
        "measures": measures,
        "verdicts": {v: sum(m["verdict"] == v for m in measures.values())
                     for v in ("match", "close", "differs", "n/a")},
    }  # fmt: skip
    curves = {"real": real_stats, "sim": sim_stats, "units": units, "sim_units": sim_units,
              "unit_names": unit_names}  # fmt: skip
    return report, curves


def _geometry_dict(geometry: FanGeometry | None) -> dict | None:
    if geometry is None:
        return None
    return {"fov_deg": geometry.fov_deg, "range_m": geometry.range_m,
            "beam_width_deg": geometry.beam_width_deg,
            "range_resolution_m": geometry.range_resolution_m}  # fmt: skip


def _clean(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(f"{float(x):.6g}")


def report_lines(report: dict) -> list[str]:
    """The report as an aligned text table, one line per measure."""
    head = (f"{'measure':26} {'real':>10} {'sim':>10} {'difference':>11} "
            f"{'real vs real':>13}  verdict")  # fmt: skip
    lines = [f"sonar-compare  REAL {report['real']} ({report['frames']['real']} frames)  "
             f"SIM {report['sim']} ({report['frames']['sim']} frames)",
             f"grain in {report['grain_units']['range']} (range), "
             f"{report['grain_units']['bearing']} (bearing)", head, "-" * len(head)]  # fmt: skip

    def fmt(x: float | None) -> str:
        return "—" if x is None else f"{x:.4g}"

    for key, m in report["measures"].items():
        values = (fmt(m.get("real")), fmt(m.get("sim")), fmt(m["difference"]),
                  fmt(m["real_baseline"]))  # fmt: skip
        lines.append(f"{key:26} {values[0]:>10} {values[1]:>10} {values[2]:>11} "
                     f"{values[3]:>13}  {m['verdict']}")  # fmt: skip
    v = report["verdicts"]
    lines.append(f"verdicts: {v['match']} match, {v['close']} close, {v['differs']} differ, "
                 f"{v['n/a']} n/a")  # fmt: skip
    return lines
