"""The static scene as plain data for the viewer (NED metres); recordings and the ROS 2
bridge use :func:`uhrisim.record.hook.scene_markers`."""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh

from uhrisim.world.scene import Scene

SEAFLOOR_MAX_FACES = 20_000  # decimate larger floors for display


def _display_mesh(obj_mesh: trimesh.Trimesh, label: str) -> trimesh.Trimesh:
    if label == "seafloor" and len(obj_mesh.faces) > SEAFLOOR_MAX_FACES:
        step = int(np.ceil(len(obj_mesh.faces) / SEAFLOOR_MAX_FACES))
        return trimesh.Trimesh(obj_mesh.vertices, obj_mesh.faces[::step], process=False)
    return obj_mesh


def scene_description(scene: Scene) -> dict[str, Any]:
    """Vertices/faces of every static object, the sea floor apart, and the bounds."""
    objects, seafloor = [], None
    for obj in scene.static_objects:
        mesh = _display_mesh(obj.mesh, obj.label)
        entry = {"label": obj.label, "kind": "mesh",
                 "vertices": np.round(np.asarray(mesh.vertices), 3).tolist(),
                 "faces": np.asarray(mesh.faces).tolist()}
        if obj.label == "seafloor" and seafloor is None:
            seafloor = {"vertices": entry["vertices"], "faces": entry["faces"]}
        else:
            objects.append(entry)
    bounds = np.asarray(scene.bounds()) if scene.static_objects else np.zeros((2, 3))
    return {"objects": objects, "seafloor": seafloor, "bounds": bounds.tolist()}
