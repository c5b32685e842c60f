"""Surface materials for the ray caster: acoustic (sonar) and optical (camera).

A :class:`Material` carries the Lambert scattering coefficient ``reflectivity`` (μ, linear,
0..1) used by the sonar's target-strength term ``TS ≈ 10·log10(μ·cos²β·A)``
(see ``docs/reference/sonar.md``), and the diffuse (Lambertian) optical reflectance
``albedo_rgb`` per camera channel (linear, 0..1) that the camera uses
(:mod:`uhrisim.sensors.camera`).

The values below are **defaults, not facts** (acoustic and optical alike): they are
order-of-magnitude choices so that sand is darker than concrete, steel and a scuba tank
in a sonar image. Published Lambert coefficients vary by an order of magnitude with
grain size, frequency and grazing angle (sandy seabeds are commonly quoted around
μ ≈ −27…−20 dB, i.e. 0.002–0.01, at tens to hundreds of kHz; hard man-made targets are
much brighter). The optical albedos are plausible diffuse reflectances (pale sand
brighter than mud, a black neoprene suit about 5 %, the VideoRay's yellow hull). Expose
them in scenarios and calibrate against real data where it matters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from uhrisim.core.errors import ConfigError


@dataclass(frozen=True)
class Material:
    """A surface's acoustic and optical properties.

    Attributes:
        name: human-readable name (e.g. ``"sand"``).
        reflectivity: Lambert scattering coefficient μ, linear, in [0, 1] (sonar).
        albedo_rgb: diffuse reflectance per camera channel (R, G, B), linear, in [0, 1].
    """

    name: str
    reflectivity: float
    albedo_rgb: tuple[float, float, float] = (0.5, 0.5, 0.5)

    def __post_init__(self) -> None:
        r = self.reflectivity
        if not isinstance(r, (int, float)) or not math.isfinite(r) or not 0.0 <= r <= 1.0:
            raise ConfigError(
                f"reflectivity must be a finite number in [0, 1], got {r!r}",
                where=f"Material({self.name!r}).reflectivity",
            )
        albedo = tuple(self.albedo_rgb)
        if len(albedo) != 3 or not all(
            isinstance(v, (int, float)) and math.isfinite(v) and 0.0 <= v <= 1.0 for v in albedo
        ):
            raise ConfigError(
                f"must be three finite numbers in [0, 1], got {self.albedo_rgb!r}",
                where=f"Material({self.name!r}).albedo_rgb",
            )
        object.__setattr__(self, "albedo_rgb", tuple(float(v) for v in albedo))


# Defaults (see module docstring: chosen for plausible contrast, not measured).
SAND = Material("sand", 0.02, (0.45, 0.40, 0.30))
MUD = Material("mud", 0.005, (0.15, 0.13, 0.10))
ROCK = Material("rock", 0.08, (0.25, 0.24, 0.22))
CONCRETE = Material("concrete", 0.2, (0.45, 0.45, 0.42))
STEEL = Material("steel", 0.5, (0.35, 0.36, 0.38))
WOOD = Material("wood", 0.1, (0.35, 0.25, 0.15))
NEOPRENE = Material("neoprene", 0.05, (0.05, 0.05, 0.06))
ALUMINIUM = Material("aluminium", 0.6, (0.60, 0.60, 0.62))
ROV_PLASTIC = Material("rov_plastic", 0.15, (0.70, 0.55, 0.05))

DEFAULT_MATERIALS: dict[str, Material] = {
    m.name: m for m in (SAND, MUD, ROCK, CONCRETE, STEEL, WOOD, NEOPRENE, ALUMINIUM, ROV_PLASTIC)
}
