"""Acoustic surface materials for the ray caster.

A :class:`Material` carries the Lambert scattering coefficient ``reflectivity`` (μ, linear,
0..1) used by the sonar's target-strength term ``TS ≈ 10·log10(μ·cos²β·A)``
(see ``shared/reference/sonar.md``).

The values below are **defaults, not facts**: they are order-of-magnitude choices so that
sand is darker than concrete, steel and a scuba tank in a sonar image. Published Lambert
coefficients vary by an order of magnitude with grain size, frequency and grazing angle
(sandy seabeds are commonly quoted around μ ≈ −27…−20 dB, i.e. 0.002–0.01, at tens to
hundreds of kHz; hard man-made targets are much brighter). Expose them in scenarios and
calibrate against real data where it matters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from uhrisim.core.errors import ConfigError


@dataclass(frozen=True)
class Material:
    """A surface's acoustic properties.

    Attributes:
        name: human-readable name (e.g. ``"sand"``).
        reflectivity: Lambert scattering coefficient μ, linear, in [0, 1].
    """

    name: str
    reflectivity: float

    def __post_init__(self) -> None:
        r = self.reflectivity
        if not isinstance(r, (int, float)) or not math.isfinite(r) or not 0.0 <= r <= 1.0:
            raise ConfigError(
                f"reflectivity must be a finite number in [0, 1], got {r!r}",
                where=f"Material({self.name!r}).reflectivity",
            )


# Defaults (see module docstring: chosen for plausible contrast, not measured).
SAND = Material("sand", 0.02)
MUD = Material("mud", 0.005)
ROCK = Material("rock", 0.08)
CONCRETE = Material("concrete", 0.2)
STEEL = Material("steel", 0.5)
WOOD = Material("wood", 0.1)
NEOPRENE = Material("neoprene", 0.05)
ALUMINIUM = Material("aluminium", 0.6)
ROV_PLASTIC = Material("rov_plastic", 0.15)

DEFAULT_MATERIALS: dict[str, Material] = {
    m.name: m for m in (SAND, MUD, ROCK, CONCRETE, STEEL, WOOD, NEOPRENE, ALUMINIUM, ROV_PLASTIC)
}
