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

The names below are imported at their first use (:mod:`uhrisim.core.lazy`): the meshes
need trimesh (and through it scipy), about a second of CPU, which a process that only
reads a scenario's declarations (:mod:`uhrisim.world.events`,
:mod:`uhrisim.world.tool_kinds`) need not pay.
"""

from __future__ import annotations

from uhrisim.core.lazy import lazy_exports

#: Each exported name -> the module that defines it (a submodule is its own entry).
_HOMES = {
    "ArticulatedMesh": "bodies", "Joint": "bodies", "Part": "bodies",
    "DynamicBody": "objects", "StaticObject": "objects",
    "EmbreeRayCaster": "raycast", "RayCaster": "raycast", "RayHits": "raycast",
    "ReferenceRayCaster": "raycast",
    "Material": "materials", "load_mesh": "meshes", "Scene": "scene", "SeaFloor": "seafloor",
    "assets": "assets", "materials": "materials", "primitives": "primitives",
    "seafloor": "seafloor",
}

__all__ = sorted(_HOMES)
__getattr__ = lazy_exports(__name__, _HOMES)
