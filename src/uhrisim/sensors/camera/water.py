"""Optical properties of sea water per camera channel (R, G, B): the water types.

Each :class:`WaterOptics` gives, per channel, the absorption ``a`` and scattering ``b``
coefficients (1/m); the beam attenuation is ``c = a + b``. Scattering is split between
water molecules (fraction ``molecular_fraction``, phase function nearly isotropic:
Henyey–Greenstein g = 0) and particles (HG g = 0.924, forward-peaked). From these follow
the backscattering coefficient ``b_b`` and the diffuse attenuation of down-welling
daylight ``K_d``.

Sources (see ``docs/camera.md``):

* RGB a, b and molecular fractions of the Jerlov water types: M. Droske, J. Hanika,
  J. Vorba, A. Weidlich, M. Sabbadin, "Path Tracing in Production: The Path of Water",
  ACM SIGGRAPH 2023 Courses — RGB reductions of the spectral IOPs of Solonenko & Mobley,
  "Inherent optical properties of Jerlov water types", Appl. Opt. 54(17) 5392 (2015).
  Jerlov classes: N. G. Jerlov, *Marine Optics* (Elsevier, 1976): oceanic I, IA, IB, II,
  III and coastal 1C…9C. The published 5C row (a_R = 4.638, b_R = 3.589 /m) breaks the
  monotone trend from 3C to 7C by an order of magnitude in red; we leave 5C out rather
  than copy a probable transcription error (give a measured coefficient instead).
* Particle phase function HG g = 0.924 (same course; close to Petzold's average particle
  function, backscatter fraction ≈ 0.018, Mobley, *Light and Water*, 1994).
* ``K_d ≈ 1.0395·(a + b_b)/μ₀`` with the sun at the zenith (μ₀ = 1): H. R. Gordon, "Can
  the Lambert-Beer law be applied to the diffuse attenuation coefficient of ocean
  water?", Limnol. Oceanogr. 34(8) 1389 (1989).

Local turbidity (a silt cloud a diver kicks up: :class:`uhrisim.world.silt.SiltMedium`)
adds beam attenuation where it is; :func:`through_cloud` applies it to an image by
Koschmieder's law (H. Koschmieder, Beitr. Phys. freien Atm. 12, 1924; for water S. Q.
Duntley, "The visibility of submerged objects", 1952): along a ray of extra optical depth
τ the radiance becomes ``L·exp(−τ) + L_∞·(1 − exp(−τ))``, L_∞ the equilibrium (path)
radiance of the water in that direction — the cloud assumed to scatter like the water's
own particles in the same light field, so a thick cloud looks like open water there. The
apparent contrast of anything behind the cloud falls as exp(−τ).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError

#: Henyey–Greenstein asymmetry of the particle phase function (Droske et al. 2023).
PARTICLE_G = 0.924
#: Gordon (1989): K_d ≈ 1.0395 (a + b_b) / μ₀; sun at the zenith.
GORDON_KD_FACTOR = 1.0395


def hg_backscatter_fraction(g: float) -> float:
    """Share of a Henyey–Greenstein phase function's scattering into the back hemisphere
    (closed form of ∫_{π/2}^{π} p_HG(θ) 2π sinθ dθ)."""
    if g == 0.0:
        return 0.5
    return (1.0 - g) / (2.0 * g) * ((1.0 + g) / math.sqrt(1.0 + g * g) - 1.0)


def hg_phase(cos_theta: NDArray, g: float) -> NDArray:
    """Henyey–Greenstein phase function (1/sr) at scattering-angle cosine ``cos_theta``."""
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * cos_theta) ** 1.5)


@dataclass(frozen=True)
class WaterOptics:
    """Inherent optical properties per channel (R, G, B), 1/m."""

    name: str
    absorption: tuple[float, float, float]
    scattering: tuple[float, float, float]
    molecular_fraction: float = 0.0

    def __post_init__(self) -> None:
        for field in ("absorption", "scattering"):
            values = tuple(getattr(self, field))
            if len(values) != 3 or not all(
                isinstance(v, (int, float)) and math.isfinite(v) and v >= 0.0 for v in values
            ):
                raise ConfigError(
                    f"must be three finite numbers >= 0 (1/m, R G B), got {values!r}",
                    where=f"water {self.name!r}.{field}",
                )
            object.__setattr__(self, field, tuple(float(v) for v in values))
        if not 0.0 <= self.molecular_fraction <= 1.0:
            raise ConfigError(
                f"must be in [0, 1], got {self.molecular_fraction!r}",
                where=f"water {self.name!r}.molecular_fraction",
            )
        if not all(a + b > 0.0 for a, b in zip(self.absorption, self.scattering, strict=True)):
            raise ConfigError(
                "attenuation a + b must be > 0 in every channel", where=f"water {self.name!r}"
            )

    @property
    def a(self) -> NDArray[np.float64]:
        return np.array(self.absorption)

    @property
    def b(self) -> NDArray[np.float64]:
        return np.array(self.scattering)

    @property
    def c(self) -> NDArray[np.float64]:
        """Beam attenuation coefficient c = a + b per channel (1/m)."""
        return self.a + self.b

    @property
    def backscatter_fraction(self) -> float:
        """b_b / b: molecules scatter half backwards, particles ~1.7 %."""
        w = self.molecular_fraction
        return w * 0.5 + (1.0 - w) * hg_backscatter_fraction(PARTICLE_G)

    @property
    def b_b(self) -> NDArray[np.float64]:
        """Backscattering coefficient per channel (1/m)."""
        return self.b * self.backscatter_fraction

    @property
    def k_d(self) -> NDArray[np.float64]:
        """Diffuse attenuation of down-welling daylight per channel (1/m), Gordon (1989)."""
        return GORDON_KD_FACTOR * (self.a + self.b_b)

    def phase(self, cos_theta: NDArray) -> NDArray:
        """Phase function (1/sr) of the mixture of molecules and particles."""
        w = self.molecular_fraction
        return w * hg_phase(cos_theta, 0.0) + (1.0 - w) * hg_phase(cos_theta, PARTICLE_G)


# Droske et al. (2023), RGB reductions of Solonenko & Mobley (2015): (a, b, molecular share).
_JERLOV: dict[str, tuple[tuple[float, float, float], tuple[float, float, float], float]] = {
    "I": ((0.309, 0.053, 0.009), (0.001, 0.002, 0.004), 0.93),
    "IA": ((0.309, 0.054, 0.014), (0.002, 0.004, 0.007), 0.44),
    "IB": ((0.309, 0.054, 0.015), (0.045, 0.054, 0.070), 0.06),
    "II": ((0.310, 0.054, 0.016), (0.270, 0.365, 0.516), 0.007),
    "III": ((0.310, 0.056, 0.031), (0.737, 0.998, 1.413), 0.003),
    "1C": ((0.316, 0.067, 0.105), (0.274, 0.372, 0.526), 0.005),
    "3C": ((0.508, 0.052, 0.161), (0.904, 1.071, 1.532), 0.003),
    "7C": ((0.351, 0.188, 0.574), (1.772, 2.394, 3.376), 0.0),
    "9C": ((0.398, 0.349, 0.995), (2.347, 3.180, 4.496), 0.0),
}

#: The documented water types by Jerlov class name.
JERLOV_TYPES: dict[str, WaterOptics] = {
    name: WaterOptics(f"jerlov-{name}", a, b, w) for name, (a, b, w) in _JERLOV.items()
}


def jerlov(name: str) -> WaterOptics:
    """The Jerlov water type ``name`` (I, IA, IB, II, III, 1C, 3C, 7C, 9C)."""
    water = JERLOV_TYPES.get(str(name))
    if water is None:
        raise ConfigError(
            f"unknown Jerlov type {name!r}; known: {', '.join(JERLOV_TYPES)} "
            "(5C is left out: see docs/camera.md)",
            where="water.jerlov",
        )
    return water


def measured(
    attenuation: tuple[float, float, float], single_scattering_albedo: float = 0.8
) -> WaterOptics:
    """Water from a measured beam attenuation c per channel (1/m, e.g. a transmissometer),
    split into b = ω₀·c and a = (1 − ω₀)·c with the single-scattering albedo ω₀ (0.8 is
    typical of particle-rich coastal water; give your own), all scattering by particles."""
    c = tuple(attenuation)
    if len(c) != 3 or not all(
        isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0 for v in c
    ):
        raise ConfigError(
            f"must be three finite numbers > 0 (1/m, R G B), got {attenuation!r}",
            where="water.attenuation",
        )
    w0 = float(single_scattering_albedo)
    if not 0.0 <= w0 < 1.0:
        raise ConfigError(f"must be in [0, 1), got {w0!r}", where="water.single_scattering_albedo")
    return WaterOptics(
        "measured", tuple((1.0 - w0) * v for v in c), tuple(w0 * v for v in c), 0.0
    )


def through_cloud(radiance: NDArray[np.float32], optical_depth: NDArray[np.float32],
                  background: NDArray[np.float32]) -> NDArray[np.float32]:
    """Koschmieder's law (module docstring): (H, W, 3) ``radiance`` seen through a
    local cloud of extra (H, W) ``optical_depth``, against the water's (H, W, 3) path
    radiance ``background`` in each pixel's direction (a new array)."""
    transmittance = np.exp(-optical_depth)[..., None].astype(radiance.dtype)
    return background + (radiance - background) * transmittance
