"""Shared figure helpers: matplotlib's object API (no pyplot, no global backend state),
so figures render headless anywhere and never open a window."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matplotlib.figure import Figure


def subplots(nrows: int = 1, ncols: int = 1, **kwargs: Any) -> tuple[Figure, Any]:
    """A new figure and its axes, like ``pyplot.subplots`` (``figsize`` etc. in kwargs)."""
    figure_keys = {"figsize", "dpi", "layout"}
    fig = Figure(**{k: v for k, v in kwargs.items() if k in figure_keys})
    axes = fig.subplots(nrows, ncols, **{k: v for k, v in kwargs.items() if k not in figure_keys})
    return fig, axes


def save_figure(fig: Figure, path: Path, dpi: int = 120) -> Path:
    """Lay out (tightly, unless the figure has its own layout engine, as figures with
    colour bars do) and write ``path`` (format from its suffix); return ``path``."""
    if fig.get_layout_engine() is None:
        fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    return path
