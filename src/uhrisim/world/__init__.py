"""The world: sea floor, static structures, dynamic bodies, and ray casting against them.

Frames and units follow ``docs/conventions.md`` (world NED metres, body FRD).

Typical use::

    from uhrisim.world import Scene, materials, primitives, seafloor
    scene = Scene()
    scene.add_static(seafloor.flat(8.0, 50.0), "seafloor", materials.SAND)
    scene.add_static(primitives.vertical_cylinder(0.3, 10, 0, 0, 8), "piling", materials.CONCRETE)
    scene.add_dynamic("diver", assets.diver_parts(), "diver", materials.NEOPRENE)
    rc = scene.raycaster()                      # once
    scene.set_pose("diver", pos_ned, R_body_to_ned, kick_phase)   # every tick
    hits = rc.cast(origins, directions, max_range=30.0, exclude=frozenset({"videoray"}))
"""

from uhrisim.world import assets, materials, primitives, seafloor
from uhrisim.world.bodies import ArticulatedMesh, Joint, Part
from uhrisim.world.materials import Material
from uhrisim.world.meshes import load_mesh
from uhrisim.world.objects import DynamicBody, StaticObject
from uhrisim.world.raycast import EmbreeRayCaster, RayCaster, RayHits, ReferenceRayCaster
from uhrisim.world.scene import Scene
from uhrisim.world.seafloor import SeaFloor

__all__ = [
    "ArticulatedMesh",
    "DynamicBody",
    "EmbreeRayCaster",
    "Joint",
    "Material",
    "Part",
    "RayCaster",
    "RayHits",
    "ReferenceRayCaster",
    "Scene",
    "SeaFloor",
    "StaticObject",
    "assets",
    "load_mesh",
    "materials",
    "primitives",
    "seafloor",
]
