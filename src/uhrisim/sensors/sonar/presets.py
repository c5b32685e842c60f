"""Forward-looking imaging sonar specifications (presets).

The BlueView P900-45 row is Table I of DeMarco, West & Howard (OCEANS 2013); the P900-90
and P900-130 rows are the same family (900 kHz, 1°×20° beams, ~2.5 cm range resolution,
100 m maximum range) with 512 and 768 beams over 90° and 130°
(``docs/reference/sonar.md``). Angles are degrees (suffix ``_deg``), ranges metres.
"""

from __future__ import annotations

from dataclasses import dataclass

from uhrisim.core.errors import ConfigError


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

    @property
    def beam_spacing_deg(self) -> float:
        """Angular spacing of the beam centres (beams span the FOV edge to edge), degrees."""
        return self.fov_h_deg / (self.n_beams - 1)


_P900_SOURCE = "DeMarco, West & Howard 2013, Table I; docs/reference/sonar.md (P900 family)"

P900_45 = SonarSpec(
    name="P900-45",
    frequency_hz=900e3,
    fov_h_deg=45.0,
    n_beams=256,
    beam_width_h_deg=1.0,
    beam_width_v_deg=20.0,
    max_range_m=100.0,
    range_resolution_m=0.0254,
    max_rate_hz=15.0,
    source=_P900_SOURCE,
)
P900_90 = SonarSpec(
    name="P900-90",
    frequency_hz=900e3,
    fov_h_deg=90.0,
    n_beams=512,
    beam_width_h_deg=1.0,
    beam_width_v_deg=20.0,
    max_range_m=100.0,
    range_resolution_m=0.0254,
    max_rate_hz=15.0,
    source=_P900_SOURCE,
)
P900_130 = SonarSpec(
    name="P900-130",
    frequency_hz=900e3,
    fov_h_deg=130.0,
    n_beams=768,
    beam_width_h_deg=1.0,
    beam_width_v_deg=20.0,
    max_range_m=100.0,
    range_resolution_m=0.0254,
    max_rate_hz=15.0,
    source=_P900_SOURCE,
)

PRESETS: dict[str, SonarSpec] = {s.name: s for s in (P900_45, P900_90, P900_130)}


def get_preset(name: str) -> SonarSpec:
    """The preset called ``name``; ConfigError (with the known names) if there is none."""
    try:
        return PRESETS[name]
    except KeyError:
        known = ", ".join(sorted(PRESETS))
        raise ConfigError(f"unknown sonar preset {name!r} (known: {known})", "preset") from None
