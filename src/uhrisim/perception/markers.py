"""Reading the diver's slate: ArUco markers found in the ROV's camera images.

Detection is OpenCV's ``cv2.aruco.ArucoDetector`` (Garrido-Jurado et al., Pattern
Recognition 47(6), 2014) on the camera's 8-bit picture as the sensor formed it — the
water's attenuation and veils, forward-scatter blur, the lamps and the sensor noise are
all in the pixels; nothing is read from the scene. Each detection carries:

* ``confidence``: 1 − the fraction of the marker's pixels that disagree with its code.
  The quad is warped to a canonical (cells × 8 px)² image, binarized at Otsu's threshold,
  and compared pixel by pixel with the marker that the id names, leaving out a margin of
  13 % of a cell along every cell edge (OpenCV's ``perspectiveRemoveIgnoredMarginPerCell``),
  where blur mixes neighbouring cells. This is the definition of OpenCV's own
  ``detectMarkersWithConfidence`` ("1 minus the normalized uncertainty, the percentage
  of incorrect pixel detections"; OpenCV ≥ 4.13), computed here so that it does not
  depend on the OpenCV version; a test holds the two together where both exist.
* ``contrast``: the Michelson contrast of the code's white and black cells in that image.
* the slate's pose from the four corners (``cv2.solvePnP``, ``SOLVEPNP_IPPE_SQUARE``, the
  camera's K, no distortion): range (m), bearing (deg, right of the optical axis > 0),
  elevation (deg, below it > 0), the marker centre in the camera frame (x along the axis,
  y right, z down) and, from the frame's pose, in NED.

What each marker id means is data (:class:`MarkerCommands`; the shipped table
``perception/data/marker_commands.json``, a scenario gives its own).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.perception.signals import Command, RecognizedSignal, load_json
from uhrisim.sensors.camera.camera import CameraFrame
from uhrisim.world.slate import DEFAULT_DICTIONARY, aruco_dictionary, dictionary_size

#: canonical pixels per cell for the confidence, and the ignored margin (a cell's share)
_PX_PER_CELL = 8
_IGNORED_MARGIN = 0.13


@dataclass(frozen=True)
class MarkerCommands:
    """What the slate's markers say: a dictionary, the printed marker's side (m, the black
    square) and marker id → :class:`~uhrisim.perception.signals.Command`."""

    dictionary: str = DEFAULT_DICTIONARY
    marker_size_m: float = 0.20
    commands: Mapping[int, Command] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = dictionary_size(self.dictionary)
        for marker_id in self.commands:
            if not 0 <= marker_id < n:
                raise ConfigError(f"marker id {marker_id} is not in {self.dictionary} "
                                  f"(0..{n - 1})", "MarkerCommands.commands")
        if not (math.isfinite(self.marker_size_m) and self.marker_size_m > 0.0):
            raise ConfigError(f"must be > 0 m, got {self.marker_size_m!r}",
                              "MarkerCommands.marker_size_m")

    @staticmethod
    def from_mapping(data: object, where: str = "markers") -> MarkerCommands:
        """From ``{"dictionary": ..., "marker_size_m": ..., "commands": {"0": "stop",
        "10": "bring_tool wrench", ...}}``; errors name the field."""
        if not isinstance(data, Mapping):
            raise ConfigError("must be a mapping with 'commands'", where)
        unknown = set(data) - {"dictionary", "marker_size_m", "commands", "provenance"}
        if unknown:
            raise ConfigError(f"unknown field(s) {sorted(unknown)}", where)
        table = data.get("commands")
        if not isinstance(table, Mapping):
            raise ConfigError("must map marker ids to commands", f"{where}.commands")
        commands: dict[int, Command] = {}
        for key, text in table.items():
            try:
                marker_id = int(key)
            except (TypeError, ValueError):
                raise ConfigError(f"marker id must be an integer, got {key!r}",
                                  f"{where}.commands") from None
            commands[marker_id] = Command.parse(text, f"{where}.commands.{key}")
        try:
            return MarkerCommands(str(data.get("dictionary", DEFAULT_DICTIONARY)),
                                  float(data.get("marker_size_m", 0.20)), commands)
        except ConfigError as error:
            raise ConfigError(str(error), where) from None
        except (TypeError, ValueError):
            raise ConfigError(f"must be a number of metres, got {data['marker_size_m']!r}",
                              f"{where}.marker_size_m") from None

    @staticmethod
    def load(path: str | Path | None = None) -> MarkerCommands:
        """The table in the JSON file ``path``, or the shipped one."""
        data, where = load_json(path, "marker_commands.json", "marker commands")
        return MarkerCommands.from_mapping(data, where)


@dataclass(frozen=True)
class MarkerDetection:
    """One marker found in one image (module docstring for the fields' meaning)."""

    marker_id: int
    corners: NDArray[np.float32]  # (4, 2) px: top-left, top-right, bottom-right, bottom-left
    confidence: float
    contrast: float
    range_m: float
    bearing_deg: float
    elevation_deg: float
    position_camera: NDArray[np.float64]  # (3,) m: x along the axis, y right, z down
    position_ned: NDArray[np.float64] | None
    command: Command | None


class MarkerReader:
    """Finds the markers of a :class:`MarkerCommands` table in camera frames."""

    def __init__(self, commands: MarkerCommands | None = None) -> None:
        self.commands = commands or MarkerCommands.load()
        self._dictionary = aruco_dictionary(self.commands.dictionary)
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        self._detector = cv2.aruco.ArucoDetector(self._dictionary, params)
        self._cells = int(self._dictionary.markerSize) + 2
        side = self._cells * _PX_PER_CELL
        self._canonical = np.array([[0, 0], [side, 0], [side, side], [0, side]], np.float32)
        margin = np.ones(_PX_PER_CELL, bool)
        cut = max(1, round(_IGNORED_MARGIN * _PX_PER_CELL))
        margin[:cut] = margin[-cut:] = False
        inner = np.tile(margin, self._cells)
        self._inner = inner[:, None] & inner[None, :]
        h = 0.5 * self.commands.marker_size_m
        self._object = np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float64)
        self._codes: dict[int, NDArray[np.bool_]] = {}

    def _code(self, marker_id: int) -> NDArray[np.bool_]:
        """The marker's canonical image, True for white (cached)."""
        if marker_id not in self._codes:
            side = self._cells * _PX_PER_CELL
            image = cv2.aruco.generateImageMarker(self._dictionary, marker_id, side, borderBits=1)
            self._codes[marker_id] = image > 127
        return self._codes[marker_id]

    def confidence(self, grey: NDArray[np.uint8], corners: NDArray[np.float32],
                   marker_id: int) -> tuple[float, float]:
        """(confidence, contrast) of a detected marker (module docstring)."""
        side = self._cells * _PX_PER_CELL
        warp = cv2.getPerspectiveTransform(corners.astype(np.float32), self._canonical)
        canonical = cv2.warpPerspective(grey, warp, (side, side), flags=cv2.INTER_LINEAR)
        _, binary = cv2.threshold(canonical, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        code = self._code(marker_id)
        wrong = (binary > 127) != code
        confidence = 1.0 - float(wrong[self._inner].mean())
        white = float(canonical[self._inner & code].mean())
        black = float(canonical[self._inner & ~code].mean())
        contrast = (white - black) / (white + black) if white + black > 0 else 0.0
        return confidence, contrast

    def read_image(self, rgb: NDArray[np.uint8], K: NDArray[np.float64],
                   position_ned: NDArray[np.float64] | None = None,
                   rotation_ned_from_camera: NDArray[np.float64] | None = None
                   ) -> list[MarkerDetection]:
        """The markers in an (H, W, 3) RGB image taken with intrinsics ``K``; with the
        camera's pose (NED, camera frame → NED) each also gets its NED position."""
        grey = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
        corners, ids, _ = self._detector.detectMarkers(grey)
        out = []
        for quad, marker_id in zip(corners, [] if ids is None else ids.ravel(), strict=True):
            c = quad.reshape(4, 2)
            ok, _, tvec = cv2.solvePnP(self._object, c.astype(np.float64), K, None,
                                       flags=cv2.SOLVEPNP_IPPE_SQUARE)
            if not ok:
                continue
            tx, ty, tz = (float(v) for v in tvec.ravel())  # OpenCV: x right, y down, z ahead
            p_cam = np.array([tz, tx, ty])
            p_ned = None
            if position_ned is not None and rotation_ned_from_camera is not None:
                p_ned = np.asarray(position_ned) + np.asarray(rotation_ned_from_camera) @ p_cam
            confidence, contrast = self.confidence(grey, c, int(marker_id))
            out.append(MarkerDetection(
                int(marker_id), c.copy(), confidence, contrast, float(np.linalg.norm(p_cam)),
                math.degrees(math.atan2(tx, tz)), math.degrees(math.atan2(ty, math.hypot(tx, tz))),
                p_cam, p_ned, self.commands.commands.get(int(marker_id))))
        return out

    def read(self, frame: CameraFrame) -> list[MarkerDetection]:
        """The markers in a camera frame (its picture, K and pose)."""
        return self.read_image(frame.rgb, frame.K, frame.position_ned,
                               frame.rotation_ned_from_camera)


def marker_signals(detections: list[MarkerDetection], t: float,
                   min_confidence: float = 0.0) -> list[RecognizedSignal]:
    """The commands read from ``detections`` at time ``t`` (s): one signal per detection
    whose id means a command and whose confidence is at least ``min_confidence``."""
    return [RecognizedSignal(d.command, "marker", d.confidence, float(t))
            for d in detections if d.command is not None and d.confidence >= min_confidence]
