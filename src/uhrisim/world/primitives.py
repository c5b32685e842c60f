"""Posed geometric primitives as ``trimesh.Trimesh`` in world NED metres.

Every constructor builds the shape in its own frame (centred on the origin, symmetry axis
along +z where it has one) and then applies a pose: the rotation (body→NED, either a 3x3
matrix or ZYX Euler angles ``yaw``/``pitch``/``roll`` in radians, see
``docs/conventions.md``) followed by the translation ``position_ned``.

NED z points **down**: a cylinder "standing" on a sea floor at depth 8 m and reaching the
surface spans z from 8 to 0, i.e. ``cylinder(r, 8.0, position_ned=(n, e, 4.0))`` or, more
explicitly, :func:`vertical_cylinder` ``(r, n, e, z_top=0.0, z_bottom=8.0)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rotation_zyx


def pose_matrix(
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
    rotation: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """4x4 homogeneous body→NED transform from a position and a rotation.

    ``rotation`` (3x3, body→NED) takes precedence over the Euler angles (radians, ZYX).
    """
    t = np.asarray(position_ned, dtype=float).reshape(-1)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise ConfigError(f"must be 3 finite numbers, got {position_ned!r}", where="position_ned")
    if rotation is None:
        rot = rotation_zyx(roll, pitch, yaw)
    else:
        rot = np.asarray(rotation, dtype=float)
        if rot.shape != (3, 3) or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6):
            raise ConfigError("must be a 3x3 orthonormal matrix", where="rotation")
        if np.linalg.det(rot) < 0.0:
            raise ConfigError("must be a proper rotation (det = +1)", where="rotation")
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = t
    return m


def _posed(
    mesh: trimesh.Trimesh,
    position_ned: ArrayLike,
    yaw: float,
    pitch: float,
    roll: float,
    rotation: ArrayLike | None,
) -> trimesh.Trimesh:
    mesh.apply_transform(pose_matrix(position_ned, yaw, pitch, roll, rotation))
    return mesh


def positive_length(value: float, where: str) -> float:
    """``value`` as a float, metres; ConfigError at ``where`` unless finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not np.isfinite(v) or v <= 0.0:
        raise ConfigError(f"must be a positive finite length in metres, got {value!r}", where=where)
    return v


def box(
    size: Sequence[float],
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    *,
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
    rotation: ArrayLike | None = None,
) -> trimesh.Trimesh:
    """Box with edge lengths ``size`` = (x, y, z) metres in its own frame, centred on the pose."""
    ext = np.asarray(size, dtype=float).reshape(-1)
    if ext.shape != (3,):
        raise ConfigError(f"must be 3 edge lengths, got {size!r}", where="box.size")
    for i, e in enumerate(ext):
        positive_length(e, f"box.size[{i}]")
    return _posed(trimesh.creation.box(extents=ext), position_ned, yaw, pitch, roll, rotation)


def cylinder(
    radius: float,
    height: float,
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    *,
    sections: int = 32,
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
    rotation: ArrayLike | None = None,
) -> trimesh.Trimesh:
    """Closed cylinder, axis along its own z, centred on the pose (a ``sections``-gon prism)."""
    r = positive_length(radius, "cylinder.radius")
    h = positive_length(height, "cylinder.height")
    if int(sections) < 3:
        raise ConfigError(f"must be >= 3, got {sections!r}", where="cylinder.sections")
    mesh = trimesh.creation.cylinder(radius=r, height=h, sections=int(sections))
    return _posed(mesh, position_ned, yaw, pitch, roll, rotation)


def vertical_cylinder(
    radius: float,
    north: float,
    east: float,
    z_top: float,
    z_bottom: float,
    *,
    sections: int = 32,
) -> trimesh.Trimesh:
    """Upright cylinder at (north, east) spanning depth ``z_top`` (shallower) to ``z_bottom``."""
    if not z_bottom > z_top:
        raise ConfigError(
            f"z_bottom ({z_bottom}) must be deeper (larger) than z_top ({z_top})",
            where="vertical_cylinder",
        )
    centre = (north, east, 0.5 * (z_top + z_bottom))
    return cylinder(radius, z_bottom - z_top, centre, sections=sections)


def sphere(
    radius: float,
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    *,
    subdivisions: int = 3,
) -> trimesh.Trimesh:
    """Icosphere of circumradius ``radius`` (vertices on the sphere) centred on the position."""
    r = positive_length(radius, "sphere.radius")
    mesh = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=r)
    return _posed(mesh, position_ned, 0.0, 0.0, 0.0, None)


def torus(
    major_radius: float,
    minor_radius: float,
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    *,
    major_sections: int = 48,
    minor_sections: int = 16,
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
    rotation: ArrayLike | None = None,
) -> trimesh.Trimesh:
    """Torus around its own z axis (lying flat when unrotated: its hole points up/down)."""
    big = positive_length(major_radius, "torus.major_radius")
    small = positive_length(minor_radius, "torus.minor_radius")
    if small >= big:
        raise ConfigError(
            f"minor_radius ({small}) must be smaller than major_radius ({big})", where="torus"
        )
    mesh = trimesh.creation.torus(
        major_radius=big,
        minor_radius=small,
        major_sections=int(major_sections),
        minor_sections=int(minor_sections),
    )
    return _posed(mesh, position_ned, yaw, pitch, roll, rotation)


def capsule(
    radius: float,
    height: float,
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    *,
    count: tuple[int, int] = (16, 16),
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
    rotation: ArrayLike | None = None,
) -> trimesh.Trimesh:
    """Capsule along its own z: ``height`` is the distance between the two hemisphere centres.

    Total length is ``height + 2 * radius``.
    """
    r = positive_length(radius, "capsule.radius")
    h = positive_length(height, "capsule.height")
    mesh = trimesh.creation.capsule(height=h, radius=r, count=list(count))
    # trimesh's capsule spans z in [0, height + 2r] in some versions; centre it on the origin.
    lo, hi = mesh.bounds[:, 2]
    mesh.apply_translation((0.0, 0.0, -0.5 * (lo + hi)))
    return _posed(mesh, position_ned, yaw, pitch, roll, rotation)
