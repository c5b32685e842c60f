"""Camera configuration: intrinsics, mount, lamps, water, daylight and sensor (validated).

Units and frames (``docs/conventions.md``): SI; the **camera frame** is FRD-like — x along
the optical axis, y to the right of the image, z down the image — mounted on the vehicle
like the sonar (tilt > 0 points it down, yaw > 0 to starboard). Pixel (u, v) (column,
row; u right, v down) looks along ((v − c_y)/f_y, …): see :mod:`.geometry`.

Light is in *relative radiometric units*: the down-welling daylight radiance just below
the surface is ``sun_radiance`` (1 = a bright overcast day, per channel, white-balanced);
a lamp of intensity I (same units × m²) lights a surface d metres away, on its axis, with
irradiance I/d². ``exposure`` maps radiance to the sensor's full scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.core.settings import check_settings, setting
from uhrisim.sensors.camera.water import WaterOptics, jerlov


@dataclass(frozen=True)
class Lamp:
    """A lamp on the vehicle, pointing along the camera axis.

    ``position_cam``: (3,) offset from the camera centre in the camera frame (m);
    ``half_angle_deg``: half-power half-angle of its Gaussian beam; ``intensity``: on-axis
    radiant intensity (relative units × m²)."""

    position_cam: tuple[float, float, float]
    half_angle_deg: float = 40.0
    intensity: float = 20.0


@dataclass(frozen=True)
class CameraSpec:
    """A camera model's defaults (a preset)."""

    name: str
    width: int
    height: int
    hfov_deg: float
    lamps: tuple[Lamp, ...]
    mount_position_frd: tuple[float, float, float]
    tilt_deg: float
    description: str


#: VideoRay Pro 4 class: an SD colour camera looking forward through the front dome, two
#: LED lamps either side of it. Numbers are typical of the class (assumptions, not a
#: datasheet): 640×480, 80° horizontal field of view in water, lamps 0.12 m either side,
#: 40° half-power half-angle.
PRESETS: dict[str, CameraSpec] = {
    "videoray-pro4": CameraSpec(
        name="videoray-pro4",
        width=640,
        height=480,
        hfov_deg=80.0,
        lamps=(Lamp((0.0, -0.12, 0.02)), Lamp((0.0, 0.12, 0.02))),
        mount_position_frd=(0.17, 0.0, 0.0),
        tilt_deg=0.0,
        description="VideoRay Pro 4 class front camera with two LED lamps",
    ),
}


def _finite(value: object, name: str, lo: float = -math.inf, hi: float = math.inf,
            lo_open: bool = False) -> float:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ConfigError(f"must be a number, got {value!r}", name) from None
    if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo):
        bound = f"> {lo:g}" if lo_open else f">= {lo:g}"
        raise ConfigError(f"must be a finite number {bound} and <= {hi:g}, got {value!r}", name)
    return v


#: The most pixels a camera may have: its pixel rays and lamp tables take ~90 MB a
#: megapixel (1920 x 1200, a machine-vision sensor, fits).
MAX_PIXELS = 2_500_000


@dataclass(frozen=True)
class CameraConfig:
    """A validated camera configuration (every default here or in the preset)."""

    preset: str = "videoray-pro4"
    width: int | None = setting(None, "px", ge=1, le=8192, integer=True,
                                doc="image width (None: the preset's)", cost="linear")
    height: int | None = setting(None, "px", ge=1, le=8192, integer=True,
                                 doc="image height (None: the preset's)", cost="linear")
    hfov_deg: float | None = setting(None, "deg", gt=0.0, lt=180.0,
                                     doc="horizontal field of view (None: the preset's or K's)")
    #: full intrinsic matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (pixels); overrides hfov
    K: tuple[tuple[float, float, float], ...] | None = None
    rate_hz: float = setting(10.0, "Hz", gt=0.0, le=1000.0, doc="frame rate", cost="linear")
    max_range_m: float = setting(30.0, "m", ge=0.1, le=1e4, doc="farthest surface seen")
    #: "adaptive": rays on every second pixel, more only where the image needs them
    #: (:mod:`.sampling`); "full": one ray per pixel
    sampling: Literal["adaptive", "full"] = "adaptive"
    mount_position_frd: tuple[float, float, float] | None = setting(
        None, "m", doc="camera centre in the body frame FRD (None: the preset's)")
    tilt_deg: float | None = setting(None, "deg", ge=-90.0, le=90.0,
                                     doc="tilt of the optical axis, > 0 down (None: the preset's)")
    yaw_deg: float = setting(0.0, "deg", ge=-360.0, le=360.0,
                             doc="yaw of the optical axis from the bow, > 0 starboard")
    water: WaterOptics = field(default_factory=lambda: jerlov("IB"))
    lamps_on: bool = True
    lamp_power: float = setting(1.0, "1", ge=0.0, le=1e6, doc="multiplies every lamp's intensity")
    sun_radiance: float = setting(1.0, "relative", ge=0.0, le=1e6,
                                  doc="down-welling radiance just below the surface")
    forward_scatter: bool = True
    forward_scatter_spread: float = setting(
        0.01, "rad", ge=0.0, le=1.0, doc="forward-scatter blur per unit scattering depth b·r")
    exposure: float | Literal["auto"] = "auto"  # radiance gain to full scale, or "auto"
    auto_exposure_target: float = setting(0.25, "1", gt=0.0, le=1.0,
                                          doc="mean linear level auto exposure aims for")
    max_gain: float = setting(2000.0, "1", gt=0.0, le=1e12,
                              doc="auto exposure never amplifies more than this")
    noise: bool = True
    full_well_e: float = setting(6000.0, "e⁻", ge=1.0, le=1e9,
                                 doc="electrons at full scale (shot noise)")
    read_noise_e: float = setting(8.0, "e⁻", ge=0.0, le=1e6, doc="read noise, rms")

    def __post_init__(self) -> None:
        spec = PRESETS.get(self.preset)
        if spec is None:
            raise ConfigError(
                f"unknown camera preset {self.preset!r}; known: {', '.join(PRESETS)}",
                "camera.preset",
            )
        check_settings(self, "camera")  # the declared bounds, before the preset fills in
        object.__setattr__(self, "width", int(spec.width if self.width is None else self.width))
        object.__setattr__(self, "height",
                           int(spec.height if self.height is None else self.height))
        if self.width * self.height > MAX_PIXELS:
            raise ConfigError(
                f"{self.width} x {self.height} pixels is more than {MAX_PIXELS / 1e6:g} "
                "megapixels (the camera's ray tables take ~90 MB a megapixel)", "camera.width")
        if self.K is not None:
            k = np.asarray(self.K, dtype=float)
            if k.shape != (3, 3) or not np.all(np.isfinite(k)) or not (
                    k[0, 0] > 0 and k[1, 1] > 0) or np.any(k[2] != (0.0, 0.0, 1.0)):
                raise ConfigError(
                    "must be a 3x3 intrinsic matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with "
                    f"fx, fy > 0, got {self.K!r}", "camera.K")
            object.__setattr__(self, "K", tuple(tuple(float(v) for v in row) for row in k))
            if self.hfov_deg is not None:
                raise ConfigError("give either K or hfov_deg, not both", "camera.hfov_deg")
            # the field of view K gives across the image's width (at the principal point)
            hfov = math.degrees(math.atan2(k[0, 2] + 0.5, k[0, 0])
                                + math.atan2(self.width - 0.5 - k[0, 2], k[0, 0]))
            if not 0.0 < hfov < 180.0:
                raise ConfigError(f"must be in (0, 180) degrees for a pinhole camera, got "
                                  f"{hfov!r} from K", "camera.hfov_deg")
        else:
            hfov = spec.hfov_deg if self.hfov_deg is None else self.hfov_deg
        object.__setattr__(self, "hfov_deg", float(hfov))
        if self.sampling not in ("adaptive", "full"):
            raise ConfigError(f"must be 'adaptive' or 'full', got {self.sampling!r}",
                              "camera.sampling")
        mount = spec.mount_position_frd if self.mount_position_frd is None else (
            self.mount_position_frd)
        if len(tuple(mount)) != 3:
            raise ConfigError(f"must be 3 numbers (m, FRD), got {mount!r}", "camera.mount.position")
        object.__setattr__(self, "mount_position_frd", tuple(float(v) for v in mount))
        object.__setattr__(self, "tilt_deg",
                           float(spec.tilt_deg if self.tilt_deg is None else self.tilt_deg))
        if not isinstance(self.water, WaterOptics):
            raise ConfigError(f"expected WaterOptics, got {type(self.water).__name__}",
                              "camera.water")
        if self.exposure != "auto":
            _finite(self.exposure, "camera.exposure", 0.0, math.inf, True)

    @property
    def spec(self) -> CameraSpec:
        return PRESETS[self.preset]

    @property
    def lamps(self) -> tuple[Lamp, ...]:
        """The lamps that shine (none when ``lamps_on`` is false), intensities scaled."""
        if not self.lamps_on or self.lamp_power == 0.0:
            return ()
        return tuple(replace(lamp, intensity=lamp.intensity * self.lamp_power)
                     for lamp in self.spec.lamps)

    @property
    def intrinsics(self) -> NDArray[np.float64]:
        """3x3 K (pixels): given, or from the horizontal FOV with square pixels and the
        principal point at the image centre ((W − 1)/2, (H − 1)/2; OpenCV/ROS pixel
        centres at integer coordinates)."""
        if self.K is not None:
            return np.array(self.K)
        w, h = int(self.width), int(self.height)  # type: ignore[arg-type]
        f = 0.5 * w / math.tan(math.radians(float(self.hfov_deg)) / 2.0)  # type: ignore[arg-type]
        return np.array([[f, 0.0, 0.5 * (w - 1)], [0.0, f, 0.5 * (h - 1)], [0.0, 0.0, 1.0]])
