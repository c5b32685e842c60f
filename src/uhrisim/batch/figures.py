"""The sweep's summary figure: each metric against each swept parameter, with 95 % CIs.

For a parameter with few distinct values (a grid, a list) each value is one point: the
mean of the metric over every run with that value (other parameters and seeds pooled)
and its 95 % confidence interval of the mean, mean ± t(0.975, n−1)·s/√n. A parameter with
many values (random draws) is cut into :data:`BINS` bins of equal count first. Text
values (presets, materials) are categories in the order they first appear.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from scipy import stats

from uhrisim.viz.figures import save_figure, subplots

BINS = 6
#: Columns of the table that are bookkeeping, not outcomes.
NOT_METRICS = ("seed", "run_wall_s", "wall_s", "real_time_factor", "simulated_s",
               "trail_range_m", "trail_angle_deg", "completed")
MAX_METRICS = 8
#: Shown first: the headline outcomes of a mission (then RMS errors, then the rest).
HEADLINE = ("time_to_acquire_s", "min_separation_m", "collisions")


def numeric_column(rows: list[dict[str, Any]], name: str) -> np.ndarray | None:
    """The column as floats (None/bool-free numbers; missing -> NaN), or None if it holds
    anything else."""
    values = [row.get(name) for row in rows]
    if not all(v is None or (isinstance(v, int | float) and not isinstance(v, bool))
               for v in values):
        return None
    return np.array([np.nan if v is None else float(v) for v in values])


def mean_ci95(values: np.ndarray) -> tuple[float, float]:
    """(mean, half-width of the 95 % confidence interval of the mean); NaN are left out,
    the half-width is 0 with fewer than two values."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return float("nan"), 0.0
    if v.size < 2:
        return float(v[0]), 0.0
    half = stats.t.ppf(0.975, v.size - 1) * np.std(v, ddof=1) / np.sqrt(v.size)
    return float(np.mean(v)), float(half)


def metric_columns(rows: list[dict[str, Any]], parameters: list[str]) -> list[str]:
    """Numeric outcome columns that vary over the completed runs, headline ones and RMS
    errors first (at most MAX_METRICS)."""
    names = list(dict.fromkeys(k for row in rows for k in row))
    chosen = []
    for name in names:
        if name in parameters or name in NOT_METRICS or name in ("run", "status", "error"):
            continue
        column = numeric_column(rows, name)
        if column is not None and np.isfinite(column).any() and np.nanstd(column) > 0:
            chosen.append(name)
    rank = {name: (0 if name in HEADLINE else 1 if name.endswith(".rms") else 2)
            for name in chosen}
    return sorted(chosen, key=lambda name: rank[name])[:MAX_METRICS]


def _groups(values: list[Any]) -> tuple[list[np.ndarray], list[float], list[str]]:
    """Row indices of each group of a parameter's values, the x of each, its tick label."""
    numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
    distinct = list(dict.fromkeys(values))
    if numeric and len(distinct) > 2 * BINS:
        x = np.array(values, float)
        edges = np.quantile(x, np.linspace(0, 1, BINS + 1))
        which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, BINS - 1)
        groups = [np.flatnonzero(which == b) for b in range(BINS)]
        keep = [i for i, g in enumerate(groups) if g.size]
        return ([groups[i] for i in keep], [float(np.mean(x[groups[i]])) for i in keep],
                [f"{np.mean(x[groups[i]]):.3g}" for i in keep])
    if numeric:
        distinct = sorted(distinct)
    groups = [np.flatnonzero([v == d for v in values]) for d in distinct]
    xs = [float(d) for d in distinct] if numeric else list(map(float, range(len(distinct))))
    return groups, xs, [str(d) for d in distinct]


#: Units by the end of a metric's or parameter's name (the project's naming habit).
UNIT_SUFFIXES = {"_s": "s", "_m": "m", "_deg": "deg", "_pct": "%", "_hz": "Hz", "_mps": "m/s",
                 "_db": "dB"}
#: Words for the last part of a name (what the reader calls it).
WORDS = {"rms": "RMS", "min": "minimum", "max": "maximum", "pct": "%"}


def human_label(name: str) -> str:
    """A column name as a reader says it, with its unit: ``range_error_m.rms`` -> "range
    error RMS (m)", ``agents.videoray.controller.heading`` -> "videoray controller
    heading", ``min_separation_m`` -> "minimum separation (m)"."""
    parts = name.removeprefix("agents.").split(".")
    unit = ""
    words = []
    for part in parts:
        for suffix, symbol in UNIT_SUFFIXES.items():
            if part.endswith(suffix) and len(part) > len(suffix):
                part, unit = part[:-len(suffix)], symbol
                break
        words += [WORDS.get(w, w) for w in part.split("_")]
    text = " ".join(words)
    return f"{text} ({unit})" if unit else text


def summary_figure(rows: list[dict[str, Any]], parameters: list[str], title: str = "sweep"
                   ) -> Figure:
    """The summary figure of the completed runs: a grid of panels, one per metric and
    swept parameter (about three across), each metric's mean and 95 % CI per value over
    the runs' own values, labelled in words with units."""
    ok = [row for row in rows if row["status"] == "ok"]
    metrics = metric_columns(ok, parameters)
    shown = parameters or ["seed"]
    panels = [(metric, parameter) for parameter in shown for metric in metrics] or [(None, "")]
    n_cols = min(3, len(panels))
    n_rows = math.ceil(len(panels) / n_cols)
    fig, axes = subplots(n_rows, n_cols, figsize=(4.4 * n_cols, 3.3 * n_rows + 0.5),
                         squeeze=False, layout="constrained")
    flat = list(axes.flat)
    for ax in flat[len(panels):]:
        ax.axis("off")
    for ax, (metric, parameter) in zip(flat, panels, strict=False):
        if metric is None:
            ax.text(0.5, 0.5, "no completed run with a varying metric",
                    ha="center", va="center", transform=ax.transAxes)
            continue
        values = [row.get(parameter) for row in ok]
        groups, xs, labels = _groups([str(v) if isinstance(v, list | dict) else v
                                      for v in values])
        column = numeric_column(ok, metric)
        cis = [mean_ci95(column[g]) for g in groups]
        ax.errorbar(xs, [m for m, _ in cis], yerr=[h for _, h in cis], fmt="o-",
                    capsize=3, lw=1, label="mean, 95 % CI")
        ax.scatter(np.repeat(xs, [g.size for g in groups]),
                   np.concatenate([column[g] for g in groups]) if groups else [],
                   s=8, alpha=0.4, color="grey", label="runs")
        if not all(isinstance(v, int | float) for v in values):
            ax.set_xticks(xs, labels, rotation=30, fontsize=8)
        ax.set_title(human_label(metric), fontsize=10)
        ax.set_xlabel(human_label(parameter), fontsize=9)
        ax.grid(alpha=0.3)
    if metrics:
        flat[0].legend(fontsize=7)
    failed = len(rows) - len(ok)
    fig.suptitle(f"{title}: {len(ok)} completed runs ({failed} failed), mean and 95 % CI "
                 "per value", fontsize=11)
    return fig


def plot_sweep_summary(rows: list[dict[str, Any]], parameters: list[str], path: Path,
                       title: str = "sweep") -> Path:
    """Draw :func:`summary_figure` into ``path`` (PNG)."""
    return save_figure(summary_figure(rows, parameters, title), path, dpi=100)
