"""Configuration of one imaging sonar instance (what a scenario sets).

Frames and units follow ``docs/conventions.md``: the mount position is in the vehicle's
body FRD frame (metres), tilt > 0 points the sonar down, yaw > 0 turns it to starboard
(degrees, suffixed). Levels are dB re 1 µPa (source level at 1 m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

from uhrisim.core.errors import ConfigError, warn_user
from uhrisim.core.settings import check_settings, setting
from uhrisim.sensors.sonar.acoustics import absorption_db_per_m, sound_speed_fg
from uhrisim.sensors.sonar.presets import SonarSpec, get_preset

#: Colour maps accepted for ``SonarConfig.colormap``: OpenCV's built-ins, by the name of
#: their ``cv2.COLORMAP_<NAME>`` (OpenCV is imported where a fan is coloured).
COLORMAPS = ("autumn", "bone", "jet", "ocean", "hot", "viridis", "inferno", "magma",
             "twilight", "cividis")

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
    range_min_m: float = setting(0.0, "m", ge=0.0, doc="near end of the range window")
    range_max_m: float = setting(30.0, "m", gt=0.0, doc="far end of the range window "
                                 "(at most the preset's maximum range)", cost="linear")
    range_resolution_m: float | None = setting(None, "m", gt=0.0,
                                               doc="range-bin size (None: the preset's)")
    rays_per_beam: int = setting(64, "1", ge=2, le=4096, integer=True,
                                 doc="rays cast in elevation per beam", cost="linear")
    rays_per_beam_azimuth: int = setting(1, "1", ge=1, le=64, integer=True,
                                         doc="sub-rays per beam in azimuth", cost="linear")
    elevation_span: float = setting(1.0, "1", gt=0.0, le=3.0,
                                    doc="rays cover ± this × the -3 dB vertical half-aperture")
    mount_position_frd: tuple[float, float, float] = setting(
        (0.2, 0.0, 0.0), "m", doc="sonar origin in the vehicle body frame FRD")
    tilt_deg: float = setting(10.0, "deg", gt=-90.0, lt=90.0, doc="tilt of the axis, > 0 down")
    yaw_deg: float = setting(0.0, "deg", ge=-360.0, le=360.0,
                             doc="yaw of the axis from the bow, > 0 starboard")
    rate_hz: float = setting(15.0, "Hz", gt=0.0, doc="requested ping rate (capped by the "
                             "preset and by the two-way travel time)", cost="linear")
    mode: Literal["physical", "2013"] = "physical"
    source_level_db: float = setting(210.0, "dB re 1 µPa at 1 m", ge=150.0, le=260.0,
                                     doc="source level")
    noise_floor_db: float = setting(65.0, "dB re 1 µPa²", ge=-200.0, le=260.0,
                                    doc="receiver self-noise per cell (below the source level)")
    ambient_noise: bool = True
    sea_state: float = setting(1.0, "1", ge=0.0, le=9.0, doc="sea state of the wind noise")
    receiver_bandwidth_hz: float | None = setting(
        None, "Hz", gt=0.0, doc="receiver bandwidth (None: c / (2 · pulse resolution))")
    post_tvg_noise_db: float | None = setting(
        146.0, "dB", ge=-200.0, le=400.0, doc="noise after the TVG amplifier (None: off)")
    volume_scattering_db: float | None = setting(
        -70.0, "dB re 1/m", ge=-200.0, le=0.0, doc="volume backscattering strength (None: off)")
    surface_scattering_db: float | None = setting(
        -40.0, "dB", ge=-200.0, lt=0.0, doc="Lambert coefficient of the surface (None: off)")
    far_sidelobe_db: float | None = setting(
        -30.0, "dB", ge=-200.0, lt=0.0, doc="integrated far side-lobe level (None: off)")
    tvg: bool = True
    tvg_spreading_db_per_decade: float = setting(40.0, "dB/decade", ge=0.0, le=100.0,
                                                 doc="spreading term of the TVG")
    tvg_min_range_m: float = setting(1.0, "m", ge=0.0, doc="TVG held constant inside this")
    gain_db: float = setting(0.0, "dB", ge=0.0, le=200.0, doc="user gain")
    display_top_db: float = setting(180.0, "dB", ge=-200.0, le=400.0,
                                    doc="level mapped to full scale")
    dynamic_range_db: float = setting(60.0, "dB", gt=0.0, le=400.0,
                                      doc="display window below the top")
    display_gamma: float = setting(2.5, "1", ge=0.1, le=10.0, doc="contrast of the 8-bit curve")
    speckle: bool = True
    speckle_model: Literal["product", "coherent"] = "product"
    labels: bool = False
    sidelobe_db: float | None = setting(None, "dB", ge=-200.0, lt=0.0,
                                        doc="first side lobe (None: the preset's)")
    n_sidelobes: int = setting(1, "1", ge=0, le=16, integer=True,
                               doc="side lobes modelled each side")
    pulse_resolution_m: float | None = setting(None, "m", gt=0.0,
                                               doc="pulse length as range (None: the preset's)")
    fan_edge_loss_db: float | None = setting(None, "dB", ge=0.0, le=30.0,
                                             doc="two-way loss at the fan edges "
                                                 "(None: the preset's)")
    beam_steering: bool | None = None  # steered beams widen as 1/cos (None: the preset's)
    tvg_max_gain_db: float | None = setting(None, "dB", gt=0.0, le=200.0,
                                            doc="the TVG's largest gain (None: the preset's)")
    display_black_level: int | None = setting(None, "1", ge=0, le=254, integer=True,
                                              doc="8-bit level of no echo inside the fan "
                                                  "(None: the preset's)")
    multipath: bool = False
    multipath_loss_db: float = setting(6.0, "dB", ge=0.0, le=200.0,
                                       doc="loss of the surface ghost's path")
    fan_size_px: int = setting(512, "px", ge=16, le=4096, integer=True,
                               doc="larger side of the fan image", cost="quadratic")
    colormap: str | None = None
    water_temperature_c: float = setting(15.0, "°C", ge=-2.0, le=40.0, doc="water temperature")
    salinity_psu: float = setting(35.0, "psu", ge=0.0, le=45.0, doc="salinity")
    water_depth_m: float = setting(5.0, "m", ge=0.0, le=11000.0,
                                   doc="depth for absorption and sound speed")
    ph: float = setting(8.0, "1", ge=6.0, le=9.5, doc="pH of the water")
    px_per_m_2013: float = setting(10.0, "px/m", gt=0.0, le=1000.0,
                                   doc="2013 image scale", cost="quadratic")
    blur_ksize_2013: int = setting(5, "px", ge=1, le=99, integer=True,
                                   doc="2013 Gaussian blur kernel (odd)")
    blur_sigma_2013: float = setting(1.5, "px", ge=0.0, le=100.0, doc="2013 Gaussian blur σ")
    layout_2013: Literal["port-edge", "literal"] = "port-edge"

    # -- validation -------------------------------------------------------------------
    def __post_init__(self) -> None:
        spec = self.sonar_spec  # raises on an unknown preset

        def bad(name: str, msg: str) -> ConfigError:
            return ConfigError(msg, where=f"SonarConfig.{name}")

        check_settings(self)  # every declared bound (uhrisim.core.settings)
        if self.noise_floor_db >= self.source_level_db:
            raise bad(
                "noise_floor_db",
                f"{self.noise_floor_db} dB is not below source_level_db "
                f"({self.source_level_db} dB): no echo could rise above the noise",
            )
        if self.beam_steering is not None and not isinstance(self.beam_steering, bool):
            raise bad("beam_steering", f"must be true or false, got {self.beam_steering!r}")
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
        r = self.range_resolution_m
        if r is not None and r > self.range_max_m - self.range_min_m:
            raise bad("range_resolution_m", "must be smaller than the range window")
        if len(self.mount_position_frd) != 3:
            raise bad("mount_position_frd",
                      f"must be 3 finite numbers (m), got {self.mount_position_frd!r}")
        for name, allowed in (("mode", ("physical", "2013")),
                              ("speckle_model", ("product", "coherent")),
                              ("layout_2013", ("port-edge", "literal"))):
            if getattr(self, name) not in allowed:
                raise bad(name, f"must be one of {', '.join(map(repr, allowed))}, "
                                f"got {getattr(self, name)!r}")
        if self.colormap is not None and self.colormap not in COLORMAPS:
            raise bad(
                "colormap",
                f"unknown colour map {self.colormap!r} (known: {', '.join(sorted(COLORMAPS))})",
            )
        if self.blur_ksize_2013 % 2 == 0:
            raise bad("blur_ksize_2013", f"must be an odd integer >= 1, got "
                                         f"{self.blur_ksize_2013!r}")

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

    @cached_property
    def sound_speed_m_s(self) -> float:
        """Sound speed (m/s) from the Francois–Garrison expression for the configured water."""
        return float(
            sound_speed_fg(self.water_temperature_c, self.salinity_psu, self.water_depth_m)
        )

    @cached_property
    def alpha_db_per_m(self) -> float:
        """Absorption α (dB/m) at the sonar frequency (Francois & Garrison 1982; worked
        out once per configuration, every ping reads it)."""
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
        floor ``height_m`` below the sonar (docs/reference/sonar.md's ray budget).

        Near grazing, a ray at slant range R meets the floor at R ≈ h/sin φ, so
        dR/dφ ≈ R²/h; adjacent rays are δφ apart, and every bin is hit while R²·δφ/h < Δr.
        """
        span = math.radians(self.sonar_spec.beam_width_v_deg) * self.elevation_span
        dphi = span / self.rays_per_beam
        return math.sqrt(self.bin_m * height_m / dphi)
