"""A sonar fan drawn for reading: metric axes (starboard and forward, m), range arcs and
bearing lines with their values, a colour bar of the display level, and a crop to a
point of interest (the diver). Used by the run's sonar strip and the sonar figures.

Fan images here are the physical mode's ``fan_u8``: apex at the bottom centre, forward up,
starboard right (:class:`uhrisim.sensors.sonar.SonarPing`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.image import AxesImage

#: The colour bar's label: the 8-bit display level of the fan (black level to white).
LEVEL_LABEL = "display level (0-255)"


@dataclass(frozen=True)
class FanView:
    """One fan image and its geometry: ``image`` (H, W) uint8, ``px_per_m``, ``apex``
    (column, row) in pixel-centre coordinates, ``half_fov_deg``, ``range_m`` (far edge)."""

    image: NDArray[np.uint8]
    px_per_m: float
    apex: tuple[float, float]
    half_fov_deg: float
    range_m: float

    @classmethod
    def of_ping(cls, ping) -> FanView:
        """The view of a physical-mode :class:`SonarPing` (its fan copied)."""
        return cls(ping.fan_u8.copy(), float(ping.fan_px_per_m), tuple(ping.fan_apex_px),
                   math.degrees(ping.fan_half_fov_rad), float(ping.bin_ranges_m[-1]))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) of the image in metres: starboard, forward."""
        h, w = self.image.shape[:2]
        s, (c0, r0) = self.px_per_m, self.apex
        return ((-0.5 - c0) / s, (w - 0.5 - c0) / s, (r0 - h + 0.5) / s, (r0 + 0.5) / s)

    def pixel_of(self, starboard_m: float, forward_m: float) -> tuple[float, float]:
        """(column, row) of a point of the sonar's horizontal plane."""
        return (self.apex[0] + starboard_m * self.px_per_m,
                self.apex[1] - forward_m * self.px_per_m)


def in_sonar_plane(ping, position_ned: NDArray[np.float64]) -> tuple[float, float]:
    """(starboard m, forward m) of a world NED point as the sonar images it: the point in
    the sonar frame, its slant range kept and laid into the horizontal fan at its bearing
    (imaging sonars do not measure elevation)."""
    p = (np.asarray(position_ned, float) - ping.position_ned) @ ping.rotation_ned_from_sonar
    slant = float(np.linalg.norm(p))
    bearing = math.atan2(p[1], p[0])
    return slant * math.sin(bearing), slant * math.cos(bearing)


def crop_window(view: FanView, target: tuple[float, float] | None,
                half_width_m: float = 2.5) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) metres to show: a square of ``2 half_width_m`` around ``target``
    (starboard, forward), kept inside the fan's image; the whole fan without a target or
    when the target lies beyond the fan's range."""
    left, right, bottom, top = view.extent
    if target is None or math.hypot(*target) > view.range_m:
        return left, right, max(bottom, 0.0), top
    side = min(2 * half_width_m, right - left, top - max(bottom, 0.0))
    x0 = min(max(target[0] - side / 2, left), right - side)
    y0 = min(max(target[1] - side / 2, max(bottom, 0.0)), top - side)
    return x0, x0 + side, y0, y0 + side


def nice_step(span: float) -> float:
    """A 1-2-5 step giving about five divisions of ``span``."""
    raw = span / 5.0
    power = 10.0 ** math.floor(math.log10(raw))
    return next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= raw)


def draw_fan(ax: Axes, view: FanView, cmap: str = "copper",
             window: tuple[float, float, float, float] | None = None,
             colorbar: bool = True, grid_colour: str = "0.75") -> AxesImage:
    """``view`` on ``ax`` in metres, with range arcs and bearing lines labelled, the axes
    named, limited to ``window`` (x0, x1, y0, y1) if given, and a colour bar of the
    display level (or none: :func:`level_bar` draws one for several fans); the image."""
    image = ax.imshow(view.image, cmap=cmap, vmin=0, vmax=255, extent=view.extent,
                      interpolation="nearest")
    x0, x1, y0, y1 = window or (*view.extent[:2], max(view.extent[2], 0.0), view.extent[3])
    span = max(x1 - x0, y1 - y0)
    step = nice_step(min(span, view.range_m))
    half = math.radians(view.half_fov_deg)
    angles = np.linspace(-half, half, 90)
    r = step
    while r <= view.range_m + 1e-9:
        ax.plot(r * np.sin(angles), r * np.cos(angles), color=grid_colour, lw=0.5)
        label_at = (r * math.sin(half), r * math.cos(half))
        slack = 0.02 * span  # the fan's far corner may lie a pixel outside its image
        if x0 - slack <= label_at[0] <= x1 + slack and y0 - slack <= label_at[1] <= y1 + slack:
            ax.annotate(f"{r:g} m", label_at, color=grid_colour, fontsize=7,
                        xytext=(2, 0), textcoords="offset points")
        r += step
    tick = 15.0 if view.half_fov_deg > 30.0 else 10.0
    bearings = sorted({-view.half_fov_deg, view.half_fov_deg,
                       *np.arange(-math.floor(view.half_fov_deg / tick) * tick,
                                  view.half_fov_deg + 1e-9, tick)})
    for bearing in bearings:
        b = math.radians(bearing)
        end = (view.range_m * math.sin(b), view.range_m * math.cos(b))
        ax.plot([0.0, end[0]], [0.0, end[1]], color=grid_colour, lw=0.5)
        at = _inside_along(end, (x0, x1, y0, y1))
        if at is not None:
            ax.annotate(f"{bearing:+.0f}°", at, color=grid_colour, fontsize=7,
                        ha="center", va="bottom")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("starboard (m)")
    ax.set_ylabel("forward (m)")
    if colorbar:
        level_bar(image, [ax])
    return image


def level_bar(image: AxesImage, axes: list[Axes]) -> None:
    """The colour bar of the display level beside ``axes``."""
    axes[0].figure.colorbar(image, ax=axes, shrink=0.85, label=LEVEL_LABEL, pad=0.01)


def _inside_along(end: tuple[float, float], window: tuple[float, float, float, float]
                  ) -> tuple[float, float] | None:
    """The farthest point of the ray from the apex to ``end`` inside ``window`` (where a
    bearing line's label goes), or None when the ray misses the window."""
    x0, x1, y0, y1 = window
    for f in np.linspace(1.0, 0.05, 40):
        x, y = end[0] * f, end[1] * f
        if x0 <= x <= x1 and y0 <= y <= y1:
            return x, y
    return None
