"""Figures 5-8 of the paper from an open-loop run: x-y track, inputs, positions, velocities."""

from __future__ import annotations

from pathlib import Path

from numpy.typing import NDArray

from uhrisim.viz.figures import save_figure, subplots


def plot_openloop(t: NDArray, states: NDArray, inputs: NDArray, out_dir: Path) -> list[Path]:
    """Write ``openloop_track.png``, ``_inputs``, ``_positions``, ``_velocities`` to out_dir.

    ``t``: (n,) times (s); ``states``: (n, 8) VideoRay states ``x y z psi u v w r`` (NED m,
    rad, FRD m/s, rad/s); ``inputs``: (n, 3) thruster inputs ``port, star, vert`` (-150..150).
    """
    paths = []

    fig, ax = subplots(figsize=(5, 5))
    ax.plot(states[:, 1], states[:, 0], color="tab:blue")  # east on the horizontal axis, north up
    ax.plot(states[0, 1], states[0, 0], "go", label="start")
    ax.plot(states[-1, 1], states[-1, 0], "rs", label="end")
    ax.set_xlabel("east y (m)")
    ax.set_ylabel("north x (m)")
    ax.set_title("VideoRay open loop: x-y track (Fig. 5)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True)
    ax.legend()
    paths.append(save_figure(fig, out_dir / "openloop_track.png"))

    fig, ax = subplots(figsize=(6, 3.5))
    for k, label in enumerate(("port", "starboard", "vertical")):
        ax.plot(t, inputs[:, k], label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("thruster input (-150..150)")
    ax.set_title("Thruster inputs (Fig. 6)")
    ax.grid(True)
    ax.legend()
    paths.append(save_figure(fig, out_dir / "openloop_inputs.png"))

    fig, ax = subplots(figsize=(6, 3.5))
    for k, label in enumerate(("x north (m)", "y east (m)", "z depth (m)")):
        ax.plot(t, states[:, k], label=label)
    ax.set_xlabel("time (s)")
    ax.set_title("Positions (Fig. 7)")
    ax.grid(True)
    ax.legend()
    paths.append(save_figure(fig, out_dir / "openloop_positions.png"))

    fig, ax = subplots(figsize=(6, 3.5))
    for k, label in zip(range(4, 7), ("u surge", "v sway", "w heave"), strict=True):
        ax.plot(t, states[:, k], label=f"{label} (m/s)")
    ax.set_xlabel("time (s)")
    ax.set_title("Linear velocities (Fig. 8)")
    ax.grid(True)
    ax.legend()
    paths.append(save_figure(fig, out_dir / "openloop_velocities.png"))
    return paths
