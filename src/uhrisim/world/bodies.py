"""Articulated (multi-part) meshes for dynamic bodies such as the kicking diver.

A dynamic body is a set of rigid :class:`Part` s. Each part's mesh is given in the body
frame (FRD, metres) at its rest pose, and a chain of revolute :class:`Joint` s moves it as
a function of one scalar *phase* (the diver's flutter-kick phase, radians). Joint angles
are ``bias + amplitude * sin(phase + phase_offset)``.

The ray caster keeps one acceleration structure per part, built once at the rest pose,
and queries it with the rays transformed into the part's frame; changing the phase
therefore costs a few 4x4 products, never a BVH rebuild.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.world.materials import Material


@dataclass(frozen=True)
class Joint:
    """A revolute joint driven by the body's phase.

    Attributes:
        pivot: (3,) point on the axis, body frame (FRD, metres), in the rest pose.
        axis: (3,) rotation axis, body frame (normalised on construction).
        amplitude_rad: oscillation amplitude (radians).
        phase_offset_rad: phase lead of this joint (radians).
        bias_rad: constant offset angle (radians).
    """

    pivot: tuple[float, float, float]
    axis: tuple[float, float, float]
    amplitude_rad: float
    phase_offset_rad: float = 0.0
    bias_rad: float = 0.0

    def __post_init__(self) -> None:
        a = np.asarray(self.axis, dtype=float)
        n = float(np.linalg.norm(a))
        if a.shape != (3,) or not np.isfinite(n) or n == 0.0:
            raise ConfigError(f"must be a non-zero 3-vector, got {self.axis!r}", where="Joint.axis")
        object.__setattr__(self, "axis", tuple(float(v) for v in a / n))
        object.__setattr__(self, "pivot", tuple(float(v) for v in self.pivot))

    def angle(self, phase: float) -> float:
        """Joint angle (radians) at ``phase`` (radians)."""
        return self.bias_rad + self.amplitude_rad * float(np.sin(phase + self.phase_offset_rad))

    def transform(self, phase: float) -> NDArray[np.float64]:
        """4x4 rotation about the pivot at ``phase`` (Rodrigues, in plain floats: cheap)."""
        a = self.angle(phase)
        r, t = self._rotation(math.cos(a), math.sin(a))
        return np.array([[*r[0], t[0]], [*r[1], t[1]], [*r[2], t[2]], [0.0, 0.0, 0.0, 1.0]])

    def transforms(self, phases: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N, 4, 4): :meth:`transform` at each of ``phases`` (N,), the same arithmetic
        element by element (libm's cosine and sine of each angle)."""
        angles = self.bias_rad + self.amplitude_rad * np.sin(phases + self.phase_offset_rad)
        r, t = self._rotation(np.array([math.cos(a) for a in angles.tolist()]),
                              np.array([math.sin(a) for a in angles.tolist()]))
        out = np.zeros((len(angles), 4, 4))
        for i in range(3):
            out[:, i, :3] = np.stack(r[i], axis=-1)
            out[:, i, 3] = t[i]
        out[:, 3, 3] = 1.0
        return out

    def _rotation(self, c: Any, s: Any) -> tuple[tuple[tuple[Any, ...], ...], list[Any]]:
        """Rows of the rotation by the angle of cosine ``c`` and sine ``s`` (floats, or
        (N,) arrays) about the axis, and the translation that keeps the pivot."""
        x, y, z = self.axis
        px, py, pz = self.pivot
        k = 1.0 - c
        r = (
            (c + k * x * x, k * x * y - s * z, k * x * z + s * y),
            (k * x * y + s * z, c + k * y * y, k * y * z - s * x),
            (k * x * z - s * y, k * y * z + s * x, c + k * z * z),
        )
        t = [
            p - (row[0] * px + row[1] * py + row[2] * pz)
            for p, row in zip(self.pivot, r, strict=True)
        ]
        return r, t


@dataclass(frozen=True)
class Part:
    """A rigid piece of a body: rest-pose mesh (body frame) moved by a joint chain.

    ``chain`` is ordered proximal→distal (hip, then ankle): the distal joint's pivot is
    expressed in the rest pose and is carried along by the proximal joints.
    ``material`` overrides the body's material for this part when given; ``label``
    (e.g. ``"hand"``) gives the part its own label ``"<body label>/<label>"`` in label
    images (None: the body's label).
    """

    name: str
    mesh: trimesh.Trimesh
    chain: tuple[Joint, ...] = ()
    material: Material | None = None
    label: str | None = None

    def transform(self, phase: float) -> NDArray[np.float64]:
        """4x4 map from rest-pose body coordinates to posed body coordinates."""
        m = np.eye(4)
        for joint in self.chain:  # proximal first: T = J_hip @ J_ankle
            m = m @ joint.transform(phase)
        return m

    def transforms(self, phases: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N, 4, 4): :meth:`transform` at each of ``phases`` (N,), the joints' products
        one matrix product per joint for all phases."""
        m = np.broadcast_to(np.eye(4), (len(phases), 4, 4))
        for joint in self.chain:
            m = m @ joint.transforms(phases)
        return np.array(m)


#: A part posed farther than this (m) from its body's origin is hidden: a part that is
#: gone (a removed bolt, a bag size not in use) is parked far away, and the ray caster
#: skips it.
HIDDEN_BEYOND_M = 1.0e3


@dataclass(frozen=True)
class ArticulatedMesh:
    """A body made of rigid parts; a plain rigid mesh is one part with no joints.

    ``posed_apart``: every part is posed on its own by ``Scene.set_part_transforms`` (a
    work site's parts by its state: a bolt gone, a lid open, a bag's size), so the ray
    caster must not move parts that share a (here empty) joint chain as one group."""

    parts: tuple[Part, ...]
    posed_apart: bool = False
    _face_offsets: NDArray[np.int64] = field(init=False, repr=False, compare=False)
    #: the distinct joints, the distinct chain prefixes in order (each its parent prefix's
    #: index, 0 the empty chain, and its last joint's), and every part's chain: how
    #: :meth:`part_transforms` poses each joint and each chain once
    _joints: tuple[Joint, ...] = field(init=False, repr=False, compare=False)
    _prefixes: tuple[tuple[int, int], ...] = field(init=False, repr=False, compare=False)
    _part_chain: tuple[int, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if len(self.parts) == 0:
            raise ConfigError("needs at least one part", where="ArticulatedMesh.parts")
        for p in self.parts:
            if len(p.mesh.faces) == 0:
                raise ConfigError(f"part {p.name!r} has no triangles", where="ArticulatedMesh")
        counts = [len(p.mesh.faces) for p in self.parts]
        object.__setattr__(self, "_face_offsets", np.concatenate([[0], np.cumsum(counts)]))
        joints: dict[Joint, int] = {}
        prefixes: dict[tuple[Joint, ...], int] = {(): 0}
        steps: list[tuple[int, int]] = []
        for p in self.parts:
            for n in range(1, len(p.chain) + 1):
                if p.chain[:n] not in prefixes:
                    joint = joints.setdefault(p.chain[n - 1], len(joints))
                    steps.append((prefixes[p.chain[:n - 1]], joint))
                    prefixes[p.chain[:n]] = len(steps)
        object.__setattr__(self, "_joints", tuple(joints))
        object.__setattr__(self, "_prefixes", tuple(steps))
        object.__setattr__(self, "_part_chain", tuple(prefixes[p.chain] for p in self.parts))

    @classmethod
    def from_any(cls, mesh_or_parts: object, name: str = "body") -> ArticulatedMesh:
        """Accept an ArticulatedMesh, a Trimesh, a Part, or a sequence of Trimesh/Part."""
        if isinstance(mesh_or_parts, ArticulatedMesh):
            return mesh_or_parts
        if isinstance(mesh_or_parts, trimesh.Trimesh):
            return cls((Part(name, mesh_or_parts),))
        if isinstance(mesh_or_parts, Part):
            return cls((mesh_or_parts,))
        if isinstance(mesh_or_parts, Sequence) and not isinstance(mesh_or_parts, str):
            parts = []
            for i, item in enumerate(mesh_or_parts):
                if isinstance(item, Part):
                    parts.append(item)
                elif isinstance(item, trimesh.Trimesh):
                    parts.append(Part(f"{name}[{i}]", item))
                else:
                    raise ConfigError(
                        f"item {i} is {type(item).__name__}, expected Trimesh or Part",
                        where=f"body {name!r}",
                    )
            return cls(tuple(parts))
        raise ConfigError(
            "expected a Trimesh, Part, ArticulatedMesh or sequence, "
            f"got {type(mesh_or_parts).__name__}",
            where=f"body {name!r}",
        )

    @property
    def n_faces(self) -> int:
        return int(self._face_offsets[-1])

    @property
    def face_offsets(self) -> NDArray[np.int64]:
        """(n_parts + 1,) start index of each part's faces in the concatenated face list."""
        return self._face_offsets

    def part_transforms(self, phase: float) -> list[NDArray[np.float64]]:
        """Rest→posed 4x4 transform of every part at ``phase``: :meth:`Part.transform`'s
        products, each joint posed once and each chain's product taken from its parent
        prefix's (the same matrix products in the same order); parts sharing a chain (a
        leg's pieces) share the array."""
        joints = [joint.transform(phase) for joint in self._joints]
        products = [np.eye(4)]  # the empty chain's, and the start of every product
        for parent, joint in self._prefixes:
            products.append(products[parent] @ joints[joint])
        return [products[chain] for chain in self._part_chain]

    def part_transforms_many(self, phases: ArrayLike) -> NDArray[np.float64]:
        """(N, parts, 4, 4): :meth:`part_transforms` at each of ``phases`` (N,), every
        chain posed once for all of them."""
        phases = np.asarray(phases, dtype=float).reshape(-1)
        out = np.empty((len(phases), len(self.parts), 4, 4))
        cache: dict[tuple[Joint, ...], NDArray[np.float64]] = {}
        for i, p in enumerate(self.parts):
            if p.chain not in cache:
                cache[p.chain] = p.transforms(phases)
            out[:, i] = cache[p.chain]
        return out

    def triangles_at(self, phase: float, pose: ArrayLike | None = None) -> NDArray[np.float64]:
        """(F, 3, 3) posed triangles; in the body frame, or through the 4x4 ``pose``."""
        return self.triangles_posed(self.part_transforms(phase), pose)

    def triangles_posed(self, transforms: Sequence[NDArray[np.float64]],
                        pose: ArrayLike | None = None) -> NDArray[np.float64]:
        """(F, 3, 3) triangles with every part moved by its rest→posed 4x4 of
        ``transforms``; in the body frame, or through the 4x4 ``pose``."""
        out = []
        for p, t in zip(self.parts, transforms, strict=True):
            m = t if pose is None else np.asarray(pose, dtype=float) @ t
            tri = p.mesh.vertices.view(np.ndarray)[p.mesh.faces]
            out.append(tri @ m[:3, :3].T + m[:3, 3])
        return np.concatenate(out, axis=0)

    def mesh_at(self, phase: float = 0.0) -> trimesh.Trimesh:
        """The whole body as one Trimesh in the body frame at ``phase``."""
        return self.mesh_posed(self.part_transforms(phase))

    def mesh_posed(self, transforms: Sequence[NDArray[np.float64]]) -> trimesh.Trimesh:
        """The whole body as one Trimesh in the body frame, every part moved by its
        rest→posed 4x4 of ``transforms``."""
        meshes = []
        for p, t in zip(self.parts, transforms, strict=True):
            m = p.mesh.copy()
            m.apply_transform(t)
            meshes.append(m)
        return trimesh.util.concatenate(meshes)

    def part_labels(self, body_label: str) -> tuple[str, ...]:
        """Label of every part: ``body_label``, or ``"<body_label>/<part label>"``."""
        return tuple(body_label if p.label is None else f"{body_label}/{p.label}"
                     for p in self.parts)

    def part_materials(self, default: Material) -> tuple[Material, ...]:
        """Material of every part (its own, else ``default``)."""
        return tuple(p.material or default for p in self.parts)

    def face_reflectivity(self, default: Material) -> NDArray[np.float64]:
        """(F,) Lambert μ of every face (part material, else ``default``)."""
        vals = [
            np.full(len(p.mesh.faces), (p.material or default).reflectivity) for p in self.parts
        ]
        return np.concatenate(vals)
