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

A material may also carry a :class:`PlanarTexture`: a picture printed on one plane of the
object (a diver's slate with a fiducial marker), whose albedo the camera looks up where a
ray hits that plane; everywhere else on the object the material's ``albedo_rgb`` holds.
Or a :class:`RippleTexture`: sand ripples, an albedo that varies across the ripples'
crests (lit flanks and crests pale, troughs darker) with a mottle of finer grain.

The articulated diver wears a part material each (:data:`DIVER_PART_MATERIALS`): a dark
dry suit, a yellow-painted cylinder, bright fins, gloves, a hood and mask; the commercial
diver's helmet is yellow and his boots black rubber. Each keeps the reflectivity its part
had (neoprene, the cylinder aluminium), so the sonar sees the diver as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.errors import ConfigError


@dataclass(frozen=True, eq=False)
class PlanarTexture:
    """A picture on a plane of an object: diffuse albedo by where a ray hits (camera only).

    Everything is in the object's own frame: a dynamic body's body frame (FRD, m), world
    NED for a static object. The picture's top-left corner is ``origin``; ``right`` and
    ``down`` are unit vectors along its rows and columns; it is ``width_m`` × ``height_m``.
    ``image`` is (rows, cols, 3) linear albedo in [0, 1], row 0 at the top. A hit sees the
    texel it falls in (nearest: printed cells stay sharp-edged) when it lies within
    ``tolerance_m`` of the plane and inside the picture; elsewhere the material's own
    albedo holds. The picture shows from both sides of its plane (mirrored from behind);
    a slate's back face, ``thickness`` away, is beyond the tolerance. Compared by identity.
    """

    image: NDArray[np.float32]
    origin: tuple[float, float, float]
    right: tuple[float, float, float]
    down: tuple[float, float, float]
    width_m: float
    height_m: float
    tolerance_m: float = 1e-3

    def __post_init__(self) -> None:
        where = "PlanarTexture"
        img = np.asarray(self.image, dtype=np.float32)
        if img.ndim != 3 or img.shape[2] != 3 or min(img.shape[:2]) < 1:
            raise ConfigError(f"image must be (rows, cols, 3), got {img.shape}", where)
        if not (np.all(np.isfinite(img)) and img.min() >= 0.0 and img.max() <= 1.0):
            raise ConfigError("image albedos must be finite and in [0, 1]", where)
        img.setflags(write=False)
        object.__setattr__(self, "image", img)
        right, down = (np.asarray(v, dtype=float).reshape(-1) for v in (self.right, self.down))
        if right.shape != (3,) or down.shape != (3,):
            raise ConfigError("right and down must be 3-vectors", where)
        if (abs(right @ right - 1.0) > 1e-6 or abs(down @ down - 1.0) > 1e-6
                or abs(right @ down) > 1e-6):
            raise ConfigError("right and down must be orthogonal unit vectors", where)
        for name in ("width_m", "height_m", "tolerance_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
                raise ConfigError(f"{name} must be a finite number > 0, got {v!r}", where)
        for name in ("origin", "right", "down"):
            object.__setattr__(self, name, tuple(float(c) for c in np.asarray(
                getattr(self, name), dtype=float).reshape(3)))

    @property
    def normal(self) -> NDArray[np.float64]:
        """Unit normal of the picture's plane, right × down: it points away from whoever
        reads the picture (as an OpenCV camera's z axis does)."""
        return np.cross(self.right, self.down)

    def albedo_at(self, points: ArrayLike) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """(N, 3) albedo of the texel under each of the (N, 3) points (object frame, m)
        and (N,) whether the point is on the picture; rows off it read texel (0, 0)."""
        rel = np.asarray(points, dtype=float) - np.asarray(self.origin)
        u = rel @ np.asarray(self.right)
        v = rel @ np.asarray(self.down)
        on = ((np.abs(rel @ self.normal) <= self.tolerance_m)
              & (u >= 0.0) & (u < self.width_m) & (v >= 0.0) & (v < self.height_m))
        rows, cols = self.image.shape[:2]
        col = np.where(on, np.floor(u / self.width_m * cols), 0).astype(np.intp)
        row = np.where(on, np.floor(v / self.height_m * rows), 0).astype(np.intp)
        return self.image[np.minimum(row, rows - 1), np.minimum(col, cols - 1)], on


def ripple_factor(north: ArrayLike, east: ArrayLike, cos_a: float, sin_a: float, k: float,
                  meander_m: float, contrast: float, grain: float) -> NDArray[np.float64]:
    """:meth:`RippleTexture.factor` at points (``north``, ``east``) (m, NED), float64,
    from its :meth:`RippleTexture.constants`; on arrays, or compiled on floats (the
    camera's :mod:`~uhrisim.sensors.camera.fused` kernel calls it per ray)."""
    across = north * cos_a + east * sin_a
    along = -north * sin_a + east * cos_a
    s = across + meander_m * np.sin(k * along / 4.0)
    profile = (np.sin(k * s) + 0.35 * np.sin(2.0 * k * s)) / 1.2
    mottle = np.sin(37.0 * north + 11.0 * np.sin(23.0 * east)) * np.cos(
        41.0 * east + 7.0 * np.sin(29.0 * north))
    return 1.0 + contrast * profile + grain * mottle


@dataclass(frozen=True, eq=False)
class RippleTexture:
    """Sand ripples as an albedo pattern on a static surface (camera only; world NED, m).

    Along ``direction_deg`` (compass, across the crests) the albedo is multiplied by
    ``1 + contrast·r(s)`` with ``s`` the distance along it over ``wavelength_m`` and ``r``
    an asymmetric ripple profile in [-1, 1] (a sine and its second harmonic: steep lee
    sides, long stoss sides, as wave-formed ripples of 5–20 cm wavelength are), the
    crests bending gently (``meander_m`` amplitude over 4 wavelengths) and a fine mottle
    of ``grain`` relative amplitude. Deterministic; every point is "on" the texture.
    """

    wavelength_m: float = 0.12
    direction_deg: float = 30.0
    contrast: float = 0.25
    meander_m: float = 0.02
    grain: float = 0.06

    def __post_init__(self) -> None:
        for name in ("wavelength_m", "contrast", "meander_m", "grain"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0.0):
                raise ConfigError(f"{name} must be a finite number >= 0, got {v!r}",
                                  "RippleTexture")
        if self.wavelength_m <= 0.0 or self.contrast + self.grain >= 1.0:
            raise ConfigError("wavelength_m must be > 0 and contrast + grain < 1",
                              "RippleTexture")

    def factor(self, points: ArrayLike) -> NDArray[np.float32]:
        """(N,) albedo factor at (N, 3) points (NED, m); its mean over a ripple is 1."""
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        return ripple_factor(p[:, 0], p[:, 1], *self.constants()).astype(np.float32)

    def constants(self) -> tuple[float, float, float, float, float, float]:
        """:func:`ripple_factor`'s constants: cos and sin of the direction, the wave
        number (rad/m), the meander (m), the contrast and the grain."""
        a = math.radians(self.direction_deg)
        return (math.cos(a), math.sin(a), 2.0 * math.pi / self.wavelength_m, self.meander_m,
                self.contrast, self.grain)

    def albedo_over(self, albedo_rgb: ArrayLike, points: ArrayLike
                    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """(N, 3) albedo of a surface of ``albedo_rgb`` at (N, 3) points (NED, m), and
        (N,) True: the ripples cover the whole surface."""
        f = self.factor(points)
        albedo = np.clip(np.asarray(albedo_rgb, np.float32)[None, :] * f[:, None], 0.0, 1.0)
        return albedo, np.ones(len(f), bool)


@dataclass(frozen=True)
class Material:
    """A surface's acoustic and optical properties.

    Attributes:
        name: human-readable name (e.g. ``"sand"``).
        reflectivity: Lambert scattering coefficient μ, linear, in [0, 1] (sonar).
        albedo_rgb: diffuse reflectance per camera channel (R, G, B), linear, in [0, 1].
        texture: a picture on one plane of the object, or sand ripples (None: one albedo
            all over).
    """

    name: str
    reflectivity: float
    albedo_rgb: tuple[float, float, float] = (0.5, 0.5, 0.5)
    texture: PlanarTexture | RippleTexture | None = None

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
        if self.texture is not None and not isinstance(self.texture,
                                                       (PlanarTexture, RippleTexture)):
            raise ConfigError(f"must be a PlanarTexture, a RippleTexture or None, got "
                              f"{self.texture!r}", where=f"Material({self.name!r}).texture")

    def albedo_at(self, points: ArrayLike) -> NDArray[np.float32]:
        """(N, 3) albedo at (N, 3) points in the object's frame (static: NED, m): the
        texture's where it has one, ``albedo_rgb`` elsewhere."""
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        base = np.broadcast_to(np.asarray(self.albedo_rgb, np.float32), (len(p), 3))
        if self.texture is None:
            return base.copy()
        if isinstance(self.texture, RippleTexture):
            return self.texture.albedo_over(self.albedo_rgb, p)[0]
        texel, on = self.texture.albedo_at(p)
        return np.where(on[:, None], texel, base).astype(np.float32)


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
#: Sand as a scenario's sea floor is drawn: the same sand, rippled (:class:`RippleTexture`).
SAND_RIPPLED = Material("sand_rippled", SAND.reflectivity, SAND.albedo_rgb, RippleTexture())

# The articulated diver's part materials (module docstring). Reflectivities: neoprene's,
# the cylinder's aluminium's; albedos plausible for the colours named.
DRY_SUIT = Material("dry_suit", NEOPRENE.reflectivity, (0.035, 0.04, 0.055))  # black-blue
HOOD_MASK = Material("hood_mask", NEOPRENE.reflectivity, (0.12, 0.13, 0.15))  # hood, skirt
GLOVES = Material("gloves", NEOPRENE.reflectivity, (0.55, 0.38, 0.28))  # tan, skin-like
FIN_BLADES = Material("fin_blades", NEOPRENE.reflectivity, (0.03, 0.20, 0.55))  # blue
BOOT_RUBBER = Material("boot_rubber", NEOPRENE.reflectivity, (0.02, 0.02, 0.02))
TANK_PAINT = Material("tank_paint", ALUMINIUM.reflectivity, (0.75, 0.58, 0.04))  # yellow
HELMET_PAINT = Material("helmet_paint", ALUMINIUM.reflectivity, (0.80, 0.62, 0.05))

#: Material of each part label of the articulated diver (uhrisim.world.diver_figure;
#: None: the body's own parts, the suit; "helmet": the commercial diver's head).
DIVER_PART_MATERIALS: dict[str | None, Material] = {
    None: DRY_SUIT, "arm": DRY_SUIT, "head": HOOD_MASK, "hand": GLOVES, "fins": FIN_BLADES,
    "boots": BOOT_RUBBER, "tank": TANK_PAINT, "helmet": HELMET_PAINT,
}

DEFAULT_MATERIALS: dict[str, Material] = {
    m.name: m for m in (SAND, MUD, ROCK, CONCRETE, STEEL, WOOD, NEOPRENE, ALUMINIUM, ROV_PLASTIC,
                        SAND_RIPPLED, DRY_SUIT, HOOD_MASK, GLOVES, FIN_BLADES, BOOT_RUBBER,
                        TANK_PAINT, HELMET_PAINT)
}
