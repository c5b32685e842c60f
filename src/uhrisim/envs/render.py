"""``render_mode="rgb_array"`` frames: a top-down map (north up, east right) centred on the
follower, beside the follower's sonar fan image (forward up, starboard right)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import cv2
import numpy as np

from uhrisim.dynamics.plants import NavState
from uhrisim.world.scene import Scene

PANEL_PX = 400           # each panel is PANEL_PX x PANEL_PX
MAP_SPAN_M = 40.0        # the map shows this many metres across
WATER = (18, 40, 70)     # RGB
GRID = (40, 70, 105)
OBSTACLE = (150, 150, 150)
FOLLOWER = (255, 220, 0)
TARGET = (255, 120, 40)
TRAIL_POINT = (80, 255, 120)
FAN_EDGE = (120, 200, 255)


def render_frame(scene: Scene, follower: NavState, target: NavState,
                 trail_point_ned: np.ndarray, track: Sequence[tuple[np.ndarray, np.ndarray]],
                 fan_u8: np.ndarray | None, sonar_range_m: float | None,
                 half_fov_rad: float, t: float) -> np.ndarray:
    """(PANEL_PX, 2 PANEL_PX, 3) uint8 RGB: map and sonar fan (a grey panel without one)."""
    return np.concatenate([
        _map(scene, follower, target, trail_point_ned, track, sonar_range_m, half_fov_rad, t),
        _fan(fan_u8)], axis=1)


def _map(scene: Scene, follower: NavState, target: NavState, trail_point_ned: np.ndarray,
         track: Sequence[tuple[np.ndarray, np.ndarray]], sonar_range_m: float | None,
         half_fov_rad: float, t: float) -> np.ndarray:
    image = np.empty((PANEL_PX, PANEL_PX, 3), dtype=np.uint8)
    image[:] = WATER
    scale = PANEL_PX / MAP_SPAN_M
    centre = follower.position_ned[:2]

    def px(ne: np.ndarray) -> tuple[int, int]:
        return (round(PANEL_PX / 2 + (ne[1] - centre[1]) * scale),
                round(PANEL_PX / 2 - (ne[0] - centre[0]) * scale))

    step = 5.0  # m between grid lines
    for k in range(-5, 6):
        north = math.floor(centre[0] / step) * step + k * step
        east = math.floor(centre[1] / step) * step + k * step
        cv2.line(image, px(np.array([north, centre[1] - 30])),
                 px(np.array([north, centre[1] + 30])), GRID, 1)
        cv2.line(image, px(np.array([centre[0] - 30, east])),
                 px(np.array([centre[0] + 30, east])), GRID, 1)
    for obj in scene.static_objects:
        if obj.label == "seafloor":
            continue
        low, high = np.asarray(obj.mesh.bounds)
        cv2.rectangle(image, px(np.array([high[0], low[1]])), px(np.array([low[0], high[1]])),
                      OBSTACLE, -1)
    for (f0, g0), (f1, g1) in itertools.pairwise(track):
        cv2.line(image, px(f0), px(f1), FOLLOWER, 1)
        cv2.line(image, px(g0), px(g1), TARGET, 1)
    if sonar_range_m is not None:
        apex = px(follower.position_ned)
        for edge in (-half_fov_rad, half_fov_rad):
            bearing = follower.yaw + edge
            tip = follower.position_ned[:2] + sonar_range_m * np.array(
                [math.cos(bearing), math.sin(bearing)])
            cv2.line(image, apex, px(tip), FAN_EDGE, 1)
        heading_deg = math.degrees(follower.yaw) - 90.0  # cv2 angles: from +x (east), cw
        fov_deg = math.degrees(half_fov_rad)
        cv2.ellipse(image, apex, (int(sonar_range_m * scale),) * 2, 0.0,
                    heading_deg - fov_deg, heading_deg + fov_deg, FAN_EDGE, 1)
    _body(image, px, target, TARGET, 0.9 * scale)
    _body(image, px, follower, FOLLOWER, 0.5 * scale)
    cv2.drawMarker(image, px(trail_point_ned), TRAIL_POINT, cv2.MARKER_CROSS, 10, 2)
    cv2.putText(image, f"t = {t:6.1f} s", (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                (230, 230, 230), 1, cv2.LINE_AA)
    return image


def _body(image: np.ndarray, px, nav: NavState, colour: tuple[int, int, int],
          size_px: float) -> None:
    """A triangle pointing along the body's heading."""
    c, s = math.cos(nav.yaw), math.sin(nav.yaw)
    nose = px(nav.position_ned[:2] + np.array([c, s]) * size_px / (PANEL_PX / MAP_SPAN_M))
    pts = [nose]
    for side in (-1.0, 1.0):
        back = nav.position_ned[:2] + (np.array([-c, -s]) * 0.6 + side * 0.5 * np.array(
            [-s, c])) * size_px / (PANEL_PX / MAP_SPAN_M)
        pts.append(px(back))
    cv2.fillPoly(image, [np.array(pts, dtype=np.int32)], colour)


def _fan(fan_u8: np.ndarray | None) -> np.ndarray:
    if fan_u8 is None:
        panel = np.full((PANEL_PX, PANEL_PX, 3), 60, dtype=np.uint8)
        cv2.putText(panel, "no sonar in this observation", (60, PANEL_PX // 2),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.5, (200, 200, 200), 1, cv2.LINE_AA)
        return panel
    h, w = fan_u8.shape
    size = min(PANEL_PX / h, PANEL_PX / w)
    fan = cv2.resize(fan_u8, (max(1, int(w * size)), max(1, int(h * size))),
                     interpolation=cv2.INTER_AREA)
    coloured = cv2.cvtColor(cv2.applyColorMap(fan, cv2.COLORMAP_BONE), cv2.COLOR_BGR2RGB)
    panel = np.zeros((PANEL_PX, PANEL_PX, 3), dtype=np.uint8)
    top, left = (PANEL_PX - fan.shape[0]) // 2, (PANEL_PX - fan.shape[1]) // 2
    panel[top:top + fan.shape[0], left:left + fan.shape[1]] = coloured
    return panel
