"""A vehicle's sphere inside a solid that an event put on it: detect it, push it out.

A vehicle that moves into an object is stopped by the moving-sphere check of the loop;
an object that *appears* where a vehicle is (an event adds or moves it) cannot be seen
that way. The sphere is sampled at its centre and 26 points of its surface; a sphere that
overlaps is moved along the shortest way out — to the closest point of the object's
surface plus its radius — as a rigid object would shove it. World NED metres.
"""

from __future__ import annotations

import numpy as np
import trimesh
from numpy.typing import NDArray

CLEARANCE_M = 1e-3  # the pushed-out sphere stops this far off the surface


def _sphere_samples() -> NDArray[np.float64]:
    """The unit sphere sampled at its centre and 26 points: the faces, edges and corners
    of a cube, normalised."""
    cube = np.array(list(np.ndindex(3, 3, 3)), dtype=float) - 1.0
    norms = np.linalg.norm(cube, axis=1, keepdims=True)
    return cube / np.where(norms > 0.0, norms, 1.0)


SPHERE_SAMPLES = _sphere_samples()


def sphere_overlaps(mesh: trimesh.Trimesh, centre: NDArray[np.float64], radius: float) -> bool:
    """Whether the sphere (centre NED m, radius m) reaches into the closed ``mesh``."""
    low, high = mesh.bounds
    if np.any(centre + radius < low) or np.any(centre - radius > high):
        return False
    return bool(np.any(mesh.contains(centre + radius * SPHERE_SAMPLES)))


def _closest_surface_point(mesh: trimesh.Trimesh,
                           point: NDArray[np.float64]) -> NDArray[np.float64]:
    """The point of the mesh's surface closest to ``point`` (all triangles, no index)."""
    candidates = trimesh.triangles.closest_point(
        mesh.triangles, np.broadcast_to(point, (len(mesh.triangles), 3)))
    return candidates[int(np.argmin(np.linalg.norm(candidates - point, axis=1)))]


def push_out(mesh: trimesh.Trimesh, centre: NDArray[np.float64],
             radius: float) -> NDArray[np.float64]:
    """Where the sphere goes: the shortest move that takes it out of the closed ``mesh``
    (the centre, NED m, moved through or away from the nearest surface point). A sphere
    centred exactly on the surface goes up."""
    surface = _closest_surface_point(mesh, centre)
    offset = surface - centre
    distance = float(np.linalg.norm(offset))
    if distance < 1e-12:
        return surface + np.array([0.0, 0.0, -(radius + CLEARANCE_M)])
    inside = bool(mesh.contains(centre[None, :])[0])
    outward = offset / distance if inside else -offset / distance
    return surface + outward * (radius + CLEARANCE_M)
