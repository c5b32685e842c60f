"""docs/settings.md, written from the parts' own declarations (:mod:`uhrisim.core.settings`).

``python -m uhrisim.scenario.settings_doc > docs/settings.md`` rewrites the page;
``tests/unit/test_docs_settings.py`` fails when the page and the declarations differ.
"""

from __future__ import annotations

import sys

from uhrisim.autonomy.domain import MAX_AXIS_POINTS, MAX_DOMAIN_POINTS
from uhrisim.autonomy.params import MAX_PRIORITY
from uhrisim.control.videoray_p import PGains
from uhrisim.core.settings import settings_rows
from uhrisim.dynamics.videoray import VideoRayParams
from uhrisim.scenario.schema import (
    HORIZON_M,
    MAX_OBJECTS,
    ControllerConfig,
    SonarSensor,
    VideoRayModelConfig,
)
from uhrisim.sensors.camera import CameraConfig
from uhrisim.sensors.camera.config import MAX_PIXELS
from uhrisim.sensors.sonar import SonarConfig
from uhrisim.teamwork.gripper import GripperSpec
from uhrisim.world.bubbles import MAX_CLOUDS, BubbleParams

#: (title, the part, its scenario section and where it lives, in the scenario and in code)
PARTS = (
    ("Imaging sonar", SonarConfig, SonarSensor.model_fields,
     "`agents[].sensors[]` with `type: sonar`", "`uhrisim.sensors.sonar.SonarConfig`"),
    ("Camera", CameraConfig, None,
     "`agents[].sensors[]` with `type: camera`", "`uhrisim.sensors.camera.CameraConfig`"),
    ("VideoRay model", VideoRayParams, VideoRayModelConfig.model_fields,
     "`agents[].videoray`", "`uhrisim.dynamics.videoray.VideoRayParams`"),
    ("VideoRay controller gains", PGains, ControllerConfig.model_fields,
     "`agents[].controller` (after its `preset`)", "`uhrisim.control.videoray_p.PGains`"),
    ("VideoRay gripper", GripperSpec, None, "`agents[].gripper`",
     "`uhrisim.teamwork.gripper.GripperSpec`"),
    ("Diver's bubbles", BubbleParams, None,
     "`agents[].bubbles`, named without the unit suffix (`period`, `radius`, `current`, "
     "`max_age`; `cluster_radius_m` and `regulator_frd` are the Python API's only)",
     "`uhrisim.world.bubbles.BubbleParams`"),
)

HEADER = """# Settings: every numeric setting of the simulator's parts, with its unit and range

Written by `python -m uhrisim.scenario.settings_doc` from the parts' own declarations
(`uhrisim/core/settings.py`: each setting declared once, with its unit, default, physical
range and meaning); a test fails when this page and the code differ. A scenario file
uses the same names and defaults and refuses a value outside the range at load, naming the
file, line and field; the Python API refuses it when the part is made. A setting marked
with a cost makes the part's work grow with it (linearly or with its square).
"""


def budgets() -> str:
    """The cost bounds that span settings: what a scene may ask for at most."""
    return f"""
## Cost bounds

Besides each setting's range, a scene's cost is bounded, so that `uhrisim validate`
finishes in bounded time and memory and a scene that validates runs:

| what | at most | where |
| --- | --- | --- |
| objects in `world.objects` | {MAX_OBJECTS} | `uhrisim.scenario.schema.MAX_OBJECTS` |
| a camera's pixels (`width` x `height`) | {MAX_PIXELS:_} | \
`uhrisim.sensors.camera.config.MAX_PIXELS` |
| a diver's bubble clouds alive at once (breaths alive x `clusters`) | {MAX_CLOUDS} | \
`uhrisim.world.bubbles.MAX_CLOUDS` |
| points on one axis of a helm's decision domain | {MAX_AXIS_POINTS:_} | \
`uhrisim.autonomy.domain.MAX_AXIS_POINTS` |
| points over a helm's required (non-optional) decision axes together | {MAX_DOMAIN_POINTS:_} | \
`uhrisim.autonomy.domain.MAX_DOMAIN_POINTS` |
| a behavior's priority weight (`pwt`) | {MAX_PRIORITY:g} | \
`uhrisim.autonomy.params.MAX_PRIORITY` |

The scenario's own numbers have physical ranges too (`uhrisim.scenario.schema`): sizes,
extents and ranges up to 10 km, positions within {HORIZON_M:g} m of the origin
horizontally and from 100 m above the surface to 11 000 m deep, times up to 10^7 s,
rates up to 1000 Hz, speeds up to 10 m/s.
""".replace("\\\n", "")


def render() -> str:
    """The page's text."""
    out = [HEADER]
    for title, part, section, scenario, code in PARTS:
        out.append(f"\n## {title}\n\n{code}, in a scenario {scenario}.\n")
        out.append("| setting | unit | default | range | meaning |")
        out.append("| --- | --- | --- | --- | --- |")
        for name, unit, default, bounds, meaning in settings_rows(part):
            if section is None or name in section:
                out.append(f"| `{name}` | {unit} | {default} | {bounds} | {meaning} |")
    return "\n".join(out) + "\n" + budgets()


if __name__ == "__main__":
    sys.stdout.write(render())
