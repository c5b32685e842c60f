"""Loading triangle meshes from files (OBJ, STL, PLY, GLB/GLTF, OFF) into NED.

``load_mesh`` reads the file with trimesh, flattens multi-object scenes (GLB) into one
mesh with their node transforms applied, then scales and poses it: a vertex ``v`` of the
file becomes ``rotation @ (scale * v) + position_ned``. Whatever went wrong — missing,
unreadable, corrupt or empty — comes back as one :class:`~uhrisim.core.errors.AssetError`
whose one-line message starts with the file name.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import ArrayLike

from uhrisim.core.errors import AssetError, ConfigError, first_line
from uhrisim.world.primitives import pose_matrix

log = logging.getLogger(__name__)

SUPPORTED_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf", ".off")


def load_mesh(
    path: str | Path,
    scale: float = 1.0,
    position_ned: ArrayLike = (0.0, 0.0, 0.0),
    rotation: ArrayLike | None = None,
    *,
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
) -> trimesh.Trimesh:
    """Load a mesh file as a Trimesh in NED metres.

    Args:
        path: file to read (.obj, .stl, .ply, .glb, .gltf, .off).
        scale: uniform factor from file units to metres (e.g. 0.001 for millimetres).
        position_ned: translation (NED metres) applied after scaling and rotating.
        rotation: 3x3 file-frame→NED rotation; or give ``yaw``/``pitch``/``roll`` (radians,
            ZYX). The file's axes are taken as-is (no Y-up conversion is guessed).

    Raises:
        AssetError: missing, unreadable, corrupt or empty file (message names the file).
        ConfigError: non-positive scale or a bad pose.
    """
    p = Path(path)
    s = float(scale)
    if not np.isfinite(s) or s <= 0.0:
        raise ConfigError(
            f"must be a positive factor, got {scale!r}", where=f"load_mesh({p}).scale"
        )
    pose = pose_matrix(position_ned, yaw, pitch, roll, rotation)
    if not p.exists():
        raise AssetError(f"{p}: mesh file not found")
    if not p.is_file():
        raise AssetError(f"{p}: not a regular file")
    suffix = p.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise AssetError(
            f"{p}: unsupported mesh format {suffix or '(none)'!r}; "
            f"expected one of {', '.join(SUPPORTED_SUFFIXES)}"
        )
    try:
        loaded = trimesh.load(p, force=None, process=False)
    except ImportError:
        # trimesh falls back to guessing a text encoding (optional charset_normalizer)
        # only when the bytes are neither valid binary data nor UTF-8 text.
        raise AssetError(
            f"{p}: cannot read mesh (corrupt: neither valid binary {suffix[1:].upper()} "
            "nor UTF-8 text)"
        ) from None
    except Exception as exc:  # trimesh raises many types on corrupt input
        raise AssetError(f"{p}: cannot read mesh ({first_line(exc)})") from None
    try:
        if isinstance(loaded, trimesh.Scene):
            geoms = [g for g in loaded.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
            mesh = trimesh.util.concatenate(geoms) if geoms else None
        elif isinstance(loaded, trimesh.Trimesh):
            mesh = loaded
        else:
            mesh = None
    except Exception as exc:
        raise AssetError(f"{p}: cannot flatten mesh scene ({first_line(exc)})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise AssetError(f"{p}: file holds no triangles")
    verts = np.asarray(mesh.vertices, dtype=float)
    if not np.all(np.isfinite(verts)):
        raise AssetError(f"{p}: mesh has NaN or inf vertex coordinates")
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if faces.min() < 0 or faces.max() >= len(verts):
        raise AssetError(f"{p}: face indices out of range")
    out = trimesh.Trimesh(verts * s, faces, process=False, validate=False)
    out.apply_transform(pose)
    log.debug("loaded %s: %d triangles", p, len(out.faces))
    return out
