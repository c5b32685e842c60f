"""A diver's slate showing a fiducial marker, for the ROV's camera to read.

RobotChat commanded an underwater robot with printed coded cards held up to its camera
(G. Dudek, J. Sattar, A. Xu, "A visual language for robot control and programming: a
human-interface study", ICRA 2007); here a handheld slate shows one ArUco marker
(S. Garrido-Jurado, R. Muñoz-Salinas, F. J. Madrid-Cuevas, M. J. Marín-Jiménez,
"Automatic generation and detection of highly reliable fiducial markers under
occlusion", Pattern Recognition 47(6) 2280-2292, 2014), drawn by OpenCV's
``cv2.aruco.generateImageMarker`` from one of its predefined dictionaries.

**Geometry** (the slate's own frame, metres): a board ``board_m`` square and
``thickness_m`` thick, centred on the origin. The marker is printed on the face at
x = +thickness/2: its black square (``marker_size_m``, the marker's border bits
included) sits in a white quiet zone one cell wide. A camera that looks at the printed
face along −x with its image "down" along +z reads the marker upright and unmirrored:
the picture's right is −y, its down +z. Pose the slate as a one-part dynamic body (a
diver holds it up facing the ROV) or as static geometry.

**Optics** (assumptions, like :mod:`uhrisim.world.materials`): white PVC 0.80 and matte
black print 0.04 diffuse albedo, grey-neutral; the board's edges and back are white.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import trimesh
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.world.materials import Material, PlanarTexture
from uhrisim.world.primitives import box

#: the dictionary divers' slates use unless a scenario says otherwise
DEFAULT_DICTIONARY = "DICT_4X4_50"


def aruco_dictionary(name: str) -> cv2.aruco.Dictionary:
    """OpenCV's predefined ArUco dictionary ``name`` (e.g. "DICT_4X4_50")."""
    value = getattr(cv2.aruco, str(name), None) if str(name).startswith("DICT_") else None
    if not isinstance(value, int):
        known = ", ".join(n for n in dir(cv2.aruco) if n.startswith("DICT_4X4"))
        raise ConfigError(f"unknown ArUco dictionary {name!r} (e.g. {known})",
                          where="marker dictionary")
    return cv2.aruco.getPredefinedDictionary(value)


def dictionary_size(name: str) -> int:
    """Number of markers (ids 0 .. n−1) in dictionary ``name``."""
    return int(aruco_dictionary(name).bytesList.shape[0])


@dataclass(frozen=True)
class MarkerSlate:
    """A slate with one ArUco marker (module docstring; lengths in metres)."""

    marker_id: int
    dictionary: str = DEFAULT_DICTIONARY
    marker_size_m: float = 0.20
    thickness_m: float = 0.01
    white: float = 0.80
    black: float = 0.04
    texels_per_cell: int = 8

    def __post_init__(self) -> None:
        where = "MarkerSlate"
        n = dictionary_size(self.dictionary)
        if not (isinstance(self.marker_id, int) and 0 <= self.marker_id < n):
            raise ConfigError(f"marker_id must be an integer in [0, {n - 1}] for "
                              f"{self.dictionary}, got {self.marker_id!r}", where)
        for name in ("marker_size_m", "thickness_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
                raise ConfigError(f"{name} must be a finite number > 0, got {v!r}", where)
        if not 0.0 <= self.black < self.white <= 1.0:
            raise ConfigError(f"need 0 <= black < white <= 1, got {self.black}, {self.white}",
                              where)
        if not (isinstance(self.texels_per_cell, int) and self.texels_per_cell >= 1):
            raise ConfigError(f"texels_per_cell must be an integer >= 1, got "
                              f"{self.texels_per_cell!r}", where)

    @property
    def cells(self) -> int:
        """Cells across the black square: the code's bits plus a one-cell border."""
        return int(aruco_dictionary(self.dictionary).markerSize) + 2

    @property
    def cell_m(self) -> float:
        return self.marker_size_m / self.cells

    @property
    def board_m(self) -> float:
        """Side of the board: the black square and a one-cell white quiet zone around it."""
        return self.marker_size_m + 2.0 * self.cell_m

    def image(self) -> NDArray[np.float32]:
        """(rows, cols, 3) albedo of the printed face, row 0 at the top."""
        k = self.texels_per_cell
        marker = cv2.aruco.generateImageMarker(aruco_dictionary(self.dictionary),
                                               self.marker_id, self.cells * k, borderBits=1)
        printed = np.pad(marker, k, constant_values=255) > 127
        grey = np.where(printed, self.white, self.black).astype(np.float32)
        return np.repeat(grey[:, :, None], 3, axis=2)

    def material(self) -> Material:
        """The slate's material: white, with the marker on the printed face."""
        half = 0.5 * self.board_m
        texture = PlanarTexture(self.image(), origin=(0.5 * self.thickness_m, half, -half),
                                right=(0.0, -1.0, 0.0), down=(0.0, 0.0, 1.0),
                                width_m=self.board_m, height_m=self.board_m,
                                tolerance_m=0.25 * self.thickness_m)
        return Material(f"slate-{self.dictionary}-{self.marker_id}", 0.1,
                        (self.white,) * 3, texture)

    def mesh(self) -> trimesh.Trimesh:
        """The board in the slate's frame."""
        return box((self.thickness_m, self.board_m, self.board_m))

    def marker_corners(self) -> NDArray[np.float64]:
        """(4, 3) corners of the black square in the slate's frame, in OpenCV's order:
        top-left, top-right, bottom-right, bottom-left as the marker is read."""
        h, x = 0.5 * self.marker_size_m, 0.5 * self.thickness_m
        return np.array([[x, h, -h], [x, -h, -h], [x, -h, h], [x, h, h]])
