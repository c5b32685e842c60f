"""Ray casting against a :class:`~uhrisim.world.scene.Scene`: Embree and a numpy reference.

A caster reads the scene through :class:`SceneGeometry` (its static objects and posed
bodies, :mod:`uhrisim.world.objects`); the Scene builds casters over itself
(``Scene.raycaster()``), so this module sits below it.

Both back ends answer the same question — for each ray (origin, unit direction, NED
metres) the first surface within ``max_range`` — and return a :class:`RayHits`.

* ``"embree"`` (:class:`EmbreeRayCaster`): Intel Embree through ``embreex``. All static
  geometry lives in one Embree scene, built once (and rebuilt lazily only when
  ``add_static`` is called again). Each dynamic body is split into groups of rigid parts
  that move together (for the diver: core+tank, each leg, each fin); every group has its
  own small Embree scene built once in its rest frame. A cast first traces the static
  scene, then culls the rays against each body's bounding sphere, transforms the
  survivors into each group's frame — so poses and kick phases set through
  ``Scene.set_pose`` are seen without any BVH rebuild — traces those that meet the
  group's rest-frame bounding box, and keeps the nearest hit.
  Embree works in float32 (coordinates more than 1 km from the origin are shifted to the
  geometry's centre first); it only chooses the triangle: the distance is recomputed in
  float64 against that triangle's plane, so results agree with the reference to ~1e-9 m.
  Cost: ~110 ns per ray inside Embree (one core) plus ~1 µs per ray-batch operation in
  numpy; ``threads`` > 1 splits the static query across threads. With numba installed
  (the ``[fast]`` extra) the per-ray tests and arithmetic around Embree — the static
  geometry's box pick, the bodies' bounding-sphere cull (one pass for all bodies), every
  group's sphere-and-box pick of a body (one pass for all its groups; what depends on a
  shared origin alone formed once a group), the float32 rows handed to Embree, the float64
  refinement and the keeping of a group's and a body's hits — run compiled, a pass each
  instead of several numpy calls per body and group (which cost more than Embree itself
  for an articulated diver of ~20 groups); a body's sphere is tested within the static
  hits, before the bodies ahead of it are traced (more rays reach its groups' own tests,
  the same hits); the hits are the same to the bit (tested), ``UHRISIM_NUMBA=0`` runs
  numpy. The group frame's turns of the rays and normals stay numpy's products (BLAS:
  their last bits depend on the batch's shape).
* ``"reference"`` (:class:`ReferenceRayCaster`): Möller–Trumbore in numpy against every
  triangle of the posed world (float64), chunked to bound memory. Slow and obviously
  correct; the tests hold the Embree caster to it.

Conventions: a hit at distance exactly ``max_range`` counts; triangles are two-sided (no
back-face culling); a ray that starts exactly on a surface may or may not report that
surface at distance ~0 (float32 inside Embree), so start rays a hair off surfaces.
"""

from __future__ import annotations

import itertools
import logging
import math
import weakref
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cache
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.compiled import jit, jit_with
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import row_dots
from uhrisim.world.bodies import HIDDEN_BEYOND_M, ArticulatedMesh
from uhrisim.world.objects import DynamicBody, StaticObject

log = logging.getLogger(__name__)

_UNIT_TOL = 1e-5  # allowed | |d| - 1 |
_EMBREE_FAR = 1e30  # stands in for an infinite max_range in float32
_MIN_RAYS_PER_THREAD = 2048  # smaller batches are not worth a thread hand-off
_SHIFT_BEYOND_M = 1000.0  # geometry farther than this from its origin is shifted for float32


@dataclass(frozen=True)
class RayHits:
    """First-hit results for N rays (all arrays have N rows).

    Attributes:
        distance: (N,) float64 metres along the ray; ``np.inf`` on a miss or beyond range.
        label: (N,) int32 index into ``Scene.labels``; -1 on a miss.
        normal: (N, 3) float64 unit surface normal in world NED, turned to face the ray
            origin (``normal · direction <= 0``); zeros on a miss.
        reflectivity: (N,) float64 Lambert μ of the surface hit; 0 on a miss.
        body: (N,) int32 index into ``Scene.body_names`` of the dynamic body hit; -1 for
            static geometry or a miss.
        material: (N,) int32 index into ``Scene.materials`` of the surface hit; -1 on a
            miss (the camera reads its optical albedo there).
    """

    distance: NDArray[np.float64]
    label: NDArray[np.int32]
    normal: NDArray[np.float64]
    reflectivity: NDArray[np.float64]
    body: NDArray[np.int32]
    material: NDArray[np.int32]

    @property
    def hit(self) -> NDArray[np.bool_]:
        """(N,) True where the ray hit something within range."""
        return np.isfinite(self.distance)

    def points(self, origins: ArrayLike, directions: ArrayLike) -> NDArray[np.float64]:
        """(N, 3) hit points in NED (NaN on a miss)."""
        o = np.asarray(origins, dtype=float)
        d = np.asarray(directions, dtype=float)
        t = np.where(self.hit, self.distance, np.nan)
        return o + d * t[:, None]

    @staticmethod
    def empty(n: int) -> RayHits:
        """All-miss result for ``n`` rays."""
        return RayHits(
            distance=np.full(n, np.inf),
            label=np.full(n, -1, dtype=np.int32),
            normal=np.zeros((n, 3)),
            reflectivity=np.zeros(n),
            body=np.full(n, -1, dtype=np.int32),
            material=np.full(n, -1, dtype=np.int32),
        )


def validate_rays(
    origins: ArrayLike, directions: ArrayLike, max_range: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Check and convert ray inputs; raises ConfigError naming the bad field.

    Returns (origins, directions, max_range): directions (N, 3); origins (N, 3), or (3,)
    when one origin is shared by every ray (a sensor's fan; cheaper to trace)."""
    o = np.ascontiguousarray(origins, dtype=np.float64)
    d = np.ascontiguousarray(directions, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != 3:
        raise ConfigError(
            f"must have shape (N, 3), got {d.shape}", where="RayCaster.cast.directions"
        )
    if o.shape != (3,) and o.shape != d.shape:
        raise ConfigError(
            f"must have shape (N, 3) matching directions {d.shape}, or (3,) for one shared "
            f"origin; got {o.shape}",
            where="RayCaster.cast.origins",
        )
    try:
        r = float(max_range)
    except (TypeError, ValueError):
        raise ConfigError(
            f"must be a positive number of metres, got {max_range!r}",
            where="RayCaster.cast.max_range",
        ) from None
    if not r > 0.0:  # also rejects NaN
        raise ConfigError(
            f"must be a positive number of metres, got {max_range!r}",
            where="RayCaster.cast.max_range",
        )
    # Cheap NaN/inf screens: a sum is finite iff every term is (for sane magnitudes).
    if not np.isfinite(np.sum(o)):
        raise ConfigError("contains NaN or inf", where="RayCaster.cast.origins")
    if len(d):
        dev = row_dots(d, d) - 1.0  # |d|² − 1
        if not (dev.max() <= 2.0 * _UNIT_TOL and dev.min() >= -2.0 * _UNIT_TOL):  # NaN fails
            norms2 = dev + 1.0
            i = int(np.argmax(~(np.abs(dev) <= 2.0 * _UNIT_TOL)))
            raise ConfigError(
                f"must be finite unit vectors; row {i} has length {np.sqrt(norms2[i]):.6g}",
                where="RayCaster.cast.directions",
            )
    return o, d, r


def _unit_normals(tri: NDArray[np.float64]) -> NDArray[np.float64]:
    """(F, 3) unit normals of (F, 3, 3) triangles (right-hand rule v0→v1→v2)."""
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length > 0.0, length, 1.0)


def _refine_hits(
    face: NDArray[np.int64],
    normal_table: NDArray[np.float64],
    plane_table: NDArray[np.float64],
    o: NDArray[np.float64],
    d: NDArray[np.float64],
    limit: NDArray[np.float64] | float,
    embree_tfar: Callable[[NDArray[np.intp]], NDArray[np.float32]],
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Float64 distances of Embree's float32 hits, refined on the hit triangle's plane.

    ``face``: (N,) triangle hit or -1; ``normal_table``: (F + 1, 3) unit normal and
    ``plane_table``: (F + 1,) n·v0 of each triangle's plane, each with a final all-zero
    row that face -1 reads; ``o``: (N, 3) ray origins or (3,) one shared origin, ``d``:
    (N, 3) unit directions, in the frame of the triangles (metres); ``limit``: the range, m
    (scalar or (N,)). t = (n·v0 − n·o) / (n·d); rays (nearly) in the triangle's plane keep
    Embree's distance, ``embree_tfar(rows)``. Hits refined past ``limit`` become misses.
    Computed for every row at once (no gather/scatter of the hit rows: a sensor's rays
    mostly hit). Returns (face or -1, distance or inf, normal turned to face the ray
    origin, zero on a miss); ``face`` is updated in place.
    """
    nh = np.take(normal_table, face, axis=0)  # misses read the zero row
    n_dot_o = nh @ o if o.ndim == 1 else row_dots(nh, o)
    compiled = _compiled_refine_rows()
    if compiled is not None:  # the same operations per row, compiled
        t = np.empty(len(face))
        grazing = np.empty(len(face), dtype=np.int64)
        plane = np.take(plane_table, face)
        limits = np.asarray(limit, dtype=float).reshape(-1)
        grazing = grazing[:compiled(face, nh, d, plane, n_dot_o, limits, t, grazing)]
        if len(grazing):
            t[grazing] = embree_tfar(grazing)
            beyond = grazing[t[grazing] > (limits if len(limits) == 1 else limits[grazing])]
            face[beyond], nh[beyond], t[beyond] = -1, 0.0, np.inf
        return face, t, nh
    dn = row_dots(nh, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (np.take(plane_table, face) - n_dot_o) / dn  # misses: 0/0
    hit = face >= 0
    grazing = np.flatnonzero(hit & (np.abs(dn) <= 1e-9))
    if len(grazing):
        t[grazing] = embree_tfar(grazing)
    np.multiply(nh, np.copysign(1.0, -dn)[:, None], out=nh)  # face the ray origin
    beyond = np.flatnonzero(hit & (t > limit))  # refined past the limit: a miss
    if len(beyond):
        face[beyond] = -1
        nh[beyond] = 0.0
    t[face < 0] = np.inf
    return face, t, nh


def _refine_rows(face, nh, d, plane, n_dot_o, limit, t, grazing):  # type: ignore[no-untyped-def]
    """:func:`_refine_hits`' arithmetic per row, compiled (numba): ``t`` the distance on
    the hit triangle's plane (``plane`` n·v0, ``n_dot_o`` n·o, ``nh`` the normal, turned in
    place to face the ray origin), a hit refined past ``limit`` ((1,) or (N,)) made a miss
    in ``face``, ``nh`` and ``t``, misses at inf. Rows whose ray (nearly) lies in the
    plane are listed in ``grazing`` (their count is returned) for Embree's distance."""
    n_grazing = 0
    for i in range(face.shape[0]):
        dn = nh[i, 0] * d[i, 0] + nh[i, 1] * d[i, 1] + nh[i, 2] * d[i, 2]
        t[i] = (plane[i] - n_dot_o[i]) / dn
        sign = math.copysign(1.0, -dn)
        for k in range(3):
            nh[i, k] *= sign
        if face[i] < 0:
            t[i] = math.inf
        elif abs(dn) <= 1e-9:
            grazing[n_grazing] = i
            n_grazing += 1
        elif t[i] > limit[0 if limit.shape[0] == 1 else i]:
            face[i] = -1
            for k in range(3):
                nh[i, k] = 0.0
            t[i] = math.inf
    return n_grazing


@cache
def _compiled_refine_rows():  # type: ignore[no-untyped-def]
    return jit(_refine_rows, numpy_errors=True)


#: :func:`_embree_rays`' shift for geometry that is not shifted
_NO_SHIFT = np.zeros(3)


def _embree_rays(o, d, limit, shift, o32, d32, far):  # type: ignore[no-untyped-def]
    """What :meth:`_EmbreeMesh.intersect` hands Embree, in one compiled pass (numba): the
    float32 rows of the origins less ``shift`` (``o`` (N, 3), or (1, 3) shared) into
    ``o32``, of the directions ``d`` (N, 3) into ``d32``, and each ray's far end, its
    ``limit`` ((1,) or (N,) m) padded by 1e-6 relative and absolute (at most
    ``_EMBREE_FAR``), into ``far``: numpy's operations, the same bits."""
    for i in range(d.shape[0]):
        row = 0 if o.shape[0] == 1 else i
        for k in range(3):
            o32[i, k] = np.float32(o[row, k] - shift[k])
            d32[i, k] = np.float32(d[i, k])
        padded = limit[0 if limit.shape[0] == 1 else i] * (1.0 + 1e-6) + 1e-6
        far[i] = np.float32(padded if padded < _EMBREE_FAR else _EMBREE_FAR)


@cache
def _compiled_embree_rays():  # type: ignore[no-untyped-def]
    return jit(_embree_rays)


def _face_to_ray(normal: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Flip rows of ``normal`` that point along ``d`` so they face the ray origin."""
    s = np.einsum("ij,ij->i", normal, d)
    return normal * np.where(s > 0.0, -1.0, 1.0)[:, None]


class SceneGeometry(Protocol):
    """What a ray caster reads of a scene (a :class:`~uhrisim.world.scene.Scene` is one)."""

    @property
    def static_objects(self) -> tuple[StaticObject, ...]:
        """Fixed meshes (NED), in the order added."""
        ...

    @property
    def static_version(self) -> int:
        """Changes whenever static geometry is added (casters rebuild lazily)."""
        ...

    @property
    def bodies(self) -> tuple[DynamicBody, ...]:
        """Posed dynamic bodies; body ids in :class:`RayHits` index this tuple."""
        ...

    @property
    def body_names(self) -> list[str]:
        """Names of the dynamic bodies, in the order of ``bodies``."""
        ...


class RayCaster(ABC):
    """Casts rays into a scene; created once, reused every tick (sees later set_pose calls)."""

    backend: str = ""

    def __init__(self, scene: SceneGeometry) -> None:
        self._scene = scene

    @property
    def scene(self) -> SceneGeometry:
        return self._scene

    def cast(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        max_range: float,
        exclude: frozenset[str] = frozenset(),
        checked: bool = True,
    ) -> RayHits:
        """First hit of each ray within ``max_range`` metres.

        Args:
            origins: (N, 3) ray origins, world NED metres, or (3,): one origin shared
                by every ray (a sensor's fan; cheaper).
            directions: (N, 3) unit directions, world NED (|d| within 1e-5 of 1).
            max_range: positive range limit in metres (``np.inf`` allowed).
            exclude: names of dynamic bodies to ignore (e.g. the sensor's own vehicle).
                Names that are not bodies of the scene are ignored.
            checked: False when the caller made the rays valid (a sensor's own rays:
                finite float64 C-contiguous arrays of those shapes, unit directions, a
                positive range), whose checks are then skipped.

        Raises:
            ConfigError: bad shapes, NaN/inf, non-unit directions, max_range <= 0.
        """
        o, d, r = (validate_rays(origins, directions, max_range) if checked
                   else (origins, directions, float(max_range)))
        if len(d) == 0:
            return RayHits.empty(0)
        unknown = set(exclude) - set(self._scene.body_names)
        if unknown:
            log.debug("exclude names not in the scene (ignored): %s", sorted(unknown))
        return self._cast(o, d, r, frozenset(exclude))

    @abstractmethod
    def _cast(
        self,
        o: NDArray[np.float64],
        d: NDArray[np.float64],
        max_range: float,
        exclude: frozenset[str],
    ) -> RayHits: ...


# --------------------------------------------------------------------------- reference


class ReferenceRayCaster(RayCaster):
    """Möller–Trumbore against every triangle, float64, chunked (slow, obviously correct)."""

    backend = "reference"

    def __init__(self, scene: SceneGeometry, max_pairs: int = 1 << 18) -> None:
        super().__init__(scene)
        self._max_pairs = int(max_pairs)

    def world_triangles(
        self, exclude: frozenset[str] = frozenset()
    ) -> tuple[
        NDArray[np.float64],
        NDArray[np.int32],
        NDArray[np.float64],
        NDArray[np.int32],
        NDArray[np.int32],
    ]:
        """All posed triangles (F, 3, 3) in NED with per-face label, reflectivity, body and
        material id."""
        tris, labels, refl, body, mat = [], [], [], [], []
        for obj in self._scene.static_objects:
            t = obj.mesh.vertices.view(np.ndarray)[obj.mesh.faces]
            tris.append(t)
            labels.append(np.full(len(t), obj.label_id, dtype=np.int32))
            refl.append(np.full(len(t), obj.material.reflectivity))
            body.append(np.full(len(t), -1, dtype=np.int32))
            mat.append(np.full(len(t), obj.material_id, dtype=np.int32))
        for bi, b in enumerate(self._scene.bodies):
            if b.name in exclude:
                continue
            t = b.geometry.triangles_posed(b.part_transforms, b.pose_matrix())
            tris.append(t)
            labels.append(b.face_label)
            refl.append(b.face_reflectivity)
            body.append(np.full(len(t), bi, dtype=np.int32))
            mat.append(b.face_material)
        if not tris:
            z = np.zeros((0, 3, 3))
            none = np.zeros(0, np.int32)
            return z, none, np.zeros(0), none, none
        return (
            np.concatenate(tris),
            np.concatenate(labels),
            np.concatenate(refl),
            np.concatenate(body),
            np.concatenate(mat),
        )

    def _cast(self, o, d, max_range, exclude):  # type: ignore[no-untyped-def]
        n = len(d)
        o = np.broadcast_to(o, d.shape)
        tri, lab, refl, body, mat = self.world_triangles(exclude)
        out = RayHits.empty(n)
        if len(tri) == 0:
            return out
        v0 = tri[:, 0]
        e1 = tri[:, 1] - v0
        e2 = tri[:, 2] - v0
        best_t = np.full(n, np.inf)
        best_f = np.full(n, -1, dtype=np.int64)
        chunk = max(1, self._max_pairs // len(tri))
        with np.errstate(divide="ignore", invalid="ignore"):
            for a in range(0, n, chunk):
                oc, dc = o[a : a + chunk], d[a : a + chunk]
                # Möller & Trumbore (1997), "Fast, minimum storage ray/triangle intersection".
                p = np.cross(dc[:, None, :], e2[None, :, :])  # (R, F, 3)
                det = np.einsum("fk,rfk->rf", e1, p)
                inv = 1.0 / det
                s = oc[:, None, :] - v0[None, :, :]
                u = np.einsum("rfk,rfk->rf", s, p) * inv
                q = np.cross(s, e1[None, :, :])
                v = np.einsum("rk,rfk->rf", dc, q) * inv
                t = np.einsum("fk,rfk->rf", e2, q) * inv
                ok = (
                    (det != 0.0)
                    & (u >= 0.0)
                    & (v >= 0.0)
                    & (u + v <= 1.0)
                    & (t >= 0.0)
                    & (t <= max_range)
                )
                t = np.where(ok, t, np.inf)
                f = np.argmin(t, axis=1)
                tmin = t[np.arange(len(oc)), f]
                best_t[a : a + chunk] = tmin
                best_f[a : a + chunk] = np.where(np.isfinite(tmin), f, -1)
        hit = best_f >= 0
        fi = best_f[hit]
        normals = np.zeros((n, 3))
        normals[hit] = _face_to_ray(_unit_normals(tri[fi]), d[hit])
        return RayHits(
            distance=best_t,
            label=np.where(hit, lab[np.maximum(best_f, 0)], -1).astype(np.int32),
            normal=normals,
            reflectivity=np.where(hit, refl[np.maximum(best_f, 0)], 0.0),
            body=np.where(hit, body[np.maximum(best_f, 0)], -1).astype(np.int32),
            material=np.where(hit, mat[np.maximum(best_f, 0)], -1).astype(np.int32),
        )


# --------------------------------------------------------------------------- embree


class _EmbreeMesh:
    """One Embree scene over triangles in a local frame, plus float64 per-face planes.

    All triangles go into a single Embree geometry, so Embree's primitive id is the face
    index into the concatenated ``tris_local``. Coordinates are handed to Embree in
    float32, shifted by ``shift`` (the bounds centre) only when the geometry lies more than
    ``_SHIFT_BEYOND_M`` from the local origin; Embree only has to pick the triangle, the
    distance is recomputed in float64.
    """

    def __init__(self, device: object, tris_local: list[NDArray[np.float64]]) -> None:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        tri = np.concatenate(tris_local)
        allv = tri.reshape(-1, 3)
        lo, hi = allv.min(axis=0), allv.max(axis=0)
        centre = 0.5 * (lo + hi)
        far_away = float(np.max(np.abs(np.concatenate([lo, hi])))) > _SHIFT_BEYOND_M
        self.shift: NDArray[np.float64] | None = centre if far_away else None
        self.scene = rtcore_scene.EmbreeScene(device)
        v = allv - centre if far_away else allv
        TriangleMesh(
            scene=self.scene,
            vertices=np.ascontiguousarray(v, dtype=np.float32),
            indices=np.arange(len(v), dtype=np.int32).reshape(-1, 3),
        )
        # Commit (build the BVH) now, so that later queries may run from several threads.
        one = np.zeros((1, 3), dtype=np.float32)
        self.scene.run(one, one + np.float32(1.0), dists=np.ones(1, dtype=np.float32))
        normal = _unit_normals(tri)
        # Per face: unit normal and n·v0 (the plane), float64, for the distance refinement;
        # a last all-zero row answers index -1 (a miss) with a zero normal.
        self.normal = np.vstack([normal, np.zeros((1, 3))])
        self.plane_w = np.append(np.einsum("ij,ij->i", normal, tri[:, 0]), 0.0)
        self.centre = centre
        self.radius = float(np.max(np.linalg.norm(allv - centre, axis=1)))
        pad = 1e-6 * (1.0 + float(np.max(hi - lo)))  # keeps the box test conservative
        self.box_lo, self.box_hi = lo - pad, hi + pad

    def box_candidates(
        self, o: NDArray[np.float64], d_cols: NDArray[np.float64], limit: NDArray[np.float64]
    ) -> NDArray[np.intp]:
        """Indices of the rays whose segment [0, limit] may meet this mesh's bounding box
        (slab test; conservative). Local frame: ``o`` (3,) one shared origin or (N, 3),
        ``d_cols`` (3, N) unit directions, ``limit`` (N,) m.

        An axis whose slab holds every origin is skipped (it could only shorten the
        segments): a vehicle above a sea floor tests one slab, not three."""
        enter = np.zeros(len(limit))
        leave = np.array(limit, dtype=float)
        for k in range(3):
            lo, hi = self.box_lo[k], self.box_hi[k]
            o_k = o[k] if o.ndim == 1 else o[:, k]
            if np.all((lo <= o_k) & (o_k <= hi)):  # every ray starts within the slab
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / d_cols[k]
                t_lo, t_hi = (lo - o_k) * inv, (hi - o_k) * inv
            # fmin/fmax skip the NaN of a ray lying in a slab's plane (no constraint there).
            np.fmax(enter, np.fmin(t_lo, t_hi), out=enter)
            np.fmin(leave, np.fmax(t_lo, t_hi), out=leave)
        return np.flatnonzero(enter <= leave)

    def intersect(
        self,
        o: NDArray[np.float64],
        d: NDArray[np.float64],
        tfar: NDArray[np.float64] | float,
        pool: ThreadPoolExecutor | None = None,
        threads: int = 1,
    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """First hits within ``tfar`` of rays given in the local frame.

        Returns (face index or -1, float64 distance or inf, unit normal in the local frame
        turned to face the ray origin, zero on a miss).
        """
        n = len(d)
        lim = float(tfar) if np.ndim(tfar) == 0 else np.asarray(tfar)
        compiled = _compiled_embree_rays()
        if compiled is not None:  # the same float32 rows in one pass
            o32, d32 = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
            far = np.empty(n, np.float32)
            compiled(o.reshape(-1, 3), d, np.reshape(lim, -1),
                     _NO_SHIFT if self.shift is None else self.shift, o32, d32, far)
        else:
            o32 = (o - self.shift if self.shift is not None else o).astype(np.float32)
            if o32.ndim == 1:  # one shared origin: Embree still wants one row per ray (a view)
                o32 = np.broadcast_to(o32, (n, 3))
            d32 = d.astype(np.float32)
            if np.ndim(lim) == 0:
                far = np.full(n, min(lim * (1.0 + 1e-6) + 1e-6, _EMBREE_FAR), dtype=np.float32)
            else:
                far = np.minimum(lim * (1.0 + 1e-6) + 1e-6, _EMBREE_FAR).astype(np.float32)
        if pool is not None and threads > 1 and n >= _MIN_RAYS_PER_THREAD * 2:
            # Embree queries are thread-safe and embreex releases the GIL while tracing.
            cuts = np.linspace(0, n, threads + 1).astype(int)
            jobs = [
                pool.submit(self.scene.run, o32[a:b], d32[a:b], dists=far[a:b])
                for a, b in itertools.pairwise(cuts)
            ]
            face = np.concatenate([j.result() for j in jobs]).astype(np.int64)
        else:
            face = self.scene.run(o32, d32, dists=far).astype(np.int64)  # primID; -1 = miss

        def embree_tfar(rows: NDArray[np.intp]) -> NDArray[np.float32]:
            return self.scene.run(o32[rows], d32[rows], dists=far[rows], output=1)["tfar"]

        return _refine_hits(face, self.normal, self.plane_w, o, d, lim, embree_tfar)


class _BodyBVH:
    """A dynamic body for Embree: one scene per group of rigid parts that move together
    (identical joint chains; every part apart if the body is ``posed_apart``), built once
    in the rest pose; ``face_offset`` numbers the groups' faces consecutively and
    ``face_map`` takes those numbers to the body's own face order (for per-face
    reflectivity)."""

    def __init__(self, device: object, geometry: ArticulatedMesh) -> None:
        chains: dict[tuple, list[int]] = {}
        for i, p in enumerate(geometry.parts):
            chains.setdefault(i if geometry.posed_apart else p.chain, []).append(i)
        offsets = geometry.face_offsets
        self.groups: list[_EmbreeMesh] = []
        group_part, face_maps = [], []
        for members in chains.values():
            tris = [
                geometry.parts[i].mesh.vertices.view(np.ndarray)[geometry.parts[i].mesh.faces]
                for i in members
            ]
            self.groups.append(_EmbreeMesh(device, tris))
            group_part.append(members[0])  # its transform moves the whole group
            face_maps.append(
                np.concatenate([np.arange(offsets[i], offsets[i + 1]) for i in members])
            )
        self.group_part = group_part
        counts = [len(g.normal) - 1 for g in self.groups]
        self.face_offset = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        self.face_map = np.concatenate(face_maps).astype(np.int64)
        self.centres = np.array([g.centre for g in self.groups])
        self.radii = np.array([g.radius for g in self.groups])
        self.box_lo = np.array([g.box_lo for g in self.groups])
        self.box_hi = np.array([g.box_hi for g in self.groups])
        #: (pose key, part transforms, :meth:`posed`'s answer) of the last pose seen
        self._posed: tuple | None = None

    def posed(self, b: DynamicBody) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                             NDArray[np.bool_], NDArray[np.float64], float
                                             ] | None:
        """The groups of body ``b`` as posed now: (G, 3, 3) rotations and (G, 3)
        translations group frame → NED, which groups are shown (hidden parts are parked
        beyond ``HIDDEN_BEYOND_M``), and the whole body's bounding sphere (centre, radius:
        it encloses every shown group's); None when nothing is shown. Kept while the pose
        and the parts' transforms stay the same (the sensors of a tick cast several times
        between two poses)."""
        key = (b.position.tobytes(), b.rotation.tobytes())
        kept = self._posed
        if kept is not None and kept[0] == key and kept[1] is b.part_transforms:
            return kept[2]
        pose = b.pose_matrix()
        frames = np.array([pose @ b.part_transforms[i] for i in self.group_part])  # → NED
        rots, trans = frames[:, :3, :3], frames[:, :3, 3]
        centres = np.einsum("gij,gj->gi", rots, self.centres) + trans
        shown = np.einsum("gi,gi->g", trans - pose[:3, 3], trans - pose[:3, 3]) \
            < HIDDEN_BEYOND_M ** 2
        posed = None
        if shown.any():
            seen = centres[shown]
            bc = 0.5 * (seen.min(axis=0) + seen.max(axis=0))
            br = float(np.max(np.linalg.norm(seen - bc, axis=1) + self.radii[shown]))
            posed = (rots, trans, shown, bc, br)
        self._posed = (key, b.part_transforms, posed)
        return posed

    @staticmethod
    def _numpy_group_rays(mesh: _EmbreeMesh, cull: _RayCuller, o: NDArray[np.float64],
                          d: NDArray[np.float64], bound: NDArray[np.float64],
                          centre: NDArray[np.float64], R: NDArray[np.float64],
                          t: NDArray[np.float64]) -> NDArray[np.intp]:
        """The rays that meet a group's posed bounding sphere (centre, its radius) within
        ``bound`` and then its rest-frame box (group frame → NED: ``R``, ``t``)."""
        near = cull.candidates(bound, centre, mesh.radius)  # cheap sphere test first
        if len(near) == 0:
            return near
        o_local = (o - t) @ R
        if o_local.ndim == 2:
            o_local = o_local[near]
        d_cols = R.T @ np.take(d, near, axis=0).T
        return near[mesh.box_candidates(o_local, d_cols, bound[near])]

    def trace(
        self,
        o: NDArray[np.float64],
        d: NDArray[np.float64],
        limit: NDArray[np.float64],
        rots: NDArray[np.float64],
        trans: NDArray[np.float64],
        shown: NDArray[np.bool_] | None = None,
    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Nearest hit on the posed body within ``limit`` (N,) m for rays from ``o`` ((3,)
        one shared origin, or (N, 3)) along ``d`` (N, 3), NED. Group g is posed by
        ``rots[g]``, ``trans[g]`` (group frame → NED). Each group traces only the rays that
        meet its bounding sphere and then its rest-frame bounding box (much tighter than
        the sphere for limbs), the groups in turn, each within the nearest hit so far.
        ``shown``: which groups to trace (None: all; hidden parts are skipped).
        Returns (body face or -1, distance or inf, NED normal facing the ray origin, zero on
        a miss)."""
        n = len(d)
        face = np.full(n, -1, dtype=np.int64)
        bound = np.array(limit, dtype=float)  # nearest hit so far (or the limit)
        normal = np.zeros((n, 3))
        centres = np.einsum("gij,gj->gi", rots, self.centres) + trans
        show = np.ones(len(self.groups), bool) if shown is None else shown
        select, select_hits = _compiled_group_rays(), _compiled_group_hits()
        if select is not None:  # every group's rays in one compiled pass
            found = np.empty(n, dtype=np.int64)
            chosen = np.empty(len(self.groups) * n, dtype=np.int64)
            counts = np.zeros(len(self.groups), dtype=np.int64)
            select(o.reshape(-1, 3), d, bound, centres, self.radii, rots, trans,
                   self.box_lo, self.box_hi, show, chosen, counts)
        else:
            cull = _RayCuller(o, d)
        # (compiled: only the groups that some ray may meet)
        for g in np.flatnonzero(show if select is None else counts):
            mesh, R = self.groups[g], rots[g]
            if select is not None:
                sel = chosen[g * n : g * n + counts[g]]
            else:
                sel = self._numpy_group_rays(mesh, cull, o, d, bound, centres[g], R, trans[g])
            if len(sel) == 0:
                continue
            o_local = (o - trans[g]) @ R  # rows of R^T (o - t)
            d_cols = R.T @ np.take(d, sel, axis=0).T  # (3, M) directions in the group frame
            f, t, nrm = mesh.intersect(
                o_local if o_local.ndim == 1 else o_local[sel], d_cols.T, bound[sel]
            )
            if select is not None:  # the group's hits written in one pass
                hit = found[:select_hits(f, t, sel, self.face_offset[g], bound, face, found)]
            else:
                hit = np.flatnonzero(f >= 0)
                bound[sel[hit]] = t[hit]
                face[sel[hit]] = f[hit] + self.face_offset[g]
            if len(hit):
                normal[sel[hit]] = nrm[hit] @ R.T
        return face, np.where(face >= 0, bound, np.inf), normal


    def trace_fans(
        self,
        origins: NDArray[np.float64],
        d: NDArray[np.float64],
        limit: NDArray[np.float64],
        rots: NDArray[np.float64],
        trans: NDArray[np.float64],
        spans: tuple[NDArray[np.float64], NDArray[np.float64]],
    ) -> tuple[NDArray[np.intp], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`trace` for N fans of R rays, fan i from ``origins[i]`` along ``d[i]``
        ((N, R, 3); ``spans`` their least and greatest component per axis, (N, 3) each)
        against the body posed for it: group g by ``rots[i, g]``, ``trans[i, g]`` ((N, G,
        3, 3), (N, G, 3)); ``limit`` (N·R,). Each group is one Embree query over the rays
        of all fans that meet its posed bounding sphere and rest-frame box. Returns the
        rows (of the N·R, fan by fan) that may meet the body, and for each, as
        :meth:`trace` does, face, distance and normal."""
        n_fans, n_rays = d.shape[:2]
        flat = d.reshape(-1, 3)
        centres = np.einsum("ngij,gj->ngi", rots, self.centres) + trans

        # The whole body's sphere per fan (it encloses every posed group's) culls first.
        lo, hi = centres.min(axis=1), centres.max(axis=1)
        whole = 0.5 * (lo + hi)
        reach = np.max(np.linalg.norm(centres - whole[:, None], axis=2) + self.radii, axis=1)
        r = _padded(reach)  # as the sphere test pads it
        fans = np.flatnonzero(_fans_reach(origins, spans, float(np.max(limit, initial=0.0)),
                                          whole - r[:, None], whole + r[:, None]))
        sphere_rays = _compiled_fan_sphere_rays() or _fan_sphere_rays
        body_rows = np.empty(len(fans) * n_rays, dtype=np.int64)
        body_rows = body_rows[:sphere_rays(fans, n_rays, origins, flat, limit, whole, reach,
                                           body_rows)]
        face = np.full(len(body_rows), -1, dtype=np.int64)
        bound = limit[body_rows]  # nearest hit so far (or the limit)
        normal = np.zeros((len(body_rows), 3))
        body_fan, body_d = body_rows // n_rays, flat[body_rows]
        near = np.empty(len(body_rows), dtype=np.int64)
        for g, mesh in enumerate(self.groups):
            # the group's sphere (_RayCuller's conservative test) on the rays near the body
            rg = np.full(n_fans, mesh.radius)
            count = sphere_rays(body_fan, 0, origins, body_d, bound, centres[:, g], rg, near)
            if count == 0:
                continue
            at = near[:count]  # indices into body_rows
            fan = body_fan[at]
            R = rots[:, g]
            o_local = np.einsum("nij,ni->nj", R, origins - trans[:, g])[fan]  # R^T (o - t)
            d_local = np.einsum("mij,mi->mj", R[fan], body_d[at])  # R^T d
            box = mesh.box_candidates(o_local, d_local.T, bound[at])
            if len(box) == 0:
                continue
            sel = at[box]
            f, t, nrm = mesh.intersect(o_local[box], d_local[box], bound[sel])
            hit = np.flatnonzero(f >= 0)
            rows = sel[hit]
            bound[rows] = t[hit]
            face[rows] = f[hit] + self.face_offset[g]
            normal[rows] = np.einsum("mij,mj->mi", R[fan[box[hit]]], nrm[hit])  # R n
        return body_rows, face, np.where(face >= 0, bound, np.inf), normal


def _fan_sphere_rays(fans, n_rays, origins, d, limit, centres, radii,
                     rows):  # type: ignore[no-untyped-def]
    """The rays of fans ``fans`` (R = ``n_rays`` each, rows fan·R + k of ``d`` (N·R, 3)
    and ``limit``; or, with ``n_rays`` 0, row j of fan ``fans[j]``) whose segment
    [0, limit] may touch the fan's sphere (``centres`` (N, 3), ``radii`` (N,)):
    :func:`_ray_meets_sphere`, :class:`_RayCuller`'s test, written to ``rows`` in
    increasing order (row numbers; with ``n_rays`` 0, indices j); returns their count.
    Compiled (numba) where it can be."""
    count = 0
    per_fan = n_rays if n_rays > 0 else 1
    for j in range(len(fans)):
        f = fans[j]
        v0, v1, v2, vv, r = _sphere_seen_from(origins[f], centres[f], radii[f])
        first = f * n_rays if n_rays > 0 else j
        for row in range(first, first + per_fan):
            if _ray_meets_sphere(v0, v1, v2, vv, r, d[row], limit[row]):
                rows[count] = row
                count += 1
    return count


def _group_rays(origins, d, bound, centres, radii, rots, trans, box_lo, box_hi, shown,
                chosen, counts):  # type: ignore[no-untyped-def]
    """For each shown group g of a body, the rays (indices into ``d`` (N, 3), NED unit)
    whose segment [0, ``bound``] may meet the group's posed bounding sphere (``centres``
    (G, 3) NED, ``radii`` (G,)) and its rest-frame box [``box_lo[g]``, ``box_hi[g]``]
    (group frame → NED: ``rots`` (G, 3, 3), ``trans`` (G, 3)), written to
    ``chosen[g·N : g·N + counts[g]]`` in increasing order. ``origins``: (N, 3), or (1, 3)
    shared by every ray. The tests of :class:`_RayCuller` and
    :meth:`_EmbreeMesh.box_candidates` (conservative: a superset of theirs, as every
    group is tested within the bound before any of them is traced), compiled (numba)."""
    n = d.shape[0]
    shared = origins.shape[0] == 1
    for g in range(centres.shape[0]):
        counts[g] = 0
        if not shown[g]:
            continue
        # one shared origin: what depends on it alone is formed once a group
        v0, v1, v2, vv, r = _sphere_seen_from(origins[0], centres[g], radii[g])
        o0, o1, o2 = _in_group_frame(origins[0], rots[g], trans[g])
        count = 0
        for i in range(n):
            if not shared:
                v0, v1, v2, vv, r = _sphere_seen_from(origins[i], centres[g], radii[g])
            if not _ray_meets_sphere(v0, v1, v2, vv, r, d[i], bound[i]):
                continue
            if not shared:
                o0, o1, o2 = _in_group_frame(origins[i], rots[g], trans[g])
            enter, leave = 0.0, bound[i]
            for k in range(3):  # slab k of the box, in the group frame
                o_k = o0 if k == 0 else (o1 if k == 1 else o2)
                d_k = d[i, 0] * rots[g, 0, k] + d[i, 1] * rots[g, 1, k] + d[i, 2] * rots[g, 2, k]
                lo, hi = box_lo[g, k] - 1e-9, box_hi[g, k] + 1e-9
                if d_k == 0.0:
                    if o_k < lo or o_k > hi:
                        leave = -1.0
                    continue
                t_lo, t_hi = (lo - o_k) / d_k, (hi - o_k) / d_k
                enter = max(enter, min(t_lo, t_hi))
                leave = min(leave, max(t_lo, t_hi))
            if enter <= leave * (1.0 + 1e-9) + 1e-9:
                chosen[g * n + count] = i
                count += 1
        counts[g] = count


def _in_group_frame(o, rot, trans):  # type: ignore[no-untyped-def]
    """The point ``o`` (3,) NED in the frame of a group posed by ``rot`` (3, 3) and
    ``trans`` (3,) (group frame → NED): the components of R^T (o − t)."""
    a, b, c = o[0] - trans[0], o[1] - trans[1], o[2] - trans[2]
    return (a * rot[0, 0] + b * rot[1, 0] + c * rot[2, 0],
            a * rot[0, 1] + b * rot[1, 1] + c * rot[2, 1],
            a * rot[0, 2] + b * rot[1, 2] + c * rot[2, 2])


def _group_hits(f, t, sel, offset, bound, face, hit):  # type: ignore[no-untyped-def]
    """A group's hits kept by :meth:`_BodyBVH.trace`, compiled (numba): for each of its
    rays ``sel`` (indices into the body's rays) with a face ``f`` (≥ 0; -1 a miss), the
    distance ``t`` into ``bound`` and the face numbered from ``offset`` into ``face``;
    the indices into ``sel`` of those rays go to ``hit`` in increasing order; returns
    their count."""
    count = 0
    for i in range(f.shape[0]):
        if f[i] >= 0:
            bound[sel[i]] = t[i]
            face[sel[i]] = f[i] + offset
            hit[count] = i
            count += 1
    return count


def _nearer_hits(rows, face, t, nrm, face_map, face_label, face_reflectivity,
                 face_material, body_index, distance, label, normal, reflectivity, body,
                 material):  # type: ignore[no-untyped-def]
    """:func:`_keep_nearer` compiled (numba): a body's hit on ray ``rows[i]`` (``face``
    ≥ 0) that is nearer than ``distance`` holds is written into the hits' arrays."""
    for i in range(face.shape[0]):
        row = rows[i]
        if face[i] < 0 or not t[i] < distance[row]:
            continue
        distance[row] = t[i] if t[i] >= 0.0 else 0.0  # np.maximum(t, 0.0)
        body_face = face_map[face[i]]
        label[row] = face_label[body_face]
        reflectivity[row] = face_reflectivity[body_face]
        material[row] = face_material[body_face]
        for k in range(3):
            normal[row, k] = nrm[i, k]
        body[row] = body_index


def _rays_near_box(mesh: _EmbreeMesh, o: NDArray[np.float64], d: NDArray[np.float64],
                   max_range: float) -> NDArray[np.intp]:
    """:meth:`_EmbreeMesh.box_candidates` of ``mesh`` for the rays (``o`` (N, 3) or (3,)
    shared, ``d`` (N, 3)) within ``max_range``: one compiled pass (numba, the same
    arithmetic and the same rays), else its numpy passes."""
    compiled = _compiled_box_rays()
    if compiled is None:
        return mesh.box_candidates(o, d.T, np.full(len(d), max_range))
    rows = np.empty(len(d), dtype=np.int64)
    return rows[:compiled(o.reshape(-1, 3), d, float(max_range), mesh.box_lo, mesh.box_hi,
                          rows)]


def _box_rays(origins, d, limit, box_lo, box_hi, rows):  # type: ignore[no-untyped-def]
    """:meth:`_EmbreeMesh.box_candidates` per ray, compiled (numba): a slab that holds
    every origin (``origins`` (N, 3), or (1, 3) shared) skipped, fmin/fmax ignoring the
    NaN of a ray in a slab's plane; the rays (``d`` (N, 3)) whose segment [0, ``limit``]
    may meet the box go to ``rows`` in increasing order; returns their count."""
    skip = np.zeros(3, np.bool_)
    for k in range(3):
        skip[k] = True
        for i in range(origins.shape[0]):
            if not (box_lo[k] <= origins[i, k] and origins[i, k] <= box_hi[k]):
                skip[k] = False
                break
    count = 0
    for i in range(d.shape[0]):
        row = 0 if origins.shape[0] == 1 else i
        enter, leave = 0.0, limit
        for k in range(3):
            if skip[k]:
                continue
            inv = 1.0 / d[i, k]
            t_lo, t_hi = (box_lo[k] - origins[row, k]) * inv, (box_hi[k] - origins[row, k]) * inv
            near = t_hi if t_lo != t_lo else (t_lo if t_hi != t_hi else min(t_lo, t_hi))
            far = t_hi if t_lo != t_lo else (t_lo if t_hi != t_hi else max(t_lo, t_hi))
            enter = enter if near != near else max(enter, near)
            leave = leave if far != far else min(leave, far)
        if enter <= leave:
            rows[count] = i
            count += 1
    return count


def _rays_near_spheres(o: NDArray[np.float64], d: NDArray[np.float64],
                       limit: NDArray[np.float64], centres: list[NDArray[np.float64]],
                       radii: list[float]) -> list[NDArray[np.intp]]:
    """For each sphere (``centres`` NED, ``radii``), the indices of the rays (``o`` (N, 3)
    or (3,) shared, ``d`` (N, 3)) whose segment [0, ``limit``] may touch it
    (:class:`_RayCuller`'s test): one compiled pass over the rays for all of them (numba),
    else a :class:`_RayCuller` pass per sphere."""
    compiled = _compiled_spheres_rays()
    if compiled is None or not centres:
        cull = _RayCuller(o, d)
        return [cull.candidates(limit, c, r) for c, r in zip(centres, radii, strict=True)]
    n = len(d)
    rows = np.empty(len(centres) * n, dtype=np.int64)
    counts = np.empty(len(centres), dtype=np.int64)
    compiled(o.reshape(-1, 3), d, limit, np.array(centres), np.array(radii), rows, counts)
    return [rows[k * n: k * n + counts[k]] for k in range(len(centres))]


def _spheres_rays(origins, d, limit, centres, radii, rows, counts):  # type: ignore[no-untyped-def]
    """:func:`_rays_near_spheres` compiled (numba): sphere k's rays (``origins`` (N, 3),
    or (1, 3) shared) in increasing order at ``rows[k·N : k·N + counts[k]]``."""
    n = d.shape[0]
    shared = origins.shape[0] == 1
    for k in range(centres.shape[0]):
        count = 0
        v0, v1, v2, vv, r = _sphere_seen_from(origins[0], centres[k], radii[k])
        for i in range(n):  # (one shared origin: the sphere as seen from it, formed once)
            if not shared:
                v0, v1, v2, vv, r = _sphere_seen_from(origins[i], centres[k], radii[k])
            if _ray_meets_sphere(v0, v1, v2, vv, r, d[i], limit[i]):
                rows[k * n + count] = i
                count += 1
        counts[k] = count


def _sphere_seen_from(o, centre, radius):  # type: ignore[no-untyped-def]
    """The sphere (``centre`` (3,), ``radius``) as :func:`_ray_meets_sphere` takes it for
    rays from ``o`` (3,): c − o by component, |c − o|² and the radius padded to keep the
    test conservative. Loops over many rays from one origin form it once."""
    v0, v1, v2 = centre[0] - o[0], centre[1] - o[1], centre[2] - o[2]
    return v0, v1, v2, v0 * v0 + v1 * v1 + v2 * v2, _padded(radius)


def _padded(radius):  # type: ignore[no-untyped-def]
    """A bounding sphere's radius (a number or an array) grown by a relative and an
    absolute margin, so that rounding never culls a ray that meets the body."""
    return radius * (1.0 + 1e-6) + 1e-6


def _ray_meets_sphere(v0, v1, v2, vv, r, d, limit):  # type: ignore[no-untyped-def]
    """:class:`_RayCuller`'s test for one ray along ``d`` (3,) within ``limit``, the
    sphere given by :func:`_sphere_seen_from`: miss distance² vv − t_ca² ≤ r² and
    −r ≤ t_ca ≤ limit + r, t_ca = (c − o)·d."""
    tca = d[0] * v0 + d[1] * v1 + d[2] * v2
    return vv - tca * tca <= r * r and tca + r >= 0.0 and tca - r <= limit


#: The ray/bounding-sphere test's functions, compiled into the kernels that call them.
_SPHERE_TEST = (_sphere_seen_from, _padded, _ray_meets_sphere)


@cache
def _compiled_box_rays():  # type: ignore[no-untyped-def]
    return jit(_box_rays, numpy_errors=True)


@cache
def _compiled_spheres_rays():  # type: ignore[no-untyped-def]
    return jit_with(_spheres_rays, _SPHERE_TEST)


@cache
def _compiled_group_rays():  # type: ignore[no-untyped-def]
    return jit_with(_group_rays, (*_SPHERE_TEST, _in_group_frame))


@cache
def _compiled_group_hits():  # type: ignore[no-untyped-def]
    return jit(_group_hits)


@cache
def _compiled_nearer_hits():  # type: ignore[no-untyped-def]
    return jit(_nearer_hits)


@cache
def _compiled_fan_sphere_rays():  # type: ignore[no-untyped-def]
    return jit_with(_fan_sphere_rays, _SPHERE_TEST)


class EmbreeRayCaster(RayCaster):
    """Embree-backed caster: static BVH built once, one BVH per rigid group of each body."""

    backend = "embree"

    def __init__(self, scene: SceneGeometry, threads: int = 1) -> None:
        super().__init__(scene)
        if not isinstance(threads, int) or threads < 1:
            raise ConfigError(
                f"must be a positive integer, got {threads!r}", where="Scene.raycaster.threads"
            )
        self.threads = threads
        self._pool: ThreadPoolExecutor | None = None
        if threads > 1:
            self._pool = ThreadPoolExecutor(threads, thread_name_prefix="uhrisim-embree")
            weakref.finalize(self, self._pool.shutdown, wait=False)
        try:
            from embreex import rtcore
        except ImportError as exc:  # pragma: no cover - embreex is a core dependency
            raise ConfigError(
                f"embreex is not installed ({exc})", where="Scene.raycaster(backend='embree')"
            ) from None
        self._device = rtcore.EmbreeDevice()
        self._static: _EmbreeMesh | None = None
        self._static_version = -1
        # Per static face: label and μ, each with a last entry that face -1 (a miss) reads.
        self._static_label = np.array([-1], dtype=np.int32)
        self._static_refl = np.array([0.0])
        self._static_material = np.array([-1], dtype=np.int32)
        self._parts: dict[str, _BodyBVH] = {}
        self._sync()

    def _sync(self) -> None:
        """Build what the scene gained since the last cast (never on a pose change)."""
        sc = self._scene
        if self._static_version != sc.static_version:
            objs = sc.static_objects
            if objs:
                tris = [o.mesh.vertices.view(np.ndarray)[o.mesh.faces] for o in objs]
                self._static = _EmbreeMesh(self._device, tris)
                pairs = zip(tris, objs, strict=True)
                self._static_label = np.concatenate(
                    [np.full(len(t), o.label_id, np.int32) for t, o in pairs] + [[-1]]
                ).astype(np.int32)
                self._static_refl = np.concatenate(
                    [
                        np.full(len(t), o.material.reflectivity)
                        for t, o in zip(tris, objs, strict=True)
                    ]
                    + [[0.0]]
                )
                self._static_material = np.concatenate(
                    [
                        np.full(len(t), o.material_id, np.int32)
                        for t, o in zip(tris, objs, strict=True)
                    ]
                    + [[-1]]
                ).astype(np.int32)
            else:
                self._static = None
                self._static_label = np.array([-1], dtype=np.int32)
                self._static_refl = np.array([0.0])
                self._static_material = np.array([-1], dtype=np.int32)
            self._static_version = sc.static_version
        for b in sc.bodies:
            if b.name not in self._parts:
                self._parts[b.name] = _BodyBVH(self._device, b.geometry)

    def _cast(self, o, d, max_range, exclude):  # type: ignore[no-untyped-def]
        self._sync()
        n = len(d)
        # Only rays that meet the static geometry's bounding box go to Embree (a vehicle in
        # mid-water looking level often sees no static geometry at all).
        static = self._static
        near = None if static is None else _rays_near_box(static, o, d, max_range)
        if static is not None and near is not None and len(near) == n:
            face, best, normal = static.intersect(o, d, max_range, self._pool, self.threads)
        else:
            face = np.full(n, -1, dtype=np.int64)
            best = np.full(n, np.inf)
            normal = np.zeros((n, 3))
            if static is not None and near is not None and len(near):
                face[near], best[near], normal[near] = static.intersect(
                    o if o.ndim == 1 else o[near], d[near], max_range, self._pool, self.threads
                )
        np.maximum(best, 0.0, out=best)
        label = np.take(self._static_label, face)  # -1 → the -1 sentinel at the end
        refl = np.take(self._static_refl, face)
        material = np.take(self._static_material, face)
        body = np.full(n, -1, dtype=np.int32)
        shown_bodies = [(bi, b, posed) for bi, b in enumerate(self._scene.bodies)
                        if b.name not in exclude
                        and (posed := self._parts[b.name].posed(b)) is not None]
        # Whole-body bounding spheres (each encloses every shown group's) cull first, all
        # bodies within the static hits at once: a superset of the rays that meet each
        # body within the nearest hit so far, whose group spheres trace() tests again.
        near_body = _rays_near_spheres(o, d, np.minimum(best, max_range),
                                       [posed[3] for _, _, posed in shown_bodies],
                                       [posed[4] for _, _, posed in shown_bodies]
                                       ) if shown_bodies else []
        for (bi, b, posed), body_idx in zip(shown_bodies, near_body, strict=True):
            if len(body_idx) == 0:
                continue
            bvh = self._parts[b.name]
            rots, trans, shown = posed[:3]
            face, t, nrm = bvh.trace(
                o if o.ndim == 1 else np.take(o, body_idx, axis=0),
                np.take(d, body_idx, axis=0),
                np.minimum(best[body_idx], max_range),
                rots,
                trans,
                None if shown.all() else shown,
            )
            hits = RayHits(best, label, normal, refl, body, material)
            _keep_nearer(hits, body_idx, bi, b, bvh.face_map, face, t, nrm)
        return RayHits(
            distance=best,
            label=label,
            normal=normal,
            reflectivity=refl,
            body=body,
            material=material,
        )

    def cast_fans(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        max_range: float,
        poses: Mapping[str, tuple[ArrayLike, ArrayLike | None]],
        checked: bool = True,
    ) -> RayHits:
        """First hits of N fans of R rays (N sensors in N worlds at once): fan i from
        ``origins[i]`` ((N, 3), NED m) along ``directions[i]`` ((N, R, 3), unit), within
        ``max_range`` m. The scene's static geometry is every fan's; each body named in
        ``poses`` stands, in fan i's world, at ``pose[i]`` (4x4 body→NED, ``pose`` (N, 4,
        4)) with kick phase ``phases[i]`` (``poses[name] = (pose, phases)``; phases None:
        the rest pose); bodies not named are not seen. One Embree query for the static
        geometry and one per rigid group of each body, over all N·R rays. Returns the
        hits of the N·R rays, fan by fan (row i·R + k: fan i, ray k). ``checked=False``:
        the caller made the rays valid (finite origins, finite unit directions, a positive
        range: a sensor's own fans), whose checks are then skipped."""
        d3 = np.asarray(directions, dtype=float)
        n_fans, n_rays = d3.shape[:2]
        o_fans = np.asarray(origins, dtype=float).reshape(n_fans, 3)
        if not checked:
            d, r = np.ascontiguousarray(d3).reshape(-1, 3), float(max_range)
        elif not np.all(np.isfinite(o_fans)):
            raise ConfigError("origins must be finite", where="EmbreeRayCaster.cast_fans")
        else:
            _, d, r = validate_rays(np.zeros(3), d3.reshape(-1, 3), max_range)
        d3 = d.reshape(d3.shape)
        spans = _fan_spans(d3)  # (N, 3) each: per-axis reach
        self._sync()
        hits = RayHits.empty(len(d))
        static = self._static
        fans = (np.arange(n_fans) if static is None else
                np.flatnonzero(_fans_reach(o_fans, spans, r, static.box_lo, static.box_hi)))
        if static is not None and fans.size:  # the static geometry, for the fans that reach it
            rows = (fans[:, None] * n_rays + np.arange(n_rays)).ravel()
            seen = self._cast(np.repeat(o_fans[fans], n_rays, axis=0), d[rows], r,
                              frozenset(self._scene.body_names))
            for field in ("distance", "label", "normal", "reflectivity", "body", "material"):
                getattr(hits, field)[rows] = getattr(seen, field)
        # each ray's reach: its static hit or the range (the range alone where no fan met
        # the static geometry); after each body only that body's rays can change it
        met_static = static is not None and fans.size > 0
        limit = np.minimum(hits.distance, r) if met_static else np.full(len(d), r)
        bodies = self._scene.bodies
        for name, (pose, phases) in poses.items():
            bi = next((i for i, b in enumerate(bodies) if b.name == name), None)
            if bi is None:
                raise ConfigError(f"no dynamic body named {name!r}",
                                  where="EmbreeRayCaster.cast_fans")
            b, bvh = bodies[bi], self._parts[name]
            pose = np.asarray(pose, dtype=float).reshape(n_fans, 4, 4)
            parts = (b.geometry.part_transforms_many(phases) if phases is not None  # (N, P, 4, 4)
                     else np.broadcast_to(np.array(b.part_transforms),
                                          (n_fans, len(b.part_transforms), 4, 4)))
            frames = pose[:, None] @ parts[:, bvh.group_part]  # (N, G, 4, 4) group → NED
            rows, face, t, nrm = bvh.trace_fans(o_fans, d3, limit,
                                                frames[..., :3, :3], frames[..., :3, 3], spans)
            _keep_nearer(hits, rows, bi, b, bvh.face_map, face, t, nrm)
            limit[rows] = np.minimum(hits.distance[rows], r)
        return hits


def _fan_spans(d: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The least and greatest component per axis of each fan's rays (``d`` (N, R, 3)):
    (N, 3) each; compiled (numba) where it can be."""
    compiled = _compiled_fan_spans()
    if compiled is None:
        by_axis = np.ascontiguousarray(d.transpose(0, 2, 1))  # (N, 3, R)
        return by_axis.min(axis=2), by_axis.max(axis=2)
    lo, hi = np.empty((len(d), 3)), np.empty((len(d), 3))
    compiled(d, lo, hi)
    return lo, hi


def _fan_spans_loops(d, lo, hi):  # type: ignore[no-untyped-def]
    """:func:`_fan_spans`' loops, into ``lo`` and ``hi`` (each fan's six extremes kept in
    locals while its rays stream past: ~40 % less time than updating the arrays)."""
    for i in range(d.shape[0]):
        lo0, lo1, lo2 = d[i, 0, 0], d[i, 0, 1], d[i, 0, 2]
        hi0, hi1, hi2 = lo0, lo1, lo2
        for j in range(1, d.shape[1]):
            x, y, z = d[i, j, 0], d[i, j, 1], d[i, j, 2]
            lo0, lo1, lo2 = min(lo0, x), min(lo1, y), min(lo2, z)
            hi0, hi1, hi2 = max(hi0, x), max(hi1, y), max(hi2, z)
        lo[i, 0], lo[i, 1], lo[i, 2] = lo0, lo1, lo2
        hi[i, 0], hi[i, 1], hi[i, 2] = hi0, hi1, hi2


@cache
def _compiled_fan_spans():  # type: ignore[no-untyped-def]
    return jit(_fan_spans_loops)


def _fans_reach(origins: NDArray[np.float64],
                spans: tuple[NDArray[np.float64], NDArray[np.float64]], max_range: float,
                box_lo: NDArray[np.float64], box_hi: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which fans (origins (N, 3); ``spans`` the least and greatest direction component
    of each fan's rays per axis, (N, 3) each) may reach the box [box_lo, box_hi] within
    ``max_range``: the box of all their segments' points meets it (conservative; per axis,
    o + t·d for t in [0, max_range] spans o + max_range·min(d, 0) to
    o + max_range·max(d, 0))."""
    if not np.isfinite(max_range):
        return np.ones(len(origins), dtype=bool)
    near = origins + max_range * np.minimum(spans[0], 0.0)
    far = origins + max_range * np.maximum(spans[1], 0.0)
    return np.all((far >= box_lo) & (near <= box_hi), axis=1)


def _keep_nearer(hits: RayHits, rows: NDArray[np.intp], bi: int, b: DynamicBody,
                 face_map: NDArray[np.int64], face: NDArray[np.int64],
                 t: NDArray[np.float64], nrm: NDArray[np.float64]) -> None:
    """Body ``b`` (index ``bi``) hit by the rays ``rows`` of ``hits`` (its group-numbered
    ``face``, distance ``t``, NED normal ``nrm``; -1 a miss) where nearer than what
    ``hits`` holds (a tie keeps the static surface), written into ``hits``."""
    compiled = _compiled_nearer_hits()
    if compiled is not None:
        compiled(rows, face, t, nrm, face_map, b.face_label, b.face_reflectivity,
                 b.face_material, bi, hits.distance, hits.label, hits.normal,
                 hits.reflectivity, hits.body, hits.material)
        return
    hit = np.flatnonzero(face >= 0)
    hit = hit[t[hit] < hits.distance[rows[hit]]]
    sel = rows[hit]
    hits.distance[sel] = np.maximum(t[hit], 0.0)
    body_faces = face_map[face[hit]]
    hits.label[sel] = b.face_label[body_faces]
    hits.reflectivity[sel] = b.face_reflectivity[body_faces]
    hits.material[sel] = b.face_material[body_faces]
    hits.normal[sel] = nrm[hit]
    hits.body[sel] = bi


class _RayCuller:
    """Conservative ray/bounding-sphere tests for a batch of rays (unit directions).

    For a sphere (centre c, radius r) a ray may touch it within ``limit`` when its miss
    distance² |c − o|² − t_ca² ≤ r² with t_ca = (c − o)·d, and −r ≤ t_ca ≤ limit + r.
    When every ray starts at the same point (a sonar ping) only ``d @ (c − o)`` is needed;
    otherwise o·o and o·d are computed once and reused for every body's sphere. numpy:
    the reference of the compiled passes (:func:`_rays_near_spheres`, the groups' and the
    fans' picks), and what runs without numba.
    """

    def __init__(self, o: NDArray[np.float64], d: NDArray[np.float64]) -> None:
        """``o``: (N, 3) origins or (3,) one shared origin; ``d``: (N, 3) directions."""
        self.o, self.d = o, d
        self.o0: NDArray[np.float64] | None = o if o.ndim == 1 else None
        if self.o0 is None:
            flat = o.ravel()  # o is C-contiguous: every row equals the previous one?
            if np.array_equal(flat[3:], flat[:-3]):
                self.o0 = o[0]
            else:
                self.oo = row_dots(o, o)
                self.od = row_dots(o, d)

    def candidates(
        self, limit: NDArray[np.float64], centre: NDArray[np.float64], radius: float
    ) -> NDArray[np.intp]:
        """Indices of rays whose segment [0, limit] may touch the sphere."""
        c = np.asarray(centre, dtype=float)
        if self.o0 is not None:
            v = c - self.o0
            tca = self.d @ v
            d2 = float(v @ v) - tca * tca
        else:
            tca = self.d @ c - self.od
            d2 = (float(c @ c) - 2.0 * (self.o @ c) + self.oo) - tca * tca
        r = _padded(radius)
        return np.flatnonzero((d2 <= r * r) & (tca + r >= 0.0) & (tca - r <= limit))


def make_raycaster(scene: SceneGeometry, backend: str = "embree", threads: int = 1) -> RayCaster:
    """Ray caster of the named back end ("embree" or "reference") over ``scene``.

    ``threads`` > 1 splits the static-geometry Embree query of large batches across that
    many threads (Embree releases the GIL); results are identical to ``threads=1``.
    """
    if backend == "embree":
        return EmbreeRayCaster(scene, threads)
    if backend == "reference":
        return ReferenceRayCaster(scene)
    raise ConfigError(
        f"unknown backend {backend!r}; expected 'embree' or 'reference'",
        where="Scene.raycaster.backend",
    )
