"""What one ping of the imaging sonar produces: a :class:`SonarPing`.

Frames (``docs/conventions.md``): the **sonar frame** is FRD-like — x along the sonar axis,
y to starboard, z down; hit points are also given in world NED. Angles in radians, ranges
in metres. :class:`~uhrisim.sensors.sonar.sonar.ImagingSonar` forms pings; recorders,
bridges, viewers and perception read them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.cloud import SonarCloud


@dataclass(frozen=True)
class SonarInfo:
    """What the consumers of a sonar's pings (recorders, bridges, viewers, environments)
    need to know of the sonar, carried by every ping so none of them re-derives or
    guesses it: ``preset`` name, centre ``frequency_hz``, ``sound_speed_m_s`` of the water,
    the range window ``range_min_m`` … ``range_max_m`` (m), the horizontal field of view
    ``fov_deg`` (the outer beams' centres point at its edges), ``n_beams`` and the
    range-bin size ``bin_m`` (m)."""

    preset: str
    frequency_hz: float
    sound_speed_m_s: float
    range_min_m: float
    range_max_m: float
    fov_deg: float
    n_beams: int
    bin_m: float


@dataclass(frozen=True)
class SonarPing:
    """One ping.

    Attributes:
        t: simulation time of the ping, s.
        position_ned: sonar origin in world NED, m.
        rotation_ned_from_sonar: 3×3 rotation taking sonar-frame vectors to NED.
        beam_angles_rad: (n_beams,) beam centre angles, > 0 starboard, ascending: the
            preset's native ones (evenly spaced, or a lens's measured table).
        bin_ranges_m: (n_bins,) range-bin centres, m.
        polar: (n_bins, n_beams) float32 display intensity 0…1 (row 0 = nearest bin);
            physical mode: the log-compressed level after the image-formation stages
            (docs/sonar.md), linear in dB over the display window; 2013 mode: hit
            occupancy (1 where a ray hit in the cell).
        polar_u8: the 8-bit image: physical mode ``round(b + (255 − b)·polar^γ)`` (the
            display curve from the black level b), 2013 mode ``polar`` as 0…255.
        fan_u8: Cartesian image. Physical mode: apex at the bottom centre, forward up,
            starboard right, black outside the fan. 2013 mode: the paper's image.
        fan_px_per_m: pixels per metre of ``fan_u8``.
        fan_apex_px: (column, row) of the apex in ``fan_u8`` (pixel-centre coordinates).
        fan_rgb: colour-mapped ``fan_u8`` (H, W, 3) BGR, when ``config.colormap`` is set.
        fan_layout: ``"bottom-centre"`` (physical), ``"port-edge"`` or ``"literal"`` (2013).
        fan_half_fov_rad: half the horizontal field of view (for the 2013 layouts).
        label_polar: (n_bins, n_beams) int16: the scene label of the strongest return in
            each cell (cells reached only by a ray's range footprint take the label of the
            nearest ray centre along range), −1 where no echo arrived. With
            ``config.labels`` off: all −1, one read-only array shared by every ping.
        label_fan: label image aligned with ``fan_u8`` (−1 none; read-only and shared
            with labels off).
        form_fan_images: forms (fan_u8, label_fan, fan_rgb). The three fan images are
            formed on first access of any of them (scan conversion is a large share of a
            small ping; a simulation whose hooks never look at the fan never pays for it).
        cloud: the paper's ``sonar_cloud`` with intensities.
        hit_points_sonar, hit_points_ned: (M, 3) hit points of the rays that hit inside the
            window, sonar frame and NED, m.
        form_hit_products: forms (cloud, hit_points_sonar, hit_points_ned), on first
            access of any of them (most consumers read only the images).
        hit_labels: (M,) int32 scene labels of the hits inside the window.
        mode: ``"physical"`` or ``"2013"``.
        info: the sonar that made it (:class:`SonarInfo`).
    """

    t: float
    position_ned: NDArray[np.float64]
    rotation_ned_from_sonar: NDArray[np.float64]
    beam_angles_rad: NDArray[np.float64]
    bin_ranges_m: NDArray[np.float64]
    polar: NDArray[np.float32]
    polar_u8: NDArray[np.uint8]
    fan_px_per_m: float
    fan_apex_px: tuple[float, float]
    label_polar: NDArray[np.int16]
    hit_labels: NDArray[np.int32]
    info: SonarInfo
    form_fan_images: Callable[[], tuple[Any, Any, Any]] = field(repr=False, compare=False)
    form_hit_products: Callable[[], tuple[Any, Any, Any]] = field(repr=False, compare=False)
    mode: str = "physical"
    fan_layout: str = "bottom-centre"
    fan_half_fov_rad: float = 0.0

    @cached_property
    def _fan_images(self) -> tuple[NDArray[np.uint8], NDArray[np.int16], NDArray[np.uint8] | None]:
        return self.form_fan_images()

    @property
    def fan_u8(self) -> NDArray[np.uint8]:
        """The Cartesian fan image (see the class docstring); formed on first access."""
        return self._fan_images[0]

    @property
    def label_fan(self) -> NDArray[np.int16]:
        """Label image aligned with ``fan_u8`` (−1 none); formed on first access."""
        return self._fan_images[1]

    @property
    def fan_rgb(self) -> NDArray[np.uint8] | None:
        """Colour-mapped ``fan_u8`` (H, W, 3) BGR when ``config.colormap`` is set;
        formed on first access."""
        return self._fan_images[2]

    @cached_property
    def _hit_products(self) -> tuple[SonarCloud, NDArray[np.float64], NDArray[np.float64]]:
        return self.form_hit_products()

    @property
    def cloud(self) -> SonarCloud:
        """The paper's ``sonar_cloud`` with intensities; formed on first access."""
        return self._hit_products[0]

    @property
    def hit_points_sonar(self) -> NDArray[np.float64]:
        """(M, 3) hit points inside the window, sonar frame, m; formed on first access."""
        return self._hit_products[1]

    @property
    def hit_points_ned(self) -> NDArray[np.float64]:
        """(M, 3) hit points inside the window, NED, m; formed on first access."""
        return self._hit_products[2]

    def fan_pixels_to_sonar(self, px: NDArray[np.float64]) -> NDArray[np.float64]:
        """Sonar-frame points (N, 3), metres, for fan pixel coordinates ``px`` (N, 2) as
        (column, row). Imaging sonars do not measure elevation: the points are placed in
        the sonar's x–y plane (z = 0)."""
        p = np.asarray(px, dtype=float).reshape(-1, 2)
        s = self.fan_px_per_m
        u = p[:, 0] - self.fan_apex_px[0]
        v = p[:, 1] - self.fan_apex_px[1]
        if self.fan_layout == "bottom-centre":
            x, y = -v / s, u / s
        elif self.fan_layout == "port-edge":
            c, sn = math.cos(self.fan_half_fov_rad), math.sin(self.fan_half_fov_rad)
            x, y = (u * c + v * sn) / s, (-u * sn + v * c) / s
        else:  # "literal"
            x, y = u / s, v / s
        return np.stack([x, y, np.zeros_like(x)], axis=1)

    def sonar_to_ned(self, pts_sonar: NDArray[np.float64]) -> NDArray[np.float64]:
        """World NED points for sonar-frame points (N, 3)."""
        return self.position_ned + np.asarray(pts_sonar, float) @ self.rotation_ned_from_sonar.T
