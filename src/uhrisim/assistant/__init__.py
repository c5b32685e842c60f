"""The diver's assistant: a task layer above the helm (docs/hri.md).

Behavior trees (``py_trees``, the ``hri`` extra) decide what the ROV does from the
diver's signals and track; they drive the IvP-style helm only through its variables
(``assistant/data/assistant.bhv``) and the gripper through commands::

    from uhrisim.assistant import Assistant, AssistantInputs, RovNav, DiverTrack
    assistant = Assistant()                       # AssistantConfig() defaults
    out = assistant.step(AssistantInputs(t, RovNav(pos_ned, heading_deg, speed),
                                         DiverTrack(diver_ned, diver_heading_deg),
                                         signals=recognized))
    out.posts            # [(MOOS variable, value), ...] for the helm
    out.gripper_command  # "open" / "close" / None
"""

from __future__ import annotations

from uhrisim.core.errors import MissingExtraError

try:
    import py_trees  # noqa: F401
except ImportError as error:  # pragma: no cover - depends on the installed extras
    raise MissingExtraError('uhrisim.assistant needs py_trees: pip install "uhrisim[hri]"') \
        from error

from uhrisim.assistant.assistant import HELM_DOMAIN, Assistant, assistant_bhv
from uhrisim.assistant.config import AssistantConfig
from uhrisim.assistant.io import (
    HELM_VARS,
    AssistantInputs,
    AssistantOutputs,
    DiverTrack,
    GripperStatus,
    RovNav,
)

__all__ = [
    "HELM_DOMAIN",
    "HELM_VARS",
    "Assistant",
    "AssistantConfig",
    "AssistantInputs",
    "AssistantOutputs",
    "DiverTrack",
    "GripperStatus",
    "RovNav",
    "assistant_bhv",
]
