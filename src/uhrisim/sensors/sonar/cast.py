"""Casting a ping: the sonar's ray fan into the world, and the hits inside its window.

Rays start at the sonar's origin (world NED, m) along unit directions in NED; the caster
(:class:`RayCaster`, e.g. ``Scene.raycaster()``) returns each ray's first hit. A sonar that
sits inside geometry cannot ping: :func:`cast_fan` refuses with a ConfigError naming the
mount, whether the scene says so (below the sea floor, inside a watertight mesh) or most
rays hit at ~0 m.
"""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import orthonormality_error, row_dots

#: A ping is refused (ConfigError) when more than this fraction of rays hit closer than
#: :data:`INSIDE_GEOMETRY_RANGE_M`: the sonar sits inside (or flush against) geometry.
INSIDE_GEOMETRY_FRACTION = 0.5
INSIDE_GEOMETRY_RANGE_M = 0.02
#: Largest departure of R·Rᵀ from the identity (each entry) for which a rotated unit fan
#: passes a ray caster's unit-length check (its 2e-5 on |d|² − 1) unchecked.
ROTATION_TOL = 2e-6


class RayCaster(Protocol):
    """What the sonar needs from a ray caster (``uhrisim.world.scene.Scene.raycaster()``)."""

    def cast(
        self,
        origins: NDArray[np.float64],
        directions: NDArray[np.float64],
        max_range: float,
        exclude: frozenset[str] = ...,
    ) -> Any:
        """First hits of N rays from one shared origin (the sonar's; ``origins`` has shape
        (3,)) along ``directions`` (N, 3): hits with ``distance`` (N,) inf on miss,
        ``label`` (N,) int −1 on miss, ``normal`` (N, 3) unit, ``reflectivity`` (N,)
        Lambert μ."""
        ...


class FanHits(NamedTuple):
    """The rays of a fan that hit inside the cast window (all arrays have M rows)."""

    idx: NDArray[np.int64]  # indices into the fan
    r: NDArray[np.float64]  # slant range, m
    cos_inc: NDArray[np.float64]  # |cos| of the incidence angle
    mu: NDArray[np.float64]  # Lambert coefficient of the surface hit
    labels: NDArray[np.int32]  # scene label of the surface hit


def cast_fan(
    raycaster: RayCaster,
    origin_ned: NDArray[np.float64],
    dirs_ned: NDArray[np.float64],
    window_m: tuple[float, float],
    exclude: frozenset[str] = frozenset(),
    unit_rays: bool = False,
) -> FanHits:
    """Cast the rays ``dirs_ned`` (N, 3) from ``origin_ned`` (3,) and keep the hits with
    slant range in ``window_m`` = [near, far) (m); bodies named in ``exclude`` are not seen.
    ``unit_rays``: the caller made the rays valid (a finite float64 origin, C-contiguous
    float64 unit directions: a sonar's own fan, :func:`own_fan_is_valid`); a scene's ray
    caster (:class:`uhrisim.world.raycast.RayCaster`) then skips its checks of them.

    Raises ConfigError (naming ``SonarConfig.mount_position_frd``) if the origin is inside
    the caster's scene geometry or more than :data:`INSIDE_GEOMETRY_FRACTION` of the rays
    hit closer than :data:`INSIDE_GEOMETRY_RANGE_M`.
    """
    inside = _inside_scene_geometry(raycaster, origin_ned)
    if inside is not None:
        raise ConfigError(
            f"sonar at NED {np.round(origin_ned, 3).tolist()} is inside geometry ({inside})",
            where="SonarConfig.mount_position_frd",
        )
    from uhrisim.world.raycast import RayCaster as SceneRayCaster

    if unit_rays and isinstance(raycaster, SceneRayCaster):  # one shared origin
        hits = raycaster.cast(origin_ned, dirs_ned, window_m[1], exclude=exclude, checked=False)
    else:
        hits = raycaster.cast(origin_ned, dirs_ned, window_m[1], exclude=exclude)
    distance = np.asarray(hits.distance, dtype=np.float64)
    near = np.count_nonzero(distance < INSIDE_GEOMETRY_RANGE_M)
    if near > INSIDE_GEOMETRY_FRACTION * distance.size:
        raise ConfigError(
            f"sonar at NED {np.round(origin_ned, 3).tolist()} is inside geometry: "
            f"{near}/{distance.size} rays hit closer than {INSIDE_GEOMETRY_RANGE_M} m",
            where="SonarConfig.mount_position_frd",
        )
    return fan_hits(distance, hits.normal, hits.reflectivity, hits.label, dirs_ned, window_m)


def own_fan_is_valid(origin_ned: NDArray[np.float64],
                     rotation_ned_from_sonar: NDArray[np.float64]) -> bool:
    """Whether a sonar's fan, its unit directions turned by ``rotation_ned_from_sonar``,
    from ``origin_ned``, passes a ray caster's checks (finite origin, directions of unit
    length within 1e-5): the origin is finite and the rotation orthonormal within
    :data:`ROTATION_TOL` (then |R·d|² − 1 stays within 9·ROTATION_TOL)."""
    return bool(np.isfinite(origin_ned).all()
                and orthonormality_error(rotation_ned_from_sonar) <= ROTATION_TOL)


def fan_hits(
    distance: NDArray[np.float64],
    normal: NDArray[np.float64],
    reflectivity: NDArray[np.float64],
    label: NDArray[np.integer],
    dirs_ned: NDArray[np.float64],
    window_m: tuple[float, float],
) -> FanHits:
    """The hits of a cast fan (per ray: ``distance`` m, inf on a miss; unit NED
    ``normal``; Lambert ``reflectivity``; scene ``label``) with slant range in
    ``window_m`` = [near, far) (m), ``dirs_ned`` (N, 3) the rays' directions."""
    near_m, far_m = window_m
    cos_all = np.abs(row_dots(np.asarray(normal, np.float64), dirs_ned))
    idx = np.flatnonzero((distance >= near_m) & (distance < far_m))
    return FanHits(
        idx=idx,
        r=distance[idx],
        cos_inc=cos_all[idx],
        mu=np.asarray(reflectivity, dtype=np.float64)[idx],
        labels=np.asarray(label)[idx].astype(np.int32),
    )


def _inside_scene_geometry(raycaster: RayCaster, p: NDArray[np.float64]) -> str | None:
    """Why the point ``p`` (NED) is inside the caster's scene geometry, or None: asks the
    caster's ``scene`` when it has one (``uhrisim.world.scene.Scene.inside_solid``: below
    the sea floor or inside a watertight static mesh). Dynamic bodies are not checked (the
    sonar's own vehicle is excluded from its rays anyway)."""
    scene = getattr(raycaster, "scene", None)
    inside_solid = getattr(scene, "inside_solid", None)
    return inside_solid(p) if inside_solid is not None else None
