"""What a :class:`~uhrisim.world.scene.Scene` holds: fixed meshes and posed dynamic bodies.

Both are in world NED metres (``docs/conventions.md``); each carries its label id (an
index into ``Scene.labels``) and its :class:`~uhrisim.world.materials.Material` (with its
index into ``Scene.materials``; a body has one per face, its parts may differ). The
scene creates and poses them; ray casters (:mod:`uhrisim.world.raycast`) read them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from uhrisim.world.bodies import ArticulatedMesh
from uhrisim.world.materials import Material


@dataclass(frozen=True)
class StaticObject:
    """A fixed mesh in NED with its label id, material and material id."""

    mesh: trimesh.Trimesh
    label: str
    label_id: int
    material: Material
    material_id: int = 0


class DynamicBody:
    """A movable body: geometry in its body frame (FRD) plus the current pose.

    Mutated only through ``Scene.set_pose``; read the pose with ``Scene.pose``.
    """

    def __init__(
        self,
        name: str,
        geometry: ArticulatedMesh,
        label: str,
        label_id: int,
        material: Material,
        face_material: NDArray[np.int32] | None = None,
        face_label: NDArray[np.int32] | None = None,
    ) -> None:
        """``face_material``: (F,) index into ``Scene.materials`` of every face (None: 0);
        ``face_label``: (F,) index into ``Scene.labels`` of every face (None: ``label_id``,
        parts may carry their own, see :class:`~uhrisim.world.bodies.Part`)."""
        self.name = name
        self.geometry = geometry
        self.label = label
        self.label_id = label_id
        self.material = material
        self.face_reflectivity = geometry.face_reflectivity(material)
        self.face_reflectivity.setflags(write=False)
        self.face_material = (
            np.zeros(geometry.n_faces, np.int32)
            if face_material is None
            else np.asarray(face_material, dtype=np.int32)
        )
        self.face_material.setflags(write=False)
        self.face_label = (
            np.full(geometry.n_faces, label_id, np.int32)
            if face_label is None
            else np.asarray(face_label, dtype=np.int32)
        )
        self.face_label.setflags(write=False)
        self.position = np.zeros(3)
        self.rotation = np.eye(3)
        self.kick_phase = 0.0
        self.part_transforms = geometry.part_transforms(0.0)

    def pose_matrix(self) -> NDArray[np.float64]:
        """4x4 body(FRD)→NED transform."""
        m = np.eye(4)
        m[:3, :3] = self.rotation
        m[:3, 3] = self.position
        return m

    def mesh_world(self) -> trimesh.Trimesh:
        """The posed body as one Trimesh in NED (for plotting and export; not a hot path)."""
        mesh = self.geometry.mesh_posed(self.part_transforms)
        mesh.apply_transform(self.pose_matrix())
        return mesh
