"""The team timeline (``uhrisim figure team-timeline --run RUN``): a Gantt chart of each
diver's orders, read from a run's recording.

Each order step is one bar on its diver's lane, from its start to its end (simulated s),
coloured by outcome (done, failed; a fetch the executor inserted is hatched); the bars
come from the ``order`` events on the recording's ``/events`` topic
(:func:`uhrisim.sim.teamwork.order_detail`), so the figure needs nothing but the file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from uhrisim.core.errors import AssetError
from uhrisim.record.reader import iter_messages
from uhrisim.sim.teamwork import parse_order_detail
from uhrisim.viz.figures import save_figure, subplots

_COLOURS = {"done": "#2a9d8f", "failed": "#e63946"}


def read_order_steps(recording: Path) -> list[dict[str, Any]]:
    """The order steps of a recording, in the order they ended (``parse_order_detail``
    fields: diver, index, outcome, start, end, order, fetched, reason)."""
    steps = []
    for message in iter_messages(recording, topics=["/events"]):
        if message.message.kind == "order":
            step = parse_order_detail(message.message.detail)
            if step is not None:
                steps.append(step)
    return steps


def plot_team_timeline(steps: list[dict[str, Any]], path: Path) -> Path:
    """Draw ``steps`` (from :func:`read_order_steps`) as a Gantt chart into ``path``."""
    divers = sorted({s["diver"] for s in steps})
    rows = [(d, s) for d in divers for s in steps if s["diver"] == d]
    fig, ax = subplots(figsize=(10, 0.32 * len(rows) + 1.5))
    for row, (_, step) in enumerate(rows):
        ax.barh(row, step["end"] - step["start"], left=step["start"], height=0.7,
                color=_COLOURS.get(step["outcome"], "#999999"),
                hatch="//" if step["fetched"] else None, edgecolor="black", linewidth=0.4)
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([f"{d}: {s['order']}" for d, s in rows], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("simulated time (s)")
    ax.set_title("team timeline: each order from start to end (green done, red failed)")
    ax.grid(axis="x", alpha=0.3)
    return save_figure(fig, path)


def make_team_timeline(out: Path, run: Path | None = None) -> list[Path]:
    """The timeline of the run in folder ``run`` (its ``recording.mcap``) into ``out``."""
    if run is None:
        raise AssetError("team-timeline draws a run: give --run RUN_FOLDER (the folder "
                         "`uhrisim run` wrote, with its recording.mcap)")
    recording = run / "recording.mcap" if run.is_dir() else run
    if not recording.exists():
        raise AssetError(f"{recording}: no recording there")
    steps = read_order_steps(recording)
    if not steps:
        raise AssetError(f"{recording}: no order steps recorded (a run with diver orders "
                         "draws a timeline)")
    out.mkdir(parents=True, exist_ok=True)
    return [plot_team_timeline(steps, out / "team_timeline.png")]
