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

**Where it looks.** Given where the slate is expected (NED, from the diver's track),
:meth:`MarkerReader.read` searches only the part of the picture within a margin of it,
and the whole picture every :data:`FULL_SEARCH_EVERY` th frame (and whenever nothing is
expected) — as fielded marker trackers do. The detector's size limits, relative to the
picture's larger side, are scaled to the region so that it accepts the same markers in
pixels as the whole picture's search; a marker inside the region is found as it is in
the whole picture.

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
#: the whole picture is searched every this many frames, the expected region between
FULL_SEARCH_EVERY = 5
#: the region searched: within this of where the slate is expected, each way (m)
SEARCH_MARGIN_M = 0.5
#: a region closer than this to the camera (m, along its axis) is searched whole
NEAREST_REGION_M = 0.1


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
        self._params = params
        self._perimeter_rates = (params.minMarkerPerimeterRate, params.maxMarkerPerimeterRate)
        self._detector = cv2.aruco.ArucoDetector(self._dictionary, params)
        self._frames_since_full = FULL_SEARCH_EVERY - 1  # the first frame: whole
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

    def _detect(self, grey: NDArray[np.uint8], region: tuple[int, int, int, int] | None
                ) -> tuple[list[NDArray[np.float32]], list[int]]:
        """Quads (4, 2) px and ids found in ``grey``, or in its ``region`` (x0, y0, x1, y1
        px) with the detector's size limits scaled to it (module docstring)."""
        offset = np.zeros(2, np.float32)
        scale = 1.0
        if region is not None:
            x0, y0, x1, y1 = region
            scale = max(grey.shape) / max(x1 - x0, y1 - y0)
            grey = grey[y0:y1, x0:x1]
            offset[:] = x0, y0
        low, high = self._perimeter_rates
        if self._params.minMarkerPerimeterRate != low * scale:
            self._params.minMarkerPerimeterRate = low * scale
            self._params.maxMarkerPerimeterRate = high * scale
            self._detector.setDetectorParameters(self._params)
        corners, ids, _ = self._detector.detectMarkers(grey)
        if ids is None:
            return [], []
        return [quad.reshape(4, 2) + offset for quad in corners], [int(i) for i in ids.ravel()]

    def search_region(self, frame: CameraFrame, near_ned: NDArray[np.float64],
                      margin_m: float | NDArray[np.float64] = SEARCH_MARGIN_M
                      ) -> tuple[int, int, int, int] | None:
        """The picture's region (x0, y0, x1, y1 px) where a box of ``margin_m`` (m, each
        way; one number or north, east, down) around ``near_ned`` appears; None for the
        whole picture (the box reaches behind the camera), an empty region when it is
        out of view."""
        corners = np.array([[n, e, d] for n in (-1, 1) for e in (-1, 1) for d in (-1, 1)],
                           float) * margin_m + np.asarray(near_ned, float)
        ahead, right, down = frame.rotation_ned_from_camera.T @ (corners - frame.position_ned).T
        if ahead.min() < NEAREST_REGION_M:
            return None
        K = frame.K
        u, v = K[0, 0] * right / ahead + K[0, 2], K[1, 1] * down / ahead + K[1, 2]
        height, width = frame.rgb.shape[:2]
        x0, x1 = (int(np.clip(f(u), 0, width)) for f, u in ((np.floor, u.min()),
                                                               (np.ceil, u.max())))
        y0, y1 = (int(np.clip(f(v), 0, height)) for f, v in ((np.floor, v.min()),
                                                                (np.ceil, v.max())))
        return x0, y0, max(x0, x1), max(y0, y1)

    def read_image(self, rgb: NDArray[np.uint8], K: NDArray[np.float64],
                   position_ned: NDArray[np.float64] | None = None,
                   rotation_ned_from_camera: NDArray[np.float64] | None = None,
                   region: tuple[int, int, int, int] | None = None
                   ) -> list[MarkerDetection]:
        """The markers in an (H, W, 3) RGB image taken with intrinsics ``K`` (in its
        ``region``, x0, y0, x1, y1 px, if given); with the camera's pose (NED, camera
        frame → NED) each also gets its NED position."""
        grey = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
        if region is not None and (region[2] - region[0] < 8 or region[3] - region[1] < 8):
            return []  # out of view (or too small to hold a marker)
        out = []
        for c, marker_id in zip(*self._detect(grey, region), strict=True):
            ok, _, tvec = cv2.solvePnP(self._object, c.astype(np.float64), K, None,
                                       flags=cv2.SOLVEPNP_IPPE_SQUARE)
            if not ok:
                continue
            tx, ty, tz = (float(v) for v in tvec.ravel())  # OpenCV: x right, y down, z ahead
            p_cam = np.array([tz, tx, ty])
            p_ned = None
            if position_ned is not None and rotation_ned_from_camera is not None:
                p_ned = np.asarray(position_ned) + np.asarray(rotation_ned_from_camera) @ p_cam
            confidence, contrast = self.confidence(grey, c, marker_id)
            out.append(MarkerDetection(
                marker_id, c.copy(), confidence, contrast, float(np.linalg.norm(p_cam)),
                math.degrees(math.atan2(tx, tz)), math.degrees(math.atan2(ty, math.hypot(tx, tz))),
                p_cam, p_ned, self.commands.commands.get(marker_id)))
        return out

    def read(self, frame: CameraFrame, near_ned: NDArray[np.float64] | None = None,
             margin_m: float | NDArray[np.float64] = SEARCH_MARGIN_M) -> list[MarkerDetection]:
        """The markers in a camera frame (its picture, K and pose); with ``near_ned``,
        where the slate is expected (NED, m), within ``margin_m`` of it but every
        :data:`FULL_SEARCH_EVERY` th frame (module docstring)."""
        region = None
        if near_ned is not None and self._frames_since_full < FULL_SEARCH_EVERY - 1:
            region = self.search_region(frame, near_ned, margin_m)
        self._frames_since_full = 0 if region is None else self._frames_since_full + 1
        return self.read_image(frame.rgb, frame.K, frame.position_ned,
                               frame.rotation_ned_from_camera, region)


def marker_signals(detections: list[MarkerDetection], t: float,
                   min_confidence: float = 0.0) -> list[RecognizedSignal]:
    """The commands read from ``detections`` at time ``t`` (s): one signal per detection
    whose id means a command and whose confidence is at least ``min_confidence``."""
    return [RecognizedSignal(d.command, "marker", d.confidence, float(t))
            for d in detections if d.command is not None and d.confidence >= min_confidence]
