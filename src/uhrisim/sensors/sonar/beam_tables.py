"""Measured beam-centre angles of lens-formed imaging sonars (degrees, > 0 starboard,
ascending from port to starboard).

Source: Sound Metrics, ``aris-file-sdk`` (github.com/SoundMetrics/aris-file-sdk),
``beam-width-metrics/BeamWidths_ARIS3000_128.h`` and ``BeamWidths_ARIS3000_64.h``: "average
of 4 ARIS 3000 beampatterns for beam centers, smoothed as average of 5 beam spacings"
(Copyright 2010-2015 Sound Metrics Corp.; only the centre column is kept). The SDK's page
"Understanding ARIS data" explains why they are not evenly spaced: "the acoustic
lens introduces a non-linear beam spacing". ARIS files number beam 0 as the right-most
(starboard) beam; the tables here run from port to starboard, the polar image's column
order (``docs/conventions.md``), so column j is ARIS beam ``n_beams − 1 − j``. The tables
are symmetric about the axis (tests/unit/test_sonar_presets.py checks it).
"""

from __future__ import annotations

#: ARIS Explorer 3000 at 3.0 MHz (ping mode 9, 128 beams): spacing 0.217° at the edges,
#: 0.232° in between, 0.246° around the axis.
ARIS3000_128 = (
    -14.705, -14.488, -14.271, -14.053, -13.836, -13.619, -13.402, -13.185,
    -12.967, -12.736, -12.504, -12.272, -12.041, -11.809, -11.577, -11.345,
    -11.114, -10.882, -10.650, -10.419, -10.187, -9.955, -9.724, -9.492,
    -9.260, -9.029, -8.797, -8.565, -8.333, -8.102, -7.870, -7.638,
    -7.407, -7.175, -6.943, -6.712, -6.480, -6.248, -6.016, -5.785,
    -5.553, -5.321, -5.090, -4.858, -4.626, -4.395, -4.163, -3.931,
    -3.700, -3.468, -3.236, -3.004, -2.773, -2.541, -2.309, -2.078,
    -1.846, -1.600, -1.354, -1.107, -0.861, -0.615, -0.369, -0.123,
    0.123, 0.369, 0.615, 0.861, 1.107, 1.354, 1.600, 1.846,
    2.078, 2.309, 2.541, 2.773, 3.004, 3.236, 3.468, 3.700,
    3.931, 4.163, 4.395, 4.626, 4.858, 5.090, 5.321, 5.553,
    5.785, 6.016, 6.248, 6.480, 6.712, 6.943, 7.175, 7.407,
    7.638, 7.870, 8.102, 8.333, 8.565, 8.797, 9.029, 9.260,

#: ARIS Explorer 3000 at 1.8 MHz (ping mode 6, 64 beams): spacing 0.438° at the edges,
#: 0.467° in between, 0.497° around the axis.
    9.492, 9.724, 9.955, 10.187, 10.419, 10.650, 10.882, 11.114,
    11.345, 11.577, 11.809, 12.041, 12.272, 12.504, 12.736, 12.967,
    13.185, 13.402, 13.619, 13.836, 14.053, 14.271, 14.488, 14.705,
)
ARIS3000_64 = (
    -14.703, -14.265, -13.827, -13.389, -12.951, -12.484, -12.016, -11.549,
    -11.082, -10.615, -10.148, -9.680, -9.213, -8.746, -8.279, -7.812,
    -7.344, -6.877, -6.410, -5.943, -5.476, -5.008, -4.541, -4.074,
    -3.607, -3.140, -2.672, -2.205, -1.738, -1.242, -0.745, -0.249,
    0.249, 0.745, 1.242, 1.738, 2.205, 2.672, 3.140, 3.607,
    4.074, 4.541, 5.008, 5.476, 5.943, 6.410, 6.877, 7.344,
    7.812, 8.279, 8.746, 9.213, 9.680, 10.148, 10.615, 11.082,
    11.549, 12.016, 12.484, 12.951, 13.389, 13.827, 14.265, 14.703,
)
