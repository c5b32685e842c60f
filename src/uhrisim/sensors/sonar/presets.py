"""Forward-looking imaging sonar specifications (presets), from the makers' publications.

Every value and its source is in the preset table of ``docs/sonar.md``: the BlueView
P900-45 row is Table I of DeMarco, West & Howard (OCEANS 2013), the P900-90/-130 the same
family; the ARIS Explorer 3000 rows come from Sound Metrics' own SDKs (beam-centre tables,
frequencies, window, pulse and frame-rate limits); the Oculus, Gemini and M900-130 rows
from the makers' manuals and datasheets as cited there. Values a maker does not publish
(side-lobe level, element directivity, TVG range, display black level) are assumed and
said to be. Angles are degrees (suffix ``_deg``), ranges metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError
from uhrisim.sensors.sonar.beam_tables import ARIS3000_64, ARIS3000_128


@dataclass(frozen=True)
class SonarSpec:
    """Hardware description of a multibeam forward-looking imaging sonar.

    Attributes:
        name: preset name, e.g. ``"P900-45"``.
        frequency_hz: operating (centre) frequency in Hz.
        fov_h_deg: horizontal field of view (full angle), degrees.
        n_beams: number of formed beams across the horizontal field of view.
        beam_width_h_deg: one-way -3 dB horizontal beam width, degrees.
        beam_width_v_deg: one-way -3 dB vertical beam width, degrees (elevation aperture).
        max_range_m: maximum range the hardware supports, metres.
        range_resolution_m: native range resolution, metres.
        max_rate_hz: maximum ping rate of the hardware, Hz (physics may cap it further).
        useful_range_m: (min, max) range the vendor calls useful, metres (informational).
        source: where the numbers come from.
        sidelobe_db: first horizontal side lobe of a formed beam re its main lobe, dB.
            Not published for the P900 family: −25 dB is that of a moderately shaded
            receive array (uniform: −13.3 dB; Hamming/Taylor shading: −25…−40 dB).
        fan_edge_loss_db: two-way element directivity at the fan edge re the axis, dB
            (the fan darkens towards its edges). Not published: 3 dB is assumed.
        beam_angles_deg: the native beam-centre angles, ascending from port to starboard
            (> 0 starboard), when they are not evenly spaced (ARIS: its lens, the maker's
            measured table); None: ``n_beams`` evenly over the field of view. The first and
            last must sit at ∓``fov_h_deg``/2 (the field of view spans the beam centres).
        steered: the beams are formed electronically from a line array (True: a beam
            steered to θ is 1/cos θ wider than on the axis, ``docs/sonar.md``); False: an
            acoustic lens forms them (ARIS), each beam as wide as its spacing allows.
        tvg_max_gain_db: the largest time-varied gain the receiver can apply, dB above its
            gain at 1 m (a real TVG amplifier's range is finite: beyond the range where the
            law reaches it, the image falls off); None: unlimited. Not published: assumed.
        display_black_level: the 8-bit level the maker's viewer gives the bottom of the
            display window inside the fan (0…254; real frames seldom go near black).
            Not published: assumed.
    """

    name: str
    frequency_hz: float
    fov_h_deg: float
    n_beams: int
    beam_width_h_deg: float
    beam_width_v_deg: float
    max_range_m: float
    range_resolution_m: float
    max_rate_hz: float
    useful_range_m: tuple[float, float] = (2.0, 60.0)
    source: str = ""
    sidelobe_db: float = -25.0
    fan_edge_loss_db: float = 3.0
    beam_angles_deg: tuple[float, ...] | None = None
    steered: bool = True
    tvg_max_gain_db: float | None = None
    display_black_level: int = 0

    def __post_init__(self) -> None:
        where = f"SonarSpec({self.name!r})"
        positive = (
            "frequency_hz",
            "fov_h_deg",
            "beam_width_h_deg",
            "beam_width_v_deg",
            "max_range_m",
            "range_resolution_m",
            "max_rate_hz",
        )
        for field in positive:
            value = getattr(self, field)
            if not value > 0.0:
                raise ConfigError(f"must be > 0, got {value!r}", where=f"{where}.{field}")
        if int(self.n_beams) != self.n_beams or self.n_beams < 2:
            raise ConfigError(
                f"must be an integer >= 2, got {self.n_beams!r}", where=f"{where}.n_beams"
            )
        if not self.sidelobe_db < 0.0:
            raise ConfigError(
                f"must be < 0 dB, got {self.sidelobe_db!r}", where=f"{where}.sidelobe_db"
            )
        if not 0.0 <= self.fan_edge_loss_db <= 30.0:
            raise ConfigError(
                f"must be in [0, 30] dB, got {self.fan_edge_loss_db!r}",
                where=f"{where}.fan_edge_loss_db",
            )
        if self.fov_h_deg >= 180.0:
            raise ConfigError(
                f"must be < 180 degrees, got {self.fov_h_deg!r}", where=f"{where}.fov_h_deg"
            )
        if self.beam_width_v_deg >= 90.0:
            raise ConfigError(
                f"must be < 90 degrees, got {self.beam_width_v_deg!r}",
                where=f"{where}.beam_width_v_deg",
            )
        if self.tvg_max_gain_db is not None and not (
            math.isfinite(self.tvg_max_gain_db) and self.tvg_max_gain_db > 0.0
        ):
            raise ConfigError(
                f"must be a finite number of dB > 0, got {self.tvg_max_gain_db!r}",
                where=f"{where}.tvg_max_gain_db",
            )
        level = self.display_black_level
        if isinstance(level, bool) or not isinstance(level, int) or not 0 <= level <= 254:
            raise ConfigError(
                f"must be an integer in [0, 254], got {level!r}",
                where=f"{where}.display_black_level",
            )
        self._check_beam_angles(where)

    def _check_beam_angles(self, where: str) -> None:
        """The native beam table: n_beams ascending angles spanning ∓fov/2."""
        angles = self.beam_angles_deg
        if angles is None:
            return
        a = np.asarray(angles, dtype=float)
        half = 0.5 * self.fov_h_deg
        if a.shape != (self.n_beams,) or not np.all(np.isfinite(a)):
            raise ConfigError(
                f"must be {self.n_beams} finite angles (one per beam), got {len(angles)}",
                where=f"{where}.beam_angles_deg",
            )
        if not np.all(np.diff(a) > 0.0):
            raise ConfigError(
                "must ascend strictly from port to starboard", where=f"{where}.beam_angles_deg"
            )
        if abs(a[0] + half) > 1e-6 or abs(a[-1] - half) > 1e-6:
            raise ConfigError(
                f"must start at -{half:g} and end at +{half:g} degrees (the field of view "
                f"spans the beam centres), got {a[0]:g} ... {a[-1]:g}",
                where=f"{where}.beam_angles_deg",
            )

    @property
    def beam_spacing_deg(self) -> float:
        """Mean angular spacing of the beam centres (beams span the FOV edge to edge),
        degrees; the spacing itself where the beams are evenly spaced."""
        return self.fov_h_deg / (self.n_beams - 1)

    @property
    def beam_angles_rad(self) -> NDArray[np.float64]:
        """The beam-centre angles (n_beams,), radians, ascending, > 0 starboard."""
        if self.beam_angles_deg is not None:
            return np.radians(np.asarray(self.beam_angles_deg, dtype=float))
        half = math.radians(self.fov_h_deg) / 2.0
        return np.linspace(-half, half, self.n_beams)


#: Where the numbers come from; ``docs/sonar.md`` cites each value.
_P900_SOURCE = "DeMarco, West & Howard 2013, Table I (P900-45); the same family (P900-90/-130)"
_ARIS_SOURCE = (
    "Sound Metrics aris-file-sdk (beam-width-metrics) and aris-integration-sdk "
    "(SystemConfiguration_Definitions.cs); vertical aperture: Ocean Networks Canada"
)
_OCULUS_SOURCE = (
    "Blueprint Subsea Oculus M-Series user manual and datasheet; Sui et al. 2024 (MFS2oT)"
)
_GEMINI_SOURCE = "Tritech Gemini 720is product manual 0703-SOM-00002; Gemini 720ik datasheet"
_M900_SOURCE = "Teledyne BlueView M900-130 datasheet as quoted by Sui et al. 2024 (MFS2oT)"

#: The assumed values of what makers do not publish (docs/sonar.md, "assumed"): the TVG
#: amplifier's range; the 8-bit level of the bottom of the display window (real frames
#: have no black pixel inside the fan); the floor's net darkening at the fan edge (real
#: frames are darker there; the P900 family's 3 dB was matched to them).
_TVG_RANGE_DB = 80.0
_BLACK_LEVEL = 4
_NET_EDGE_DARKENING_DB = 3.0


def _edge_loss_db(fov_deg: float) -> float:
    """The element directivity at the fan edge (two-way, dB) of a steered array whose
    diffuse floor ends :data:`_NET_EDGE_DARKENING_DB` darker at the edge: the edge beam
    is 1/cos(fov/2) wider and gathers as much more of the floor (docs/sonar.md)."""
    return _NET_EDGE_DARKENING_DB - 10.0 * math.log10(math.cos(math.radians(fov_deg / 2.0)))


def _preset(name: str, frequency_hz: float, fov_h_deg: float, n_beams: int,
            beam_width_h_deg: float, beam_width_v_deg: float, max_range_m: float,
            range_resolution_m: float, max_rate_hz: float, source: str,
            **rest: object) -> SonarSpec:  # fmt: skip
    """A maker's sonar with the assumed values above: the TVG range, the black level and,
    for a steered array, the element directivity that gives the net edge darkening."""
    steered = bool(rest.get("steered", True))
    assumed = {
        "tvg_max_gain_db": _TVG_RANGE_DB,
        "display_black_level": _BLACK_LEVEL,
        "fan_edge_loss_db": _edge_loss_db(fov_h_deg) if steered else _NET_EDGE_DARKENING_DB,
    }
    return SonarSpec(name, frequency_hz, fov_h_deg, n_beams, beam_width_h_deg,
                     beam_width_v_deg, max_range_m, range_resolution_m, max_rate_hz,
                     source=source, **{**assumed, **rest})  # fmt: skip


#: BlueView P900 family and M900-130 (900 kHz, 1° × 20° beams).
P900_45 = _preset("P900-45", 900e3, 45.0, 256, 1.0, 20.0, 100.0, 0.0254, 15.0, _P900_SOURCE)
P900_90 = _preset("P900-90", 900e3, 90.0, 512, 1.0, 20.0, 100.0, 0.0254, 15.0, _P900_SOURCE)
P900_130 = _preset("P900-130", 900e3, 130.0, 768, 1.0, 20.0, 100.0, 0.0254, 15.0, _P900_SOURCE)
M900_130 = _preset("M900-130", 900e3, 130.0, 768, 1.0, 20.0, 100.0, 0.014, 25.0, _M900_SOURCE,
                   useful_range_m=(2.0, 100.0))  # fmt: skip
#: ARIS Explorer 3000: the range resolution is the pulse length c·τ/2 of the maker's
#: "medium" pulse (16 µs at 1.8 MHz, 10 µs at 3.0 MHz; c = 1500 m/s), the beam width the
#: mean of the maker's per-beam widths (its table's left-to-right extent of each beam);
#: the field of view spans the table's outer beam centres.
ARIS3000_1800 = _preset("ARIS3000-1.8MHz", 1.8e6, 2.0 * 14.703, 64, 0.466, 14.0, 20.0, 0.012,
                        15.0, _ARIS_SOURCE, useful_range_m=(8.0, 20.0),
                        beam_angles_deg=ARIS3000_64, steered=False)  # fmt: skip
ARIS3000_3000 = _preset("ARIS3000-3MHz", 3.0e6, 2.0 * 14.705, 128, 0.232, 14.0, 20.0, 0.0075,
                        15.0, _ARIS_SOURCE, useful_range_m=(1.0, 8.0),
                        beam_angles_deg=ARIS3000_128, steered=False)  # fmt: skip
#: Blueprint Subsea Oculus M750d and M1200d, each at its two frequencies.
M750D_750 = _preset("M750d-750kHz", 750e3, 130.0, 512, 1.0, 20.0, 120.0, 0.004, 40.0,
                    _OCULUS_SOURCE, useful_range_m=(0.1, 120.0))  # fmt: skip
M750D_1200 = _preset("M750d-1.2MHz", 1.2e6, 70.0, 512, 0.6, 12.0, 40.0, 0.0025, 40.0,
                     _OCULUS_SOURCE, useful_range_m=(0.1, 40.0))  # fmt: skip
M1200D_1200 = _preset("M1200d-1.2MHz", 1.2e6, 130.0, 512, 0.6, 20.0, 30.0, 0.0025, 40.0,
                      _OCULUS_SOURCE, useful_range_m=(0.1, 30.0))  # fmt: skip
M1200D_2100 = _preset("M1200d-2.1MHz", 2.1e6, 60.0, 512, 0.4, 12.0, 10.0, 0.0025, 40.0,
                      _OCULUS_SOURCE, useful_range_m=(0.1, 10.0))  # fmt: skip
#: Tritech Gemini 720ik.
GEMINI_720IK = _preset("Gemini-720ik", 720e3, 130.0, 512, 1.0, 20.0, 120.0, 0.008, 30.0,
                       _GEMINI_SOURCE, useful_range_m=(0.2, 120.0))  # fmt: skip

PRESETS: dict[str, SonarSpec] = {
    s.name: s
    for s in (
        P900_45, P900_90, P900_130, M900_130, ARIS3000_1800, ARIS3000_3000, M750D_750,
        M750D_1200, M1200D_1200, M1200D_2100, GEMINI_720IK,
    )
}  # fmt: skip


def get_preset(name: str) -> SonarSpec:
    """The preset called ``name``; ConfigError (with the known names) if there is none."""
    try:
        return PRESETS[name]
    except KeyError:
        known = ", ".join(sorted(PRESETS))
        raise ConfigError(f"unknown sonar preset {name!r} (known: {known})", "preset") from None
