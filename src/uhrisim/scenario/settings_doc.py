"""docs/settings.md, written from the parts' own declarations (:mod:`uhrisim.core.settings`).

``python -m uhrisim.scenario.settings_doc > docs/settings.md`` rewrites the page;
``tests/unit/test_docs_settings.py`` fails when the page and the declarations differ.
"""

from __future__ import annotations

import sys

from uhrisim.control.videoray_p import PGains
from uhrisim.core.settings import settings_rows
from uhrisim.dynamics.videoray import VideoRayParams
from uhrisim.scenario.schema import ControllerConfig, SonarSensor, VideoRayModelConfig
from uhrisim.sensors.camera import CameraConfig
from uhrisim.sensors.sonar import SonarConfig
from uhrisim.teamwork.gripper import GripperSpec

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
)

HEADER = """# Settings: every numeric setting of the simulator's parts, with its unit and range

Written by `python -m uhrisim.scenario.settings_doc` from the parts' own declarations
(`uhrisim/core/settings.py`: each setting declared once, with its unit, default, physical
range and meaning); a test fails when this page and the code differ. A scenario file
uses the same names and defaults and refuses a value outside the range at load, naming the
file, line and field; the Python API refuses it when the part is made. A setting marked
with a cost makes the part's work grow with it (linearly or with its square).
"""


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
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.stdout.write(render())
