"""Procedural meshes shipped in code: the VideoRay Pro 4 and a swimming scuba diver.

All meshes are in the BODY frame FRD (x forward, y starboard, z down), metres, origin at
the body centre; nothing is downloaded. Shapes are simple primitives sized from public
numbers; they are meant to give a sonar the right size, outline and bright spots, not to
be a CAD model.
"""

from __future__ import annotations

import math

import trimesh

from uhrisim.world import primitives as prim
from uhrisim.world.bodies import ArticulatedMesh, Joint, Part
from uhrisim.world.kick import (
    DIVER_ANKLE_AMPLITUDE_RAD,
    DIVER_ANKLE_LAG_RAD,
    DIVER_HIP_AMPLITUDE_RAD,
)
from uhrisim.world.materials import ALUMINIUM, NEOPRENE, Material

_ALONG_X = {"pitch": math.pi / 2.0}  # turns a primitive's +z axis onto body +x

# --------------------------------------------------------------------------- VideoRay

#: VideoRay Pro 4 overall size (manufacturer datasheet: 37.5 cm long, 28.9 cm wide,
#: 22.3 cm high). The mesh below is built to these envelopes.
VIDEORAY_LENGTH_M = 0.375
VIDEORAY_WIDTH_M = 0.289
VIDEORAY_HEIGHT_M = 0.223


def videoray_mesh() -> trimesh.Trimesh:
    """VideoRay Pro 4 class ROV, ~0.375 × 0.289 × 0.223 m, body FRD, origin at the centre.

    Parts: a main hull box (lower half), two buoyancy floats on top (cylinders along x,
    at −z since z is down), port and starboard horizontal thrusters (ducts along x at the
    stern) and a vertical thruster between the floats. About 400 triangles.
    """
    half_h = 0.5 * VIDEORAY_HEIGHT_M
    float_r = 0.045
    hull_top = -half_h + 2.0 * float_r  # floats sit above the hull
    parts = [
        prim.box((0.30, 0.18, half_h - hull_top), (0.0, 0.0, 0.5 * (half_h + hull_top))),
        prim.cylinder(float_r, VIDEORAY_LENGTH_M, (0.0, -0.07, -half_h + float_r), **_ALONG_X),
        prim.cylinder(float_r, VIDEORAY_LENGTH_M, (0.0, 0.07, -half_h + float_r), **_ALONG_X),
    ]
    thr_r = 0.025
    thr_y = 0.5 * VIDEORAY_WIDTH_M - thr_r
    for side in (-1.0, 1.0):
        parts.append(
            prim.cylinder(thr_r, 0.10, (-0.11, side * thr_y, 0.03), sections=16, **_ALONG_X)
        )
        # strut joining the thruster duct to the hull
        parts.append(
            prim.box((0.05, thr_y - 0.09, 0.02), (-0.11, side * 0.5 * (thr_y + 0.09), 0.03))
        )
    parts.append(prim.cylinder(0.022, 0.07, (0.0, 0.0, -half_h + 0.04), sections=16))
    return trimesh.util.concatenate(parts)


# --------------------------------------------------------------------------- diver

_HIP_X, _KNEE_TO_ANKLE, _LEG_LEN, _LEG_Y = 0.22, 0.45, 0.90, 0.10
_ANKLE_X = _HIP_X - _LEG_LEN
_FIN_LEN = 0.60


def ellipsoid(semi_axes: tuple[float, float, float],
              centre: tuple[float, float, float]) -> trimesh.Trimesh:
    """An ellipsoid with ``semi_axes`` (m, along x, y, z) centred on ``centre`` (320 faces)."""
    m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    m.apply_scale(semi_axes)
    m.apply_translation(centre)
    return m


def diver_parts(
    material: Material = NEOPRENE, tank_material: Material = ALUMINIUM,
    fin_material: Material | None = None,
) -> ArticulatedMesh:
    """The diver as rigid parts with flutter-kick joints (pass to ``Scene.add_dynamic``).

    Body FRD, origin near the centre of the body (about the navel): head forward at +x,
    back (and the scuba tank) at −z (up), prone. Parts: ``core`` (torso, head, arms),
    ``tank`` (``tank_material``), ``left_leg``/``right_leg`` (thigh+shin, hinged at the
    hips about body y) and ``left_fin``/``right_fin`` (hinged at the ankles, carried by
    the legs; ``fin_material``, None: the body's). Legs kick in opposite phase. About
    2,000 triangles.
    """
    core = trimesh.util.concatenate(
        [
            ellipsoid((0.34, 0.19, 0.12), (0.55, 0.0, 0.0)),  # torso, x 0.21..0.89
            prim.sphere(0.11, (0.99, 0.0, -0.02), subdivisions=2),  # head
            prim.capsule(0.05, 0.48, (0.55, -0.24, 0.03), count=(8, 8), **_ALONG_X),  # arms
            prim.capsule(0.05, 0.48, (0.55, 0.24, 0.03), count=(8, 8), **_ALONG_X),
        ]
    )
    tank = prim.cylinder(0.09, 0.62, (0.52, 0.0, -0.20), sections=20, **_ALONG_X)
    parts = [Part("core", core), Part("tank", tank, material=tank_material)]
    for side, offset in (("left", 0.0), ("right", math.pi)):
        y = -_LEG_Y if side == "left" else _LEG_Y
        hip = Joint((_HIP_X, y, 0.0), (0.0, 1.0, 0.0), DIVER_HIP_AMPLITUDE_RAD, offset)
        ankle = Joint(
            (_ANKLE_X, y, 0.0),
            (0.0, 1.0, 0.0),
            DIVER_ANKLE_AMPLITUDE_RAD,
            offset - DIVER_ANKLE_LAG_RAD,
        )
        leg = prim.capsule(
            0.07, _LEG_LEN - 0.14, (_HIP_X - 0.5 * _LEG_LEN, y, 0.0), count=(10, 8), **_ALONG_X
        )
        fin = prim.box((_FIN_LEN, 0.22, 0.02), (_ANKLE_X - 0.5 * _FIN_LEN + 0.05, y, 0.0))
        parts.append(Part(f"{side}_leg", leg, (hip,)))
        parts.append(Part(f"{side}_fin", fin, (hip, ankle), material=fin_material))
    return ArticulatedMesh(tuple(parts))


def diver_mesh(kick_phase_rad: float = 0.0) -> trimesh.Trimesh:
    """The whole diver at ``kick_phase_rad`` as one Trimesh (body FRD; see diver_parts)."""
    return diver_parts().mesh_at(float(kick_phase_rad))
