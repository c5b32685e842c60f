"""Tools a diver or the ROV can carry: mass, in-water weight, size, grasp point, label.

In-water weights are in sea water of 1025 kg/m³ (:mod:`uhrisim.dynamics.free_body`).
A :class:`Tool` is a rigid object described in its own frame (x along the handle or the
long axis, y across, z down when it lies flat; metres, origin at its centre). Its
``grasp_point`` is where a hand or jaw takes hold; its ``working_point`` the business end
(a wrench's jaw, a hammer's face, a light's lens). Its label is its ``kind``, so sonar and
camera label images name it.

The catalogue values are **typical numbers, assumed** (no single source): masses of
common tools, volumes from the materials' densities — steel 7850 kg/m³, aluminium 2700,
ash wood 670, PVC-coated polyester fabric ~1300 — and drag coefficients of plates and
cylinders across the flow (Hoerner, *Fluid-Dynamic Drag*, 1965: flat plate face-on 1.17-
1.28, circular cylinder broadside ~1.2). A falling tool is taken to fall flat, so its
drag area is its largest face:

================  =======  ========  ======================  ======================
kind              mass kg  volume L  size m                  in water
================  =======  ========  ======================  ======================
wrench            1.30     0.166     0.45 × 0.08 × 0.015     11.1 N (1.13 kgf)
hammer            1.40     0.547     0.27 × 0.11 × 0.05      8.2 N  (club hammer)
light             0.60     0.50      0.20 × 0.06 × 0.06      0.86 N (slightly negative)
lift_bag          2.00     1.54      0.35 × 0.25 × 0.10      4.1 N  (folded 100 L bag)
tool_basket       8.00     1.02      0.60 × 0.40 × 0.30      68 N   (steel mesh)
================  =======  ========  ======================  ======================

(wrench: a 36 mm combination spanner, 1.1-1.4 kg in makers' catalogues; hammer: a 1.13 kg
(2.5 lb) club-hammer head on a 0.27 m ash handle; light: a canister-style dive torch head,
which divers want slightly negative; lift bag: a 100 L open-bottom salvage bag folded.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import trimesh
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.dynamics.free_body import Hydro
from uhrisim.world import primitives as prim
from uhrisim.world.tool_kinds import TOOL_KINDS

_ALONG_X = {"pitch": math.pi / 2.0}


@dataclass(frozen=True)
class Tool:
    """A carryable object (module docstring). Frame: the tool's own, metres."""

    name: str
    kind: str
    hydro: Hydro
    size: tuple[float, float, float]
    grasp_point: tuple[float, float, float]
    working_point: tuple[float, float, float]
    grasp_width: float  # m, the handle's thickness a hand or jaw closes on

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"must be a non-empty string, got {self.name!r}",
                              where="Tool.name")
        if self.kind not in TOOL_KINDS:
            raise ConfigError(f"unknown kind {self.kind!r} (have {', '.join(TOOL_KINDS)})",
                              where=f"Tool({self.name!r}).kind")
        if len(self.size) != 3 or not all(math.isfinite(s) and s > 0 for s in self.size):
            raise ConfigError(f"must be three lengths > 0, got {self.size!r}",
                              where=f"Tool({self.name!r}).size")
        half = 0.5 * np.asarray(self.size) + 1e-9
        for field_name in ("grasp_point", "working_point"):
            point = np.asarray(getattr(self, field_name), dtype=float)
            if point.shape != (3,) or np.any(np.abs(point) > half):
                raise ConfigError(f"must lie inside the tool's {self.size} box, got {point}",
                                  where=f"Tool({self.name!r}).{field_name}")

    @property
    def label(self) -> str:
        return self.kind

    @property
    def in_water_weight(self) -> float:
        """Weight minus buoyancy (N) in sea water."""
        return self.hydro.in_water_weight()

    def grasp_offset(self) -> NDArray[np.float64]:
        """(3,) grasp point in the tool frame."""
        return np.array(self.grasp_point, dtype=float)

    def mesh(self) -> trimesh.Trimesh:
        """The tool in its own frame (procedural, a few hundred triangles at most)."""
        return _MESHES[self.kind](self.size)


def _wrench(size: tuple[float, float, float]) -> trimesh.Trimesh:
    length, width, thick = size
    return trimesh.util.concatenate([
        prim.box((length - 0.08, 0.035, thick)),  # handle
        prim.box((0.08, width, thick), (0.5 * length - 0.04, 0.0, 0.0)),  # open jaw end
        prim.cylinder(0.035, thick, (-0.5 * length + 0.035, 0.0, 0.0), sections=16),  # ring
    ])


def _hammer(size: tuple[float, float, float]) -> trimesh.Trimesh:
    length, width, thick = size
    return trimesh.util.concatenate([
        prim.cylinder(0.015, length - 0.05, (-0.025, 0.0, 0.0), sections=12, **_ALONG_X),
        prim.box((0.05, width, thick), (0.5 * length - 0.025, 0.0, 0.0)),  # head across
    ])


def _light(size: tuple[float, float, float]) -> trimesh.Trimesh:
    return prim.cylinder(0.5 * size[1], size[0], sections=20, **_ALONG_X)


def _folded_bag(size: tuple[float, float, float]) -> trimesh.Trimesh:
    return prim.box(size)


def _basket(size: tuple[float, float, float]) -> trimesh.Trimesh:
    """An open box (bottom and four walls, 1 cm mesh plates) with a bail handle."""
    lx, ly, lz = size
    wall = 0.01
    bottom_z = 0.5 * lz - 0.5 * wall
    parts = [prim.box((lx, ly, wall), (0.0, 0.0, bottom_z))]
    for s in (-1.0, 1.0):
        parts.append(prim.box((wall, ly, lz), (s * (0.5 * lx - 0.5 * wall), 0.0, 0.0)))
        parts.append(prim.box((lx, wall, lz), (0.0, s * (0.5 * ly - 0.5 * wall), 0.0)))
    parts.append(prim.box((0.02, 0.02, 0.02), (0.0, 0.0, -0.5 * lz + 0.01)))  # handle grip
    return trimesh.util.concatenate(parts)


_MESHES = {"wrench": _wrench, "hammer": _hammer, "light": _light, "lift_bag": _folded_bag,
           "tool_basket": _basket}


def _flat(mass: float, volume: float, size: tuple[float, float, float], cd: float) -> Hydro:
    """Hydro of a tool that falls lying flat (drag on its largest face)."""
    return Hydro(mass, volume, cd, size[0] * size[1], bottom_offset=0.5 * size[2])


#: The catalogue (module docstring); name each instance with :func:`make_tool`.
CATALOGUE: dict[str, Tool] = {
    "wrench": Tool("wrench", "wrench", _flat(1.30, 1.30 / 7850.0, (0.45, 0.05, 0.015), 1.2),
                   (0.45, 0.08, 0.015), (-0.08, 0.0, 0.0), (0.185, 0.0, 0.0), 0.015),
    "hammer": Tool("hammer", "hammer",
                   _flat(1.40, 1.13 / 7850.0 + 0.27 / 670.0, (0.27, 0.04, 0.05), 1.2),
                   (0.27, 0.11, 0.05), (-0.08, 0.0, 0.0), (0.11, 0.05, 0.0), 0.03),
    "light": Tool("light", "light", _flat(0.60, 0.50e-3, (0.20, 0.06, 0.06), 1.2),
                  (0.20, 0.06, 0.06), (-0.03, 0.0, 0.0), (0.10, 0.0, 0.0), 0.06),
    "lift_bag": Tool("lift_bag", "lift_bag", _flat(2.00, 2.00 / 1300.0, (0.35, 0.25, 0.10), 1.2),
                     (0.35, 0.25, 0.10), (0.0, 0.0, -0.05), (0.0, 0.0, 0.05), 0.03),
    "tool_basket": Tool("tool_basket", "tool_basket",
                        Hydro(8.0, 8.0 / 7850.0, 1.0, 0.6 * 0.4 * 0.4, bottom_offset=0.15),
                        (0.60, 0.40, 0.30), (0.0, 0.0, -0.14), (0.0, 0.0, 0.14), 0.02),
}


def make_tool(kind: str, name: str, mass_kg: float | None = None) -> Tool:
    """A catalogue tool of ``kind`` named ``name`` (ConfigError listing the kinds);
    ``mass_kg`` (air, kg): a lighter or heavier one of the same material and shape — its
    volume scales with the mass, so its density and its in-water weight per kg stay."""
    if kind not in CATALOGUE:
        raise ConfigError(f"unknown tool kind {kind!r} (have {', '.join(TOOL_KINDS)})",
                          where=f"tool {name!r}")
    tool = replace(CATALOGUE[kind], name=name)
    if mass_kg is None:
        return tool
    if not (math.isfinite(mass_kg) and mass_kg > 0.0):
        raise ConfigError(f"must be a finite mass > 0 kg, got {mass_kg!r}",
                          where=f"tool {name!r}.mass_kg")
    scale = mass_kg / tool.hydro.mass
    return replace(tool, hydro=replace(tool.hydro, mass=mass_kg,
                                       volume=tool.hydro.volume * scale))
