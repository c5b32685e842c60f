"""The sonar vector env's echo-free images, without the ping's echo stages.

Most of the vector env's pings see nothing inside their window (the diver out of the fan
or out of range): their polar image
(:meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar.polar_bytes`) is the diffuse level of
each range row (noise, volume and surface reverberation, no far side lobes) plus the
ping's window of the product speckle field, through the display curve.
:func:`echo_free_bytes` forms just that, with the same operations on the same values
(the same OpenCV passes), and draws from the sonar's Generator what
:meth:`~uhrisim.sensors.sonar.sonar.ImagingSonar._physical_polar` draws (the speckle
window's offset), so this ping and the next are the same bit for bit.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.geometry import surface_rows
from uhrisim.sensors.sonar.polar import diffuse_rows, display_bytes
from uhrisim.sensors.sonar.sonar import ImagingSonar


def echo_free_supported(sonar: ImagingSonar) -> bool:
    """Whether :func:`echo_free_bytes` forms this sonar's echo-free images: physical
    mode without multipath, product speckle or none (the coherent model draws more)."""
    cfg = sonar.config
    bank = sonar._bank
    return (cfg.mode == "physical" and not cfg.multipath
            and (bank is None or bank.z_re is None))


def echo_free_bytes(sonar: ImagingSonar, position_ned: NDArray[np.float64],
                    rotation_ned_from_sonar: NDArray[np.float64],
                    level: NDArray[np.float32]) -> NDArray[np.uint8]:
    """``sonar.polar_bytes`` of a ping with no hit (its pose: sonar origin NED m, rotation
    sonar → NED), bit for bit, drawing the same speckle offset (an
    :func:`echo_free_supported` sonar); ``level``: (n_bins, n_beams) float32 scratch.
    The diffuse level per row as ``_physical_image`` and ``_physical_polar`` form it with
    no echo, then OpenCV's passes of ``_physical_polar`` and ``display_bytes``."""
    cfg, g = sonar.config, sonar.geometry
    depression = math.asin(max(-1.0, min(1.0, float(rotation_ned_from_sonar[2, 0]))))
    surface = surface_rows(cfg, g.bin_centres, float(position_ned[2]), depression,
                           g.beam_spacing, float(g.beam_kernel.sum()))
    d = diffuse_rows(g.diffuse_static, level, g.leak, surface, [])  # (reads no row)
    level[:] = (g.row_offset[:, :1] + g.k_ln * np.log(np.maximum(d, 1e-300))[:, None]
                ).astype(np.float32)
    bank = sonar._bank
    if bank is not None:
        cv2.add(level, bank.log_w(*bank.w_offset(sonar.rng)), dst=level)
    return display_bytes(level, cfg.display_gamma, cfg.black_level, clipped=False)
