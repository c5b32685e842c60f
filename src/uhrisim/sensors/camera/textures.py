"""Textures for the camera: the albedo of a hit on a picture printed on an object, or on
a rippled sand floor.

A :class:`~uhrisim.world.materials.Material` may carry a
:class:`~uhrisim.world.materials.PlanarTexture` (a diver's slate with a fiducial marker)
or a :class:`~uhrisim.world.materials.RippleTexture` (sand ripples). A texture is given
in the object's own frame, so a hit point is taken there first: through the posed body's
pose (and its one part's transform) for a dynamic body, as it is (NED) for a static
object. Only materials with a texture cost anything; a scene without one never reaches
this module. A picture is *sharp* (printed cells: the adaptive sampler renders every
pixel on it exactly); ripples vary smoothly over a coarse cell and are interpolated
like shading.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.world.materials import Material, PlanarTexture, RippleTexture
from uhrisim.world.objects import DynamicBody


@dataclass(frozen=True)
class SceneTextures:
    """The textured materials of a scene: (material id, material) pairs, (M + 1,) tables
    of which material ids are textured and which have a sharp picture (their last entry,
    read by id -1, is False) and the scene's bodies (hit body ids index them)."""

    by_material: tuple[tuple[int, Material], ...]
    is_textured: NDArray[np.bool_]
    is_sharp: NDArray[np.bool_]
    bodies: tuple[DynamicBody, ...]
    #: (M + 1,) 1 where the material has sand ripples, 2 a picture, else 0; and (M + 1, 6)
    #: the ripples' :meth:`~uhrisim.world.materials.RippleTexture.constants` (for the
    #: compiled formation, :mod:`.fused`, which renders ripples itself)
    kind: NDArray[np.int8]
    ripples: NDArray[np.float64]

    @staticmethod
    def of(materials: tuple[Material, ...], bodies: tuple[DynamicBody, ...]
           ) -> SceneTextures | None:
        """The scene's textures, or None when no material has one."""
        pairs = tuple((i, m) for i, m in enumerate(materials) if m.texture is not None)
        if not pairs:
            return None
        textured = np.zeros(len(materials) + 1, bool)
        textured[[i for i, _ in pairs]] = True
        sharp = np.zeros(len(materials) + 1, bool)
        sharp[[i for i, m in pairs if isinstance(m.texture, PlanarTexture)]] = True
        kind = np.where(sharp, 2, textured.astype(np.int8)).astype(np.int8)
        ripples = np.zeros((len(materials) + 1, 6))
        for i, m in pairs:
            if isinstance(m.texture, RippleTexture):
                ripples[i] = m.texture.constants()
        return SceneTextures(pairs, textured, sharp, bodies, kind, ripples)

    def textured(self, material: NDArray[np.integer]) -> NDArray[np.bool_]:
        """Whether each hit's material (id, -1 for open water) has a texture."""
        return np.take(self.is_textured, material)

    def sharp(self, material: NDArray[np.integer]) -> NDArray[np.bool_]:
        """Whether each hit's material (id, -1 for open water) has a sharp picture."""
        return np.take(self.is_sharp, material)

    def _object_frame(self, body: int, points_ned: NDArray[np.float64]) -> NDArray[np.float64]:
        """Points (N, 3) NED in the frame of body ``body`` (-1: static, NED itself)."""
        if body < 0:
            return points_ned
        b = self.bodies[body]
        if len(b.geometry.parts) != 1:
            raise ConfigError(
                f"body {b.name!r} has {len(b.geometry.parts)} parts: a textured material "
                "must be on a one-part body or a static object", where="camera texture")
        local = (points_ned - b.position) @ b.rotation  # rows of R^T (p - t)
        part = b.part_transforms[0]
        return (local - part[:3, 3]) @ part[:3, :3]

    def albedo(self, albedo: NDArray[np.float32], material: NDArray[np.integer],
               body: NDArray[np.integer], points_ned: NDArray[np.float64]
               ) -> NDArray[np.float32]:
        """(N, 3) ``albedo`` of N hits with each textured hit's albedo from its texture
        (a copy where anything changed); ``material``, ``body``: (N,) ids, ``points_ned``
        (N, 3)."""
        out = albedo
        for material_id, mat in self.by_material:
            rows = np.flatnonzero(material == material_id)
            for b in np.unique(body[rows]):
                sel = rows[body[rows] == b]
                if out is albedo:
                    out = albedo.copy()
                out[sel] = mat.albedo_at(self._object_frame(int(b), points_ned[sel]))
        return out
