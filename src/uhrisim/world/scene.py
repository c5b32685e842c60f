"""The world: static geometry (sea floor, pilings, meshes) and posed dynamic bodies.

Everything is in world NED metres (``docs/conventions.md``). Static objects are fixed
once added; dynamic bodies (ROV, diver) carry a pose — position (NED) and a body(FRD)→NED
rotation — and, for articulated bodies, a kick phase. ``set_pose`` only stores numbers:
ray casters keep static and dynamic geometry apart and never rebuild the static BVH on a
pose change (see :mod:`uhrisim.world.raycast`).

Every object has a *label* (``Scene.labels`` holds the distinct strings; ids index that
list, so all pilings can share ``"piling"``) and a :class:`~uhrisim.world.materials.Material`
(``Scene.materials`` holds the distinct materials; ray hits carry an index into it).
"""

from __future__ import annotations

import functools
import logging
import math

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import orthonormality_error
from uhrisim.world.bodies import ArticulatedMesh
from uhrisim.world.materials import Material
from uhrisim.world.objects import DynamicBody, StaticObject
from uhrisim.world.raycast import RayCaster, make_raycaster
from uhrisim.world.seafloor import SeaFloor

__all__ = ["Scene"]

log = logging.getLogger(__name__)



def _check_label(label: str, where: str) -> str:
    if not isinstance(label, str) or not label:
        raise ConfigError(f"must be a non-empty string, got {label!r}", where=where)
    return label


def _clean_mesh(mesh: trimesh.Trimesh, where: str) -> trimesh.Trimesh:
    """Copy of ``mesh`` without zero-area faces; ConfigError if nothing is left."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise ConfigError(f"expected a trimesh.Trimesh, got {type(mesh).__name__}", where=where)
    v = np.asarray(mesh.vertices, dtype=float)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if len(f) and not np.all(np.isfinite(v)):
        raise ConfigError("mesh has NaN/inf vertices", where=where)
    if len(f):  # twice the area > 1e-14 m², squared (the cross product spelt out: 2x faster)
        p0 = v[f[:, 0]]
        a, b = v[f[:, 1]] - p0, v[f[:, 2]] - p0
        cx = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
        cy = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
        cz = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        f = f[cx * cx + cy * cy + cz * cz > 1e-28]
    if len(f) == 0:
        raise ConfigError("mesh has no (non-degenerate) triangles", where=where)
    return trimesh.Trimesh(v.copy(), f, process=False, validate=False)


class Scene:
    """Static geometry and dynamic bodies, with labels and materials."""

    def __init__(self) -> None:
        self._static: list[StaticObject] = []
        self._bodies: list[DynamicBody] = []
        self._body_index: dict[str, int] = {}
        self._labels: list[str] = []
        self._materials: list[Material] = []
        self._static_version = 0
        self._seafloor: SeaFloor | None = None
        self._floor_object: StaticObject | None = None  # the sea floor's static object
        self._collision_caster: RayCaster | None = None
        # (static_version, lower corners (K, 3), upper corners (K, 3), objects) of the
        # watertight static meshes, for inside_solid.
        self._solid_boxes: tuple[int, NDArray[np.float64], NDArray[np.float64], list] | None = None

    def __getstate__(self) -> dict:
        # The cached collision caster holds Embree handles, which do not pickle.
        state = self.__dict__.copy()
        state["_collision_caster"] = None
        return state

    # ------------------------------------------------------------------ building
    def _label_id(self, label: str) -> int:
        if label not in self._labels:
            self._labels.append(label)
        return self._labels.index(label)

    def _material_id(self, material: Material) -> int:
        if material not in self._materials:
            self._materials.append(material)
        return self._materials.index(material)

    def add_static(self, mesh: trimesh.Trimesh | SeaFloor, label: str, material: Material) -> None:
        """Add fixed geometry in NED. A :class:`SeaFloor` is also kept for ``depth_at``."""
        _check_label(label, "Scene.add_static.label")
        if not isinstance(material, Material):
            raise ConfigError(f"expected a Material, got {material!r}", where="Scene.add_static")
        is_floor = isinstance(mesh, SeaFloor) and self._seafloor is None
        if isinstance(mesh, SeaFloor):
            if self._seafloor is not None:
                log.warning("scene already has a sea floor; depth_at keeps using the first one")
            else:
                self._seafloor = mesh
            mesh = mesh.mesh
        clean = _clean_mesh(mesh, f"Scene.add_static({label!r})")
        self._static.append(
            StaticObject(
                clean, label, self._label_id(label), material, self._material_id(material)
            )
        )
        if is_floor:
            self._floor_object = self._static[-1]
        self._static_version += 1

    def add_dynamic(
        self,
        name: str,
        mesh_or_parts: object,
        label: str,
        material: Material,
        position_ned: ArrayLike = (0.0, 0.0, 0.0),
        rotation: ArrayLike | None = None,
        kick_phase: float = 0.0,
    ) -> None:
        """Add a movable body given in its body frame (FRD, metres, origin at its centre).

        ``mesh_or_parts``: a Trimesh, a sequence of Trimesh/:class:`~uhrisim.world.bodies.Part`,
        or an :class:`~uhrisim.world.bodies.ArticulatedMesh` (e.g. ``assets.diver_parts()``).
        """
        if not isinstance(name, str) or not name:
            raise ConfigError(
                f"must be a non-empty string, got {name!r}", where="Scene.add_dynamic.name"
            )
        if name in self._body_index:
            raise ConfigError(
                f"a body named {name!r} already exists", where="Scene.add_dynamic.name"
            )
        _check_label(label, "Scene.add_dynamic.label")
        if not isinstance(material, Material):
            raise ConfigError(f"expected a Material, got {material!r}", where="Scene.add_dynamic")
        geometry = ArticulatedMesh.from_any(mesh_or_parts, name)
        ids = [self._material_id(m) for m in geometry.part_materials(material)]
        face_material = np.repeat(np.array(ids, np.int32), np.diff(geometry.face_offsets))
        label_ids = [self._label_id(x) for x in geometry.part_labels(label)]
        face_label = np.repeat(np.array(label_ids, np.int32), np.diff(geometry.face_offsets))
        body = DynamicBody(
            name, geometry, label, self._label_id(label), material, face_material, face_label
        )
        self._body_index[name] = len(self._bodies)
        self._bodies.append(body)
        self.set_pose(name, position_ned, np.eye(3) if rotation is None else rotation, kick_phase)

    def set_pose(
        self,
        name: str,
        position_ned: ArrayLike,
        rotation: ArrayLike,
        kick_phase: float | None = None,
        *,
        checked: bool = True,
    ) -> None:
        """Move body ``name``: position (3,) NED metres, rotation (3, 3) body→NED.

        ``kick_phase`` (radians) re-poses an articulated body's parts; None keeps it.
        Cheap: stores the pose, rebuilds nothing. ``checked=False``: the caller vouches
        for its numbers (float arrays, a finite position and kick phase, a proper
        rotation: the simulation's own poses), which are stored as copies unchecked.
        """
        i = self._body_index.get(name)
        if i is None:
            raise ConfigError(
                f"no dynamic body named {name!r} (have {sorted(self._body_index)})",
                where="Scene.set_pose",
            )
        p = np.array(position_ned, dtype=float)
        r = np.array(rotation, dtype=float)
        k = None if kick_phase is None else float(kick_phase)
        if checked:
            p = p.reshape(-1)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise ConfigError(
                    f"must be 3 finite numbers, got {position_ned!r}",
                    where=f"Scene.set_pose({name!r}).position_ned",
                )
            # Orthonormal (NaN fails the comparison) and proper (det = +1).
            if (r.shape != (3, 3) or not orthonormality_error(r) <= 1e-6
                    or np.linalg.det(r) < 0.0):
                raise ConfigError(
                    "must be a proper 3x3 rotation matrix",
                    where=f"Scene.set_pose({name!r}).rotation",
                )
            if k is not None and not np.isfinite(k):
                raise ConfigError(
                    f"must be finite, got {kick_phase!r}",
                    where=f"Scene.set_pose({name!r}).kick_phase",
                )
        b = self._bodies[i]
        b.position = p
        b.rotation = r
        if k is not None and k != b.kick_phase:
            b.kick_phase = k
            b.part_transforms = b.geometry.part_transforms(k)

    def set_part_transforms(self, name: str, transforms: ArrayLike) -> None:
        """Re-pose an articulated body's parts directly: ``transforms`` (n_parts, 4, 4),
        each part's rest→posed map in the body frame (e.g. from the joint angles of
        :class:`~uhrisim.dynamics.diver_body.DiverSkeleton`). Cheap: stores the matrices;
        a later ``set_pose`` with a ``kick_phase`` replaces them."""
        i = self._body_index.get(name)
        if i is None:
            raise ConfigError(f"no dynamic body named {name!r}", where="Scene.set_part_transforms")
        b = self._bodies[i]
        t = np.array(transforms, dtype=float)
        if t.shape != (len(b.geometry.parts), 4, 4) or not np.all(np.isfinite(t)):
            raise ConfigError(
                f"must be {len(b.geometry.parts)} finite 4x4 matrices, got shape {t.shape}",
                where=f"Scene.set_part_transforms({name!r})",
            )
        b.part_transforms = list(t)

    # ------------------------------------------------------------------ queries
    @property
    def labels(self) -> list[str]:
        """Distinct label strings; label ids in :class:`~uhrisim.world.raycast.RayHits`
        index this list (a copy)."""
        return list(self._labels)

    @property
    def materials(self) -> tuple[Material, ...]:
        """Distinct materials; material ids in :class:`~uhrisim.world.raycast.RayHits`
        index this tuple."""
        return tuple(self._materials)

    def label_id(self, label: str) -> int:
        """Id of ``label``; ConfigError if no object carries it."""
        if label not in self._labels:
            raise ConfigError(
                f"unknown label {label!r} (have {self._labels})", where="Scene.label_id"
            )
        return self._labels.index(label)

    @property
    def body_names(self) -> list[str]:
        """Dynamic body names; body ids in :class:`~uhrisim.world.raycast.RayHits` index
        this list (a copy)."""
        return [b.name for b in self._bodies]

    @property
    def bodies(self) -> tuple[DynamicBody, ...]:
        return tuple(self._bodies)

    @property
    def static_objects(self) -> tuple[StaticObject, ...]:
        return tuple(self._static)

    @property
    def static_version(self) -> int:
        """Increments on every add_static (ray casters rebuild their static BVH lazily)."""
        return self._static_version

    @property
    def seafloor(self) -> SeaFloor | None:
        return self._seafloor

    def pose(self, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """(position NED, rotation body→NED, kick phase) of body ``name`` (copies)."""
        i = self._body_index.get(name)
        if i is None:
            raise ConfigError(f"no dynamic body named {name!r}", where="Scene.pose")
        b = self._bodies[i]
        return b.position.copy(), b.rotation.copy(), b.kick_phase

    def inside_solid(self, p_ned: ArrayLike) -> str | None:
        """Why the point ``p_ned`` (NED, m) is inside the scene's static solid geometry —
        below the sea floor, or inside a watertight static mesh — or None. Dynamic bodies
        are not checked. Cheap enough to ask once per sensor sample (bounding boxes are
        cached per ``static_version``; only meshes whose box holds the point are tested)."""
        p = np.asarray(p_ned, dtype=float).reshape(3)
        north, east, down = p.tolist()
        depth = self.depth_at(north, east)
        if math.isfinite(depth) and down > depth + 1e-6:
            return f"{down - depth:.3f} m below the sea floor"
        if self._solid_boxes is None or self._solid_boxes[0] != self._static_version:
            # the sea floor's height field is answered by depth_at above (and is never
            # a closed solid: testing it costs ~50 ms per scene built)
            solid = [o for o in self._static
                     if o is not self._floor_object and o.mesh.is_watertight]
            lo = np.array([o.mesh.bounds[0] for o in solid]).reshape(-1, 3)
            hi = np.array([o.mesh.bounds[1] for o in solid]).reshape(-1, 3)
            self._solid_boxes = (self._static_version, lo, hi, solid)
        _, lo, hi, solid = self._solid_boxes
        if not solid:  # (the usual open-water scene: no numpy passes over no boxes)
            return None
        for k in np.flatnonzero(np.all(p >= lo, axis=1) & np.all(p <= hi, axis=1)):
            if bool(solid[k].mesh.contains(p.reshape(1, 3))[0]):
                return f"inside a {solid[k].label!r} mesh"
        return None

    def depth_at(self, x_north: ArrayLike, y_east: ArrayLike) -> NDArray[np.float64] | float:
        """Sea-floor depth (m) at NED (north, east); NaN outside it or without a sea floor."""
        if self._seafloor is None:
            x, _ = np.broadcast_arrays(np.asarray(x_north, float), np.asarray(y_east, float))
            out = np.full(x.shape, np.nan)
            return float(out) if out.ndim == 0 else out
        return self._seafloor.depth_at(x_north, y_east)

    def bounds(self) -> NDArray[np.float64]:
        """(2, 3) NED axis-aligned bounds of all static and posed dynamic geometry."""
        boxes = [o.mesh.bounds for o in self._static]
        for b in self._bodies:
            tri = b.geometry.triangles_posed(b.part_transforms, b.pose_matrix()).reshape(-1, 3)
            boxes.append(np.array([tri.min(axis=0), tri.max(axis=0)]))
        if not boxes:
            raise ConfigError("scene is empty", where="Scene.bounds")
        stack = np.array(boxes)
        return np.array([stack[:, 0].min(axis=0), stack[:, 1].max(axis=0)])

    def raycaster(self, backend: str = "embree", threads: int = 1) -> RayCaster:
        """A ray caster over this scene ("embree" or "reference"); create once, reuse.

        ``threads`` > 1 (Embree only) traces large batches against the static geometry on
        that many threads; results are identical.
        """
        return make_raycaster(self, backend, threads)

    def segment_clear(
        self,
        start_ned: ArrayLike,
        end_ned: ArrayLike,
        radius: float,
        exclude: frozenset[str] = frozenset(),
        n_ring: int = 12,
    ) -> float:
        """Fraction (0..1) of the straight move start→end a sphere of ``radius`` can make.

        Approximation (a bundle of parallel rays along the motion): rays start on the
        sphere's leading hemisphere — its front point, a ring of ``n_ring`` points on the
        equator (perpendicular to the motion) and an inner ring of ``n_ring // 2`` points at
        0.6·radius — and the first contact of any of them limits the move. Obstacles thinner
        than the gaps between the rays (about 2π·radius/n_ring) can slip through, and a
        sphere that already overlaps geometry is not detected. Exclude the moving body
        itself via ``exclude``. Uses a cached Embree caster.

        Returns 1.0 for a zero-length move, 0.0 when already touching.
        """
        return self.segment_contact(start_ned, end_ned, radius, exclude, n_ring)[0]

    def segment_contact(
        self,
        start_ned: ArrayLike,
        end_ned: ArrayLike,
        radius: float,
        exclude: frozenset[str] = frozenset(),
        n_ring: int = 12,
    ) -> tuple[float, str, NDArray[np.float64]]:
        """:meth:`segment_clear`'s fraction, what the move first touches — a dynamic
        body's name or a static object's label ("" when the move is free) — and where, the
        first hit point (NED m; NaN when free)."""
        s = np.asarray(start_ned, dtype=float).reshape(3)
        e = np.asarray(end_ned, dtype=float).reshape(3)
        r = float(radius)
        if not np.isfinite(r) or r < 0.0:
            raise ConfigError(
                f"must be >= 0 metres, got {radius!r}", where="Scene.segment_clear.radius"
            )
        if not (np.all(np.isfinite(s)) and np.all(np.isfinite(e))):
            raise ConfigError("start/end must be finite", where="Scene.segment_clear")
        dx, dy, dz = (float(v) for v in e - s)
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length == 0.0:
            return 1.0, "", np.full(3, np.nan)
        d = np.array([dx, dy, dz]) / length
        # a unit vector across the motion, d x (1, 0, 0) or d x (0, 1, 0); then v = d x u
        u = (np.array([0.0, d[2], -d[1]]) if abs(d[0]) < 0.9
             else np.array([-d[2], 0.0, d[0]]))
        u /= math.sqrt(float(u @ u))
        v = np.array([d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2],
                      d[0] * u[1] - d[1] * u[0]])
        # bundle points in the (d, u, v) frame: the front point, the rings (module docstring)
        frame = _ring_offsets(r, max(int(n_ring), 3))
        origins = s + frame @ np.stack([d, u, v])
        dirs = np.tile(d, (len(origins), 1))
        if self._collision_caster is None:
            self._collision_caster = self.raycaster("embree")
        hits = self._collision_caster.cast(origins, dirs, length, exclude)
        first = int(np.argmin(hits.distance))
        travel = float(hits.distance[first])
        if not np.isfinite(travel):
            return 1.0, "", np.full(3, np.nan)
        body = int(hits.body[first])
        what = self._bodies[body].name if body >= 0 else self._labels[int(hits.label[first])]
        return min(max(travel / length, 0.0), 1.0), what, origins[first] + travel * d


@functools.lru_cache(maxsize=16)
def _ring_offsets(r: float, k: int) -> NDArray[np.float64]:
    """(1 + k + k // 2, 3) points of :meth:`Scene.segment_clear`'s ray bundle in the
    frame (along the motion, across u, across v) of a sphere of radius ``r``: its front
    point, a ring of ``k`` on the equator and an inner ring of ``max(k // 2, 3)`` at
    0.6 r, each pushed forward onto the leading hemisphere (read-only)."""
    rows = [(r, 0.0, 0.0)]
    if r > 0.0:
        for rho, count, shift in ((r, k, 0.0), (0.6 * r, max(k // 2, 3), 0.5)):
            ahead = math.sqrt(max(r * r - rho * rho, 0.0))
            for i in range(count):
                angle = 2.0 * math.pi * (i + shift) / count
                rows.append((ahead, rho * math.cos(angle), rho * math.sin(angle)))
    out = np.array(rows)
    out.setflags(write=False)
    return out
