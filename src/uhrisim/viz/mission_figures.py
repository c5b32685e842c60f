"""Figures of a mission: x-y tracks (paper Fig. 19), range/bearing to the target, sonar strip."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from uhrisim.viz.fan_plot import FanView, crop_window, draw_fan, level_bar
from uhrisim.viz.figures import save_figure, subplots


def plot_tracks(series: dict[str, np.ndarray], follower: str, target: str, path: Path,
                acquired_at: float | None = None) -> Path:
    """x-y tracks, east to the right and north up (MOOS x-y), like the paper's Fig. 19."""
    f, g, t = series["follower_ned"], series["target_ned"], series["t"]
    fig, ax = subplots(figsize=(6.5, 6))
    ax.plot(g[:, 1], g[:, 0], color="tab:orange", lw=1.5, label=f"{target} (diver)")
    ax.plot(f[:, 1], f[:, 0], color="tab:blue", lw=1.0, label=f"{follower} (ROV)")
    ax.plot(g[0, 1], g[0, 0], "o", color="tab:orange", ms=7)
    ax.plot(f[0, 1], f[0, 0], "o", color="tab:blue", ms=7)
    ax.annotate("start", (f[0, 1], f[0, 0]), textcoords="offset points", xytext=(6, 6))
    if acquired_at is not None:
        i = int(np.searchsorted(t, acquired_at))
        ax.plot(f[i, 1], f[i, 0], "k*", ms=11, label=f"trail acquired (t={acquired_at:.0f} s)")
    ax.set_xlabel("east (m)  [MOOS x]")
    ax.set_ylabel("north (m)  [MOOS y]")
    ax.set_title("Track and trail: x-y tracks (paper Fig. 19)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.4)
    ax.legend(loc="best", fontsize=8)
    return save_figure(fig, path)


def plot_range_bearing(series: dict[str, np.ndarray], trail_range: float, path: Path,
                       acquired_at: float | None = None) -> Path:
    """Range to the target and bearing error over time."""
    t = series["t"]
    fig, (ax1, ax2) = subplots(2, 1, figsize=(7, 5), sharex=True)
    ax1.plot(t, series["range"], lw=1.0)
    ax1.axhline(trail_range, color="k", ls="--", lw=0.8, label=f"trail range {trail_range} m")
    ax1.set_ylabel("range to diver (m)")
    ax1.legend(fontsize=8)
    ax1.grid(True, alpha=0.4)
    ax2.plot(t, series["bearing_error"], lw=1.0, color="tab:green")
    ax2.axhline(0.0, color="k", ls="--", lw=0.8)
    ax2.set_ylabel("bearing error (deg)")
    ax2.set_xlabel("time (s)")
    ax2.grid(True, alpha=0.4)
    for ax in (ax1, ax2):
        if acquired_at is not None:
            ax.axvline(acquired_at, color="tab:red", lw=0.8)
    return save_figure(fig, path)


def plot_sonar_strip(rows: Mapping[str, Sequence[tuple[float, FanView,
                                                     tuple[float, float] | None]]],
                     path: Path) -> Path:
    """A row of fan images per sonar, each cropped to the diver (a 5 m square about it,
    :func:`crop_window`; the whole fan when the diver is out of range), with metric axes,
    range arcs, bearing lines and the display level's colour bar; ``rows`` maps each
    row's title (e.g. ``"videoray/sonar (P900-45)"``) to its ``(t, fan, diver's
    (starboard, forward) m or None)``."""
    n = max(1, *(len(frames) for frames in rows.values()))
    fig, axes = subplots(len(rows), n, figsize=(3.6 * n, 3.9 * len(rows)), squeeze=False,
                         layout="constrained")
    for row, (title, frames) in zip(axes, rows.items(), strict=True):
        for k, (ax, (t, view, target)) in enumerate(zip(row, frames, strict=False)):
            image = draw_fan(ax, view, window=crop_window(view, target), colorbar=False)
            where = "" if target is None else \
                f", diver {math.hypot(*target):.1f} m {math.degrees(math.atan2(*target)):+.0f}°"
            if target is not None:
                ax.plot(*target, "+", color="tab:cyan", ms=10, mew=1.2)
            ax.set_title(f"t = {t:.0f} s{where}", fontsize=9)
            if k:
                ax.set_ylabel("")
        for ax in row[len(frames):]:
            ax.axis("off")
        row[0].set_ylabel(f"{title}\nforward (m)", fontsize=9)
        level_bar(image, list(row))
    fig.suptitle("sonar fans about the diver (+: its true place)", fontsize=10)
    return save_figure(fig, path)
