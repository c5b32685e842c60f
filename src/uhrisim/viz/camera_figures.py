"""Camera figure: the same diver in clear, coastal and turbid water, near and far, with the
ROV's lamps on and off (docs/camera.md).

``make_camera`` writes, into ``out_dir``:

* ``camera_grid.png`` — 3 water types (rows) × {near, far} × {lamps on, lamps off}
  (columns), each panel titled with the water's beam attenuation c (R, G, B, 1/m) and
  the diver's contrast against the water beside it;
* ``camera_<water>_<near|far>_<lamps|nolamps>.png`` — each panel at full size (sRGB);
* ``camera_contrast.csv`` — per panel: the mean linear radiance on the diver and on the
  background beside it, and the diver's mean Michelson contrast, the mean over the
  diver's pixels of |L − L_b| / (L + L_b) (green channel; the dark suit and the bright
  tank both count).

The scene: rippled sand 8 m down, a pier beam behind the diver, the camera 5 m deep looking
north and slightly down; the diver at the camera's depth, side-on, 1.5 m (near) or
5 m (far) away. The camera exposes automatically (as the ROV's does) with the lamps on,
and the lamps-off panel beside it keeps that exposure (:func:`render_pair`), so the two
compare: the lamps add light where they point. Between water types and distances
brightness does not compare; the contrast in the titles and the table does, and so do
the radiances in the table.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import cv2
import numpy as np

from uhrisim.core.frames import rot_z
from uhrisim.core.rng import component_rng
from uhrisim.sensors.camera import CameraConfig, UnderwaterCamera, jerlov
from uhrisim.viz.figures import save_figure, subplots
from uhrisim.world import primitives as prim
from uhrisim.world.materials import CONCRETE, SAND_RIPPLED
from uhrisim.world.paper_scenes import add_diver
from uhrisim.world.scene import Scene

WATERS = (("clear", "IB"), ("coastal", "3C"), ("turbid", "9C"))
DISTANCES = (("near", 1.5), ("far", 5.0))
CAMERA_DEPTH = 5.0
SEED = 19


def diver_scene(distance: float) -> Scene:
    """Rippled sand 8 m down, a pier beam behind, the diver side-on at the camera's depth,
    ``distance`` metres ahead (the module docstring)."""
    scene = Scene()
    scene.add_static(prim.box((60.0, 60.0, 1.0), (20.0, 0.0, 8.5)), "seafloor", SAND_RIPPLED)
    scene.add_static(prim.box((0.4, 0.4, 9.0), (distance + 3.0, 1.2, 4.0)), "piling", CONCRETE)
    # side-on (heading east), centred on the optical axis
    add_diver(scene, "diver", (distance, -0.55, CAMERA_DEPTH), 90.0, kick_phase=0.6)
    return scene


def _render(water: str, distance: float, lamps: bool, exposure: float | str = "auto"):
    camera = UnderwaterCamera(
        CameraConfig(width=480, height=360, water=jerlov(water), tilt_deg=5.0,
                     mount_position_frd=(0.0, 0.0, 0.0), lamps_on=lamps, exposure=exposure),
        component_rng(SEED, f"figure/camera/{water}"))
    return camera.capture(diver_scene(distance).raycaster(), (0.0, 0.0, CAMERA_DEPTH),
                          rot_z(0.0), 0.0)


def render_pair(water: str, distance: float):
    """(lamps on, lamps off) frames at one exposure: the lamps-on frame's automatic one,
    as a camera whose exposure is held while its lamps are switched sees them."""
    lit = _render(water, distance, True)
    return lit, _render(water, distance, False, exposure=lit.gain)


def _contrast(frame) -> tuple[float, float, float]:
    """Mean green radiance on the diver and on the background beside it (the image
    columns the diver spans, rows above it), and the diver's mean Michelson contrast."""
    names = frame.label_names
    diver = frame.labels == (names.index("diver") if "diver" in names else -2)
    green = frame.radiance[..., 1]
    if not diver.any():
        return math.nan, math.nan, math.nan
    rows, cols = np.nonzero(diver)
    top = max(int(rows.min()) - 1, 1)
    beside = np.zeros_like(diver)
    beside[max(top - 40, 0):top, cols.min():cols.max() + 1] = True
    beside &= frame.labels != frame.labels[diver][0]
    l_b = float(green[beside].mean())
    pixels = green[diver]
    return float(pixels.mean()), l_b, float(np.mean(np.abs(pixels - l_b) / (pixels + l_b)))


def make_camera(out_dir: Path) -> list[Path]:
    """The grid, the panels and the contrast table; see the module docstring."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    fig, axes = subplots(len(WATERS), 4, figsize=(16.0, 9.6))
    rows = [("water", "jerlov", "distance_m", "lamps", "diver_radiance_g",
             "background_radiance_g", "contrast_g")]
    for i, (label, water) in enumerate(WATERS):
        c = jerlov(water).c
        frames = [(d, lamps, frame) for d in DISTANCES
                  for lamps, frame in zip((True, False), render_pair(water, d[1]), strict=True)]
        for j, ((where, distance), lamps, frame) in enumerate(frames):
            name = f"camera_{label}_{where}_{'lamps' if lamps else 'nolamps'}.png"
            cv2.imwrite(str(out / name), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
            files.append(out / name)
            l_d, l_b, contrast = _contrast(frame)
            rows.append((label, water, f"{distance:g}", str(lamps).lower(), f"{l_d:.5g}",
                         f"{l_b:.5g}", f"{contrast:.4f}"))
            ax = axes[i, j]
            ax.imshow(frame.rgb)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{label} (Jerlov {water}), {distance:g} m, lamps "
                         f"{'on' if lamps else 'off'}\nc = {c[0]:.2f}/{c[1]:.2f}/{c[2]:.2f} /m, "
                         f"contrast {contrast:.2f}", fontsize=9)
    files.append(save_figure(fig, out / "camera_grid.png"))
    with open(out / "camera_contrast.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)
    files.append(out / "camera_contrast.csv")
    return files
