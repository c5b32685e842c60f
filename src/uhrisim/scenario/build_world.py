"""Build the static scene of a scenario: sea floor, primitives and imported meshes."""

from __future__ import annotations

import difflib
import math

from uhrisim.core.errors import AssetError, ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.scenario.load import ScenarioFile
from uhrisim.scenario.schema import (
    BoxObject,
    CapsuleObject,
    CylinderObject,
    FlatFloor,
    GridFloor,
    MeshObject,
    ProceduralFloor,
    SceneObject,
    SeaFloor,
    SlopedFloor,
    SphereObject,
    TorusObject,
)
from uhrisim.world import meshes, seafloor
from uhrisim.world import primitives as prim
from uhrisim.world.materials import DEFAULT_MATERIALS, SAND_RIPPLED, Material
from uhrisim.world.scene import Scene


def material_named(name: str, where: str) -> Material:
    """A default material by name, or a ConfigError with a did-you-mean."""
    try:
        return DEFAULT_MATERIALS[name]
    except KeyError:
        close = difflib.get_close_matches(name, sorted(DEFAULT_MATERIALS), n=1)
        hint = f"did you mean {close[0]!r}?" if close else \
            f"known: {', '.join(sorted(DEFAULT_MATERIALS))}"
        raise ConfigError(f"unknown material {name!r}; {hint}", where=where) from None


def object_mesh(obj: SceneObject, source: ScenarioFile, where: str, posed: bool = True):
    """The trimesh of one scenario object, posed in NED (or at the origin, unrotated)."""
    position = obj.position.as_list() if posed else [0.0, 0.0, 0.0]
    yaw = math.radians(obj.heading_deg) if posed else 0.0
    if isinstance(obj, BoxObject):
        return prim.box(obj.size, position, yaw=yaw)
    if isinstance(obj, CylinderObject):
        return prim.cylinder(obj.radius, obj.height, position, yaw=yaw)
    if isinstance(obj, SphereObject):
        return prim.sphere(obj.radius, position)
    if isinstance(obj, TorusObject):
        return prim.torus(obj.major_radius, obj.minor_radius, position, yaw=yaw)
    if isinstance(obj, CapsuleObject):
        return prim.capsule(obj.radius, obj.height, position, yaw=yaw)
    if isinstance(obj, MeshObject):
        try:
            return meshes.load_mesh(source.resolve(obj.file), obj.scale, position, yaw=yaw)
        except AssetError as error:
            raise AssetError(f"{where}: {error}") from None
    raise ConfigError(f"unsupported object type {type(obj).__name__}", where=where)


def build_static_scene(source: ScenarioFile, floor_material: Material = SAND_RIPPLED
                       ) -> Scene:
    """Scene with the scenario's sea floor (of ``floor_material``: rippled sand unless
    told) and objects (dynamic bodies are added later)."""
    world = source.scenario.world
    scene = Scene()
    try:
        _add_floor(scene, world.seafloor, source, floor_material)
    except ConfigError as error:  # e.g. a floor too big: name the scenario's field
        raise ConfigError(str(error), source.where("world", "seafloor")) from None
    for index, obj in enumerate(world.objects):
        add_object(scene, obj, source, source.where("world", "objects", index))
    return scene


def _add_floor(scene: Scene, floor: SeaFloor | None, source: ScenarioFile,
               material: Material) -> None:
    if isinstance(floor, FlatFloor):
        scene.add_static(seafloor.flat(floor.depth, floor.extent), "seafloor", material)
    elif isinstance(floor, SlopedFloor):
        scene.add_static(seafloor.sloped(floor.depth, floor.slope, floor.direction_deg,
                                         floor.extent), "seafloor", material)
    elif isinstance(floor, GridFloor):
        scene.add_static(seafloor.from_height_grid(source.resolve(floor.file), floor.spacing),
                         "seafloor", material)
    elif isinstance(floor, ProceduralFloor):
        scene.add_static(seafloor.procedural(floor.seed, floor.extent, floor.depth,
                                             floor.roughness), "seafloor", material)


def add_object(scene: Scene, obj: SceneObject, source: ScenarioFile, where: str) -> None:
    """Add a scenario object: static geometry, or a dynamic body if ``movable``."""
    material = material_named(obj.material, where)
    if obj.movable:
        scene.add_dynamic(obj.label, object_mesh(obj, source, where, posed=False), obj.label,
                          material, obj.position.as_list(), rot_z(math.radians(obj.heading_deg)))
    else:
        scene.add_static(object_mesh(obj, source, where), obj.label, material)
