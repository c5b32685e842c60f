"""Meshes of the articulated diver, one rigid part per link, posed from joint angles.

:func:`diver_figure` builds the parts of a :class:`~uhrisim.dynamics.diver_body.DiverSkeleton`
in its zero configuration (standing, body frame FRD, origin at the hip centre). Each part
carries the chain of its joints (as :class:`~uhrisim.world.bodies.Joint` s, pivots and
axes at rest) and a **label** that the sonar's and the camera's label images show:

===========  =====================================================================
label        parts
===========  =====================================================================
(the body)   pelvis, torso, thighs, shanks, feet of the scuba diver
``head``     head (the commercial diver: a helmet)
``tank``     the scuba cylinder on the back (the commercial diver: a bailout bottle)
``arm``      upper arms and forearms
``hand``     hands and fingers
``fins``     the scuba diver's fins
``boots``    the commercial diver's weighted boots
===========  =====================================================================

In a scene, a part labelled ``hand`` on a body labelled ``diver`` shows as
``"diver/hand"`` (``Scene.labels``); unlabelled parts show as ``"diver"``. Add the figure
with ``Scene.add_dynamic(name, diver_figure(skeleton), "diver", NEOPRENE)`` and pose it
every tick with ``Scene.set_part_transforms(name, figure_transforms(skeleton, q))``: the
ray casters keep one BVH per part built once at rest, so posing costs no rebuild.

Sizes follow the skeleton's anthropometry; thicknesses (limb radii, hand and foot boxes)
are plausible assumptions, like the swimming diver's in :mod:`uhrisim.world.assets`:
meant to give sensors the right size and outline, not to be a CAD model. The scuba
cylinder is an aluminium 80 (11.1 L: 0.184 m diameter, 0.66 m long, Luxfer data); the
fins 0.60 m long blades (as in ``assets``) raked 30° below the sole; the helmet a 0.32 m
sphere (Kirby Morgan SuperLite class); the boots 0.32 × 0.13 × 0.12 m.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from uhrisim.dynamics.diver_body import SIDES, DiverSkeleton
from uhrisim.world import primitives as prim
from uhrisim.world.assets import ellipsoid
from uhrisim.world.bodies import ArticulatedMesh, Joint, Part
from uhrisim.world.materials import ALUMINIUM, Material

#: Label of every link (None: the body's own label). Module docstring.
LINK_LABELS: dict[str, str | None] = {
    "pelvis": None, "torso": None, "tank": "tank", "head": "head",
    **{f"{s}_{link}": label for s in SIDES for link, label in (
        ("upper_arm", "arm"), ("forearm", "arm"), ("hand", "hand"), ("fingers", "hand"),
        ("thigh", None), ("shank", None), ("foot", None), ("fin", "fins"))},
}
PART_LABELS = ("head", "tank", "arm", "hand", "fins", "boots")

#: Scuba cylinder (aluminium 80) and bailout bottle (assumed 3 L steel) sizes, m.
SCUBA_TANK_RADIUS_M, SCUBA_TANK_LENGTH_M = 0.092, 0.66
BAILOUT_RADIUS_M, BAILOUT_LENGTH_M = 0.07, 0.45
#: Fin blade (m) and its rake below the sole line (assumed: blades are set at an angle to
#: the foot pocket so that they trail in line with a diver's pointed feet; the swimmer's
#: ankle is :data:`uhrisim.world.kick.SWIM_ANKLE_BIAS_RAD`).
FIN_LENGTH_M, FIN_WIDTH_M = 0.60, 0.22
FIN_RAKE_RAD = math.radians(30.0)


def _limb(radius: float, top: float, bottom: float, y: float) -> trimesh.Trimesh:
    """A capsule along z from ``top`` to ``bottom`` (body z, m) at lateral ``y``."""
    length = bottom - top
    return prim.capsule(radius, max(length - 2.0 * radius, 1e-3), (0.0, y, 0.5 * (top + bottom)),
                        count=(10, 8))


def _link_meshes(skeleton: DiverSkeleton) -> dict[str, trimesh.Trimesh]:
    """Rest-pose mesh of every link (body frame, m)."""
    b = skeleton.body
    boots = skeleton.kind == "boots"
    shoulder_z = b.shoulder_z
    meshes = {
        "pelvis": ellipsoid((0.11, 0.17, 0.10), (0.0, 0.0, -0.03)),
        "torso": ellipsoid((0.13, 0.19, 0.27), (0.0, 0.0, 0.5 * shoulder_z - 0.02)),
        "head": (prim.sphere(0.16, (0.0, 0.0, b.head_centre_z), subdivisions=2) if boots
                 else prim.sphere(0.11, (0.0, 0.0, b.head_centre_z), subdivisions=2)),
    }
    radius, length = ((BAILOUT_RADIUS_M, BAILOUT_LENGTH_M) if boots
                      else (SCUBA_TANK_RADIUS_M, SCUBA_TANK_LENGTH_M))
    meshes["tank"] = prim.cylinder(radius, length, (-0.13 - radius, 0.0, 0.5 * shoulder_z),
                                   sections=20)
    for side in SIDES:
        y = skeleton.joints[skeleton.index(f"{side}_shoulder_flex")].pivot[1]
        hip_y = skeleton.joints[skeleton.index(f"{side}_hip_flex")].pivot[1]
        elbow_z = shoulder_z + b.upper_arm
        wrist_z = elbow_z + b.forearm
        knuckle_z = wrist_z + 0.5 * b.hand
        sole_z = b.hip_height
        ankle_z = b.thigh + b.shank
        p = f"{side}_"
        meshes[p + "upper_arm"] = _limb(0.05, shoulder_z, elbow_z, y)
        meshes[p + "forearm"] = _limb(0.045, elbow_z, wrist_z, y)
        meshes[p + "hand"] = prim.box((0.03, 0.09, 0.5 * b.hand),
                                      (0.0, y, 0.5 * (wrist_z + knuckle_z)))
        meshes[p + "fingers"] = prim.box((0.025, 0.085, 0.5 * b.hand),
                                         (0.0, y, knuckle_z + 0.25 * b.hand))
        meshes[p + "thigh"] = _limb(0.075, 0.0, b.thigh, hip_y)
        meshes[p + "shank"] = _limb(0.055, b.thigh, ankle_z, hip_y)
        if boots:
            meshes[p + "foot"] = prim.box((0.32, 0.13, 0.12), (0.09, hip_y, sole_z - 0.06))
        else:
            toe_x = b.foot_length - 0.05
            meshes[p + "foot"] = prim.box((b.foot_length, 0.10, sole_z - ankle_z + 0.03),
                                          (toe_x - 0.5 * b.foot_length, hip_y,
                                           0.5 * (ankle_z + sole_z) - 0.015))
            rake = (math.cos(FIN_RAKE_RAD), 0.0, math.sin(FIN_RAKE_RAD))
            reach = 0.5 * FIN_LENGTH_M - 0.1  # the blade starts 0.1 m behind the toes
            meshes[p + "fin"] = prim.box(
                (FIN_LENGTH_M, FIN_WIDTH_M, 0.02),
                (toe_x + reach * rake[0], hip_y, sole_z - 0.02 + reach * rake[2]),
                pitch=-FIN_RAKE_RAD)
    return meshes


def _part_label(skeleton: DiverSkeleton, link: str) -> str | None:
    if skeleton.kind == "boots" and link.endswith("_foot"):
        return "boots"
    return LINK_LABELS[link]


def diver_figure(skeleton: DiverSkeleton, tank_material: Material = ALUMINIUM,
                 part_materials: Mapping[str | None, Material] | None = None
                 ) -> ArticulatedMesh:
    """The articulated diver's parts, one per link of ``skeleton`` (module docstring).

    Parts follow ``skeleton.links`` order; each carries its joint chain (rest pivots and
    axes, zero amplitude: the figure is posed by :func:`figure_transforms`, not by a kick
    phase), its label and its material: with ``part_materials`` (e.g.
    ``uhrisim.world.materials.DIVER_PART_MATERIALS``) the one of its label (None: the
    body's parts; ``"helmet"``: the commercial diver's head), else ``tank_material`` for
    the cylinder and the body's material for the rest.
    """
    meshes = _link_meshes(skeleton)
    parts = []
    for link, joint in skeleton.links.items():
        chain = tuple(Joint(skeleton.joints[i].pivot, skeleton.joints[i].axis, 0.0)
                      for i in skeleton.chain(joint))
        label = _part_label(skeleton, link)
        material = tank_material if link == "tank" else None
        if part_materials is not None:
            key = "helmet" if skeleton.kind == "boots" and link == "head" else label
            material = part_materials.get(key, material)
        parts.append(Part(link, meshes[link], chain, material=material, label=label))
    return ArticulatedMesh(tuple(parts))


def figure_transforms(skeleton: DiverSkeleton, q: ArrayLike) -> NDArray[np.float64]:
    """(n_parts, 4, 4) rest→posed transforms of :func:`diver_figure`'s parts at ``q``
    (for ``Scene.set_part_transforms``)."""
    t = skeleton.joint_transforms(q)
    return np.array([t[skeleton.index(joint)] for joint in skeleton.links.values()])


def posed_figure(skeleton: DiverSkeleton, q: ArrayLike) -> trimesh.Trimesh:
    """The whole figure at ``q`` as one Trimesh in the body frame (plots, export)."""
    return diver_figure(skeleton).mesh_posed(figure_transforms(skeleton, q))
