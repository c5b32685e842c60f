"""Configuration of one imaging sonar instance (what a scenario sets).

Frames and units follow ``docs/conventions.md``: the mount position is in the vehicle's
body FRD frame (metres), tilt > 0 points the sonar down, yaw > 0 turns it to starboard
(degrees, suffixed). Levels are dB re 1 µPa (source level at 1 m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import cv2

from uhrisim.core.errors import ConfigError, warn_user
from uhrisim.sensors.sonar.acoustics import absorption_db_per_m, sound_speed_fg
from uhrisim.sensors.sonar.presets import SonarSpec, get_preset

#: Colour maps accepted for ``SonarConfig.colormap`` (OpenCV's built-ins).
COLORMAPS: dict[str, int] = {
    "autumn": cv2.COLORMAP_AUTUMN,
    "bone": cv2.COLORMAP_BONE,
    "jet": cv2.COLORMAP_JET,
    "ocean": cv2.COLORMAP_OCEAN,
    "hot": cv2.COLORMAP_HOT,
    "viridis": cv2.COLORMAP_VIRIDIS,
    "inferno": cv2.COLORMAP_INFERNO,
    "magma": cv2.COLORMAP_MAGMA,
    "twilight": cv2.COLORMAP_TWILIGHT,
    "cividis": cv2.COLORMAP_CIVIDIS,
}

#: Settings that switch off every diffuse term of the image (noise, reverberation, far side
#: lobes), leaving the echoes of the geometry alone: ``SonarConfig(**ECHOES_ONLY, ...)``
#: for measuring where echoes and shadows fall (tests, figures of the geometry).
ECHOES_ONLY: dict[str, object] = {
    "noise_floor_db": -100.0,
    "ambient_noise": False,
    "post_tvg_noise_db": None,
    "volume_scattering_db": None,
    "surface_scattering_db": None,
    "far_sidelobe_db": None,
}

#: Margin on the two-way travel time when capping the ping rate: f ≤ 1/(margin·2R/c).
PING_RATE_MARGIN = 1.1


@dataclass(frozen=True)
class SonarConfig:
    """All settings of an imaging sonar; validated on construction (ConfigError naming
    the field).

    Geometry and sampling:
        preset: name of a :data:`~uhrisim.sensors.sonar.presets.PRESETS` entry.
        spec: a custom :class:`SonarSpec`; overrides ``preset`` when given.
        range_min_m, range_max_m: the range window, metres (0 ≤ min < max ≤ spec max).
        range_resolution_m: range-bin size, metres (default: the spec's resolution).
        rays_per_beam: rays cast in elevation per beam across the vertical aperture — the
            fidelity knob, independent of the beam count. Each ray is the centre of one of
            ``rays_per_beam`` equal elevation slices δφ = span/rays_per_beam; its echo is
            spread over the range footprint of its slice (R·δφ·tan β), so the sea floor
            stays continuous, but detail finer than a slice (a diver's fin, the top edge of
            a piling) is resolved only where R·δφ is below the detail's size. On a flat floor
            at height h, one slice covers less than one bin out to the range given by
            ``SonarConfig.floor_bin_coverage_range_m``.
        rays_per_beam_azimuth: sub-rays per beam in azimuth (1 = one ray on the beam axis);
            raise it to resolve objects narrower than the beam spacing.
        elevation_span: the rays cover ±``elevation_span``·(beam_width_v/2) (1 = the -3 dB
            aperture; the vertical pattern weights them).
        mount_position_frd: sonar origin in the vehicle body frame FRD, metres.
        tilt_deg: downward tilt of the sonar axis, degrees (> 0 down).
        yaw_deg: yaw of the sonar axis relative to the vehicle bow, degrees (> 0 starboard).
        rate_hz: requested ping rate; capped by the spec and by range physics, see
            :attr:`effective_rate_hz`.
        mode: ``"physical"`` (acoustic image formation) or ``"2013"`` (the paper's method).

    Image formation (``mode="physical"``; the stages of :mod:`uhrisim.sensors.sonar.polar`,
    physics and sources in ``docs/sonar.md``). Levels in dB re 1 µPa² unless stated:
        source_level_db: dB re 1 µPa at 1 m (default mid of the 200–220 dB range).
        noise_floor_db: receiver (electronic) self-noise per cell at the beam output,
            before TVG. Must be below ``source_level_db``.
        ambient_noise: add the ambient sea noise at the beam output: the Wenz-style band
            level (thermal + wind noise over the receiver bandwidth, :mod:`.acoustics`)
            less the beam's directivity index.
        sea_state: sea state for the wind-noise term (0–9; negligible at 900 kHz).
        receiver_bandwidth_hz: receiver bandwidth (default c / (2·pulse resolution)).
        post_tvg_noise_db: electronics/ADC noise after the TVG amplifier, on the display
            scale (the level of an echo that shows equally bright with ``gain_db`` 0): a
            constant grey at every range, so near-range water is never black. None: off.
        volume_scattering_db: volume backscattering strength S_v of the water, dB re 1/m
            (suspended particles, plankton, bubbles); None: off.
        surface_scattering_db: Lambert coefficient of the sea surface, dB (boundary
            reverberation seen through the vertical beam pattern); None: off.
        far_sidelobe_db: integrated far side-lobe level of a beam: each beam receives this
            fraction of the echo averaged over all beams at its range (grey shadows).
        sidelobe_db: first horizontal side lobe re the main lobe (default: the preset's).
        n_sidelobes: horizontal side lobes modelled each side of the main lobe.
        pulse_resolution_m: pulse length as range resolution (FWHM of the power envelope,
            default: the spec's range resolution).
        fan_edge_loss_db: two-way element directivity at the fan edges (default: the
            preset's); 0 dB: flat.
        beam_steering: the beams are steered electronically, so a beam at θ off the axis
            is 1/cos θ wider (default: the preset's ``steered``; ``docs/sonar.md``).
        speckle: speckle with Rayleigh amplitude whose grain is set by the beam width and
            the pulse length. Off: the mean (incoherent) intensity.
        speckle_model: ``"product"`` (default): the mean image times a unit speckle field
            made once per sonar from complex scatterer sums through the beam and pulse
            amplitude patterns; ``"coherent"``: each ping's echoes themselves as complex
            scatterer amplitudes summed through those patterns (exact at edges and point
            targets, ~0.6 ms more per P900-45 ping). Same statistics on uniform areas.
        tvg: apply time-varied gain ``tvg_spreading_db_per_decade·log10 R + 2αR``, held
            constant inside ``tvg_min_range_m`` and never above ``tvg_max_gain_db`` (the
            receiver's gain range is finite at both ends).
        tvg_max_gain_db: the largest TVG the receiver applies, dB (default: the preset's;
            None there: unlimited). Beyond the range where the law reaches it, echoes fall.
        gain_db: user gain, dB ≥ 0, added before display compression.
        display_top_db: level (after TVG and gain) mapped to full scale.
        dynamic_range_db: levels ``display_top_db − dynamic_range_db … display_top_db`` are
            the display window, x = 0…1 (``polar``, linear in dB: log compression).
        display_gamma: contrast of the 8-bit mapping:
            ``u8 = round(b + (255 − b)·x^display_gamma)``, b the black level.
        display_black_level: b, the 8-bit level of the bottom of the display window
            inside the fan (default: the preset's; 0…254).
        multipath: add the surface ghost (echo via one surface bounce; off by default).
        multipath_loss_db: loss of the ghost path at the surface, dB ≥ 0.
        labels: compute the per-pixel label images (which object gave each pixel's
            strongest return: ground truth for training detectors). Opt-in: they add about
            half to a ping's cost (``uhrisim bench sonar``); off, they are all −1.
        fan_size_px: larger side of the Cartesian fan image in pixels.
        colormap: OpenCV colour map name for ``fan_rgb`` (None: no colour image).
        water_temperature_c, salinity_psu, water_depth_m, ph: water for the
            Francois–Garrison absorption and the sound speed.
        px_per_m_2013, blur_ksize_2013, blur_sigma_2013, layout_2013: the paper's 2013-mode
            image (10 px/m, Gaussian blur, apex top-left). ``layout_2013="port-edge"``
            measures bearings from the port edge of the fan so the whole fan lies in the
            image quadrant; ``"literal"`` draws column = 10·x, row = 10·y (sonar frame),
            which leaves the port half outside the image. None of the image-formation
            settings above apply to the 2013 mode, which stays the paper's method.
    """

    preset: str = "P900-45"
    spec: SonarSpec | None = None
    range_min_m: float = 0.0
    range_max_m: float = 30.0
    range_resolution_m: float | None = None
    rays_per_beam: int = 64
    rays_per_beam_azimuth: int = 1
    elevation_span: float = 1.0
    mount_position_frd: tuple[float, float, float] = (0.2, 0.0, 0.0)
    tilt_deg: float = 10.0
    yaw_deg: float = 0.0
    rate_hz: float = 15.0
    mode: Literal["physical", "2013"] = "physical"
    source_level_db: float = 210.0
    noise_floor_db: float = 65.0
    ambient_noise: bool = True
    sea_state: float = 1.0
    receiver_bandwidth_hz: float | None = None
    post_tvg_noise_db: float | None = 146.0
    volume_scattering_db: float | None = -70.0
    surface_scattering_db: float | None = -40.0
    far_sidelobe_db: float | None = -30.0
    tvg: bool = True
    tvg_spreading_db_per_decade: float = 40.0
    tvg_min_range_m: float = 1.0
    gain_db: float = 0.0
    display_top_db: float = 180.0
    dynamic_range_db: float = 60.0
    display_gamma: float = 2.5
    speckle: bool = True
    speckle_model: Literal["product", "coherent"] = "product"
    labels: bool = False
    sidelobe_db: float | None = None
    n_sidelobes: int = 1
    pulse_resolution_m: float | None = None
    fan_edge_loss_db: float | None = None
    beam_steering: bool | None = None
    tvg_max_gain_db: float | None = None
    display_black_level: int | None = None
    multipath: bool = False
    multipath_loss_db: float = 6.0
    fan_size_px: int = 512
    colormap: str | None = None
    water_temperature_c: float = 15.0
    salinity_psu: float = 35.0
    water_depth_m: float = 5.0
    ph: float = 8.0
    px_per_m_2013: float = 10.0
    blur_ksize_2013: int = 5
    blur_sigma_2013: float = 1.5
    layout_2013: Literal["port-edge", "literal"] = "port-edge"

    # -- validation -------------------------------------------------------------------
    def __post_init__(self) -> None:
        spec = self.sonar_spec  # raises on an unknown preset

        def bad(name: str, msg: str) -> ConfigError:
            return ConfigError(msg, where=f"SonarConfig.{name}")

        def finite(name: str) -> float:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise bad(name, f"must be a finite number, got {v!r}")
            return float(v)

        for name in (
            "range_min_m", "range_max_m", "elevation_span", "tilt_deg", "yaw_deg", "rate_hz",
            "source_level_db", "noise_floor_db", "tvg_spreading_db_per_decade", "gain_db",
            "display_top_db", "dynamic_range_db", "water_temperature_c", "sea_state",
            "salinity_psu", "water_depth_m", "ph", "px_per_m_2013", "blur_sigma_2013",
            "tvg_min_range_m", "display_gamma", "multipath_loss_db",
        ):  # fmt: skip
            finite(name)
        for name in (
            "receiver_bandwidth_hz", "post_tvg_noise_db", "volume_scattering_db",
            "surface_scattering_db", "far_sidelobe_db", "sidelobe_db", "fan_edge_loss_db",
            "tvg_max_gain_db",
        ):  # fmt: skip
            if getattr(self, name) is not None:
                finite(name)
        if self.noise_floor_db >= self.source_level_db:
            raise bad(
                "noise_floor_db",
                f"{self.noise_floor_db} dB is not below source_level_db "
                f"({self.source_level_db} dB): no echo could rise above the noise",
            )
        if self.gain_db < 0.0:
            raise bad("gain_db", f"must be >= 0 dB (a receiver gain), got {self.gain_db!r}")
        if not 0.1 <= self.display_gamma <= 10.0:
            raise bad("display_gamma", f"must be in [0.1, 10], got {self.display_gamma!r}")
        if not 0.0 <= self.sea_state <= 9.0:
            raise bad("sea_state", f"must be in [0, 9], got {self.sea_state!r}")
        if self.tvg_min_range_m < 0.0:
            raise bad("tvg_min_range_m", f"must be >= 0 m, got {self.tvg_min_range_m!r}")
        if self.multipath_loss_db < 0.0:
            raise bad("multipath_loss_db", f"must be >= 0 dB, got {self.multipath_loss_db!r}")
        if self.receiver_bandwidth_hz is not None and self.receiver_bandwidth_hz <= 0.0:
            raise bad(
                "receiver_bandwidth_hz", f"must be > 0 Hz, got {self.receiver_bandwidth_hz!r}"
            )
        for name in ("sidelobe_db", "far_sidelobe_db", "surface_scattering_db"):
            v = getattr(self, name)
            if v is not None and v >= 0.0:
                raise bad(name, f"must be < 0 dB, got {v!r}")
        if self.fan_edge_loss_db is not None and not 0.0 <= self.fan_edge_loss_db <= 30.0:
            raise bad("fan_edge_loss_db", f"must be in [0, 30] dB, got {self.fan_edge_loss_db!r}")
        if self.tvg_max_gain_db is not None and self.tvg_max_gain_db <= 0.0:
            raise bad("tvg_max_gain_db", f"must be > 0 dB, got {self.tvg_max_gain_db!r}")
        level = self.display_black_level
        if level is not None and (
            isinstance(level, bool) or not isinstance(level, int) or not 0 <= level <= 254
        ):
            raise bad("display_black_level", f"must be an integer in [0, 254], got {level!r}")
        if self.beam_steering is not None and not isinstance(self.beam_steering, bool):
            raise bad("beam_steering", f"must be true or false, got {self.beam_steering!r}")
        if self.range_max_m <= 0.0:
            raise bad("range_max_m", f"must be > 0 m, got {self.range_max_m!r}")
        if self.range_min_m < 0.0:
            raise bad("range_min_m", f"must be >= 0 m, got {self.range_min_m!r}")
        if self.range_min_m >= self.range_max_m:
            raise bad(
                "range_min_m",
                f"must be < range_max_m ({self.range_max_m} m), got {self.range_min_m!r}",
            )
        if self.range_max_m > spec.max_range_m:
            raise bad(
                "range_max_m",
                f"{self.range_max_m} m is beyond the {spec.name} maximum of {spec.max_range_m} m",
            )
        if self.range_resolution_m is not None:
            finite("range_resolution_m")
            if self.range_resolution_m <= 0.0:
                raise bad("range_resolution_m", f"must be > 0 m, got {self.range_resolution_m!r}")
            if self.range_resolution_m > self.range_max_m - self.range_min_m:
                raise bad("range_resolution_m", "must be smaller than the range window")
        if self.pulse_resolution_m is not None:
            finite("pulse_resolution_m")
            if self.pulse_resolution_m <= 0.0:
                raise bad("pulse_resolution_m", f"must be > 0 m, got {self.pulse_resolution_m!r}")
        for name, lo in (
            ("rays_per_beam", 2), ("rays_per_beam_azimuth", 1), ("fan_size_px", 16),
            ("n_sidelobes", 0),
        ):  # fmt: skip
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise bad(name, f"must be an integer >= {lo}, got {v!r}")
        if not 0.0 < self.elevation_span <= 3.0:
            raise bad("elevation_span", f"must be in (0, 3], got {self.elevation_span!r}")
        mount = self.mount_position_frd
        if len(mount) != 3 or not all(
            isinstance(m, (int, float)) and math.isfinite(m) for m in mount
        ):
            raise bad("mount_position_frd", f"must be 3 finite numbers (m), got {mount!r}")
        if not -90.0 < self.tilt_deg < 90.0:
            raise bad("tilt_deg", f"must be in (-90, 90) degrees, got {self.tilt_deg!r}")
        if self.rate_hz <= 0.0:
            raise bad("rate_hz", f"must be > 0 Hz, got {self.rate_hz!r}")
        if self.speckle_model not in ("product", "coherent"):
            raise bad(
                "speckle_model", f"must be 'product' or 'coherent', got {self.speckle_model!r}"
            )
        if self.mode not in ("physical", "2013"):
            raise bad("mode", f"must be 'physical' or '2013', got {self.mode!r}")
        if self.dynamic_range_db <= 0.0:
            raise bad("dynamic_range_db", f"must be > 0 dB, got {self.dynamic_range_db!r}")
        if self.colormap is not None and self.colormap not in COLORMAPS:
            raise bad(
                "colormap",
                f"unknown colour map {self.colormap!r} (known: {', '.join(sorted(COLORMAPS))})",
            )
        if not -2.0 <= self.water_temperature_c <= 40.0:
            raise bad("water_temperature_c", "must be in [-2, 40] °C")
        if not 0.0 <= self.salinity_psu <= 45.0:
            raise bad("salinity_psu", "must be in [0, 45] psu")
        if not 0.0 <= self.water_depth_m <= 11000.0:
            raise bad("water_depth_m", "must be in [0, 11000] m")
        if not 6.0 <= self.ph <= 9.5:
            raise bad("ph", "must be in [6, 9.5]")
        if self.px_per_m_2013 <= 0.0:
            raise bad("px_per_m_2013", f"must be > 0, got {self.px_per_m_2013!r}")
        k = self.blur_ksize_2013
        if isinstance(k, bool) or not isinstance(k, int) or k < 1 or k % 2 == 0:
            raise bad("blur_ksize_2013", f"must be an odd integer >= 1, got {k!r}")
        if self.layout_2013 not in ("port-edge", "literal"):
            raise bad("layout_2013", f"must be 'port-edge' or 'literal', got {self.layout_2013!r}")

        cap = self.range_rate_cap_hz
        if self.rate_hz > min(cap, spec.max_rate_hz):
            msg = (
                f"SonarConfig.rate_hz: {self.rate_hz} Hz is more than this sonar can ping out to "
                f"{self.range_max_m} m (hardware {spec.max_rate_hz} Hz, two-way travel "
                f"{PING_RATE_MARGIN}·2R/c caps it at {cap:.2f} Hz); using "
                f"{self.effective_rate_hz:.2f} Hz"
            )
            warn_user(msg, stacklevel=3)

    # -- derived quantities ---------------------------------------------------------------
    @property
    def sonar_spec(self) -> SonarSpec:
        """The hardware spec: ``spec`` if given, else the named preset."""
        return self.spec if self.spec is not None else get_preset(self.preset)

    @property
    def bin_m(self) -> float:
        """Range-bin size in metres."""
        r = self.range_resolution_m
        return float(r) if r is not None else self.sonar_spec.range_resolution_m

    @property
    def n_bins(self) -> int:
        """Number of range bins in the window."""
        return max(1, math.ceil((self.range_max_m - self.range_min_m) / self.bin_m - 1e-9))

    @property
    def sound_speed_m_s(self) -> float:
        """Sound speed (m/s) from the Francois–Garrison expression for the configured water."""
        return float(
            sound_speed_fg(self.water_temperature_c, self.salinity_psu, self.water_depth_m)
        )

    @property
    def alpha_db_per_m(self) -> float:
        """Absorption α (dB/m) at the sonar frequency (Francois & Garrison 1982)."""
        return float(
            absorption_db_per_m(
                self.sonar_spec.frequency_hz,
                self.water_temperature_c,
                self.salinity_psu,
                self.water_depth_m,
                self.ph,
            )
        )

    @property
    def range_rate_cap_hz(self) -> float:
        """Physics cap on the ping rate: 1 / (1.1 · 2·R_max / c), Hz."""
        return self.sound_speed_m_s / (PING_RATE_MARGIN * 2.0 * self.range_max_m)

    @property
    def effective_rate_hz(self) -> float:
        """The ping rate actually used: min(requested, hardware maximum, range cap)."""
        return min(self.rate_hz, self.sonar_spec.max_rate_hz, self.range_rate_cap_hz)

    def _or_preset(self, name: str, spec_name: str) -> object:
        """The setting ``name``, or the spec's ``spec_name`` where it is None."""
        value = getattr(self, name)
        return value if value is not None else getattr(self.sonar_spec, spec_name)

    @property
    def beam_sidelobe_db(self) -> float:
        """First horizontal side lobe re the main lobe, dB (config or preset)."""
        return float(self._or_preset("sidelobe_db", "sidelobe_db"))

    @property
    def edge_loss_db(self) -> float:
        """Two-way element directivity at the fan edges, dB (config or preset)."""
        return float(self._or_preset("fan_edge_loss_db", "fan_edge_loss_db"))

    @property
    def steering(self) -> bool:
        """Whether the beams widen as 1/cos θ off the axis (config or preset)."""
        return bool(self._or_preset("beam_steering", "steered"))

    @property
    def tvg_cap_db(self) -> float:
        """The largest TVG applied, dB (config or preset; inf: unlimited)."""
        value = self._or_preset("tvg_max_gain_db", "tvg_max_gain_db")
        return float(value) if value is not None else math.inf

    @property
    def black_level(self) -> int:
        """The 8-bit level of the bottom of the display window (config or preset)."""
        return int(self._or_preset("display_black_level", "display_black_level"))

    @property
    def bandwidth_hz(self) -> float:
        """Receiver bandwidth, Hz: configured, else c / (2·pulse resolution)."""
        b = self.receiver_bandwidth_hz
        return float(b) if b is not None else self.sound_speed_m_s / (2.0 * self.pulse_m)

    @property
    def pulse_m(self) -> float:
        """Range blur FWHM in metres."""
        p = self.pulse_resolution_m
        return float(p) if p is not None else self.sonar_spec.range_resolution_m

    def floor_bin_coverage_range_m(self, height_m: float) -> float:
        """Range out to which adjacent elevation rays land less than one bin apart on a flat
        floor ``height_m`` below the sonar (the reference note's ray budget).

        Near grazing, a ray at slant range R meets the floor at R ≈ h/sin φ, so
        dR/dφ ≈ R²/h; adjacent rays are δφ apart, and every bin is hit while R²·δφ/h < Δr.
        """
        span = math.radians(self.sonar_spec.beam_width_v_deg) * self.elevation_span
        dphi = span / self.rays_per_beam
        return math.sqrt(self.bin_m * height_m / dphi)
