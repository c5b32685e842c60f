"""The scenario's ``agents[].assistant`` section: a vehicle driven by the diver's
assistant (docs/hri.md, "In the simulation loop").

Names (the diver, sensors, tools, sites) and the assistant's parameters are checked when
the simulation is built (:mod:`uhrisim.sim.assistance`), each problem one line with its
file:line.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field

from uhrisim.scenario.strict import Strict

AssistName = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_]*$")]
ChannelName = Literal["marker", "gesture", "sonar"]


class AssistantSection(Strict):
    """What the assistant reads and knows.

    ``diver``: the agent it assists (default: the only diver); ``track``: where his track
    comes from — ``truth`` (an acoustic tag: the simulation's pose of his body, head and
    hand) or ``sonar`` (the agent's sonar contacts; depth taken as the ROV's own, head
    and hand assumed); ``camera`` / ``sonar``: the sensors its readers read (default: the
    agent's first camera and its perception sonar; readers of a missing sensor are off);
    ``channels``: the readers that run; ``markers``: the slate's ids → commands (default:
    the shipped table); ``tools``: a command's tool name → the world's tool (default:
    each tool kind but baskets → the first tool of that kind); ``sites``: the work sites
    it knows (default: every flange, hatch and load); ``params``: the assistant's
    parameters (``uhrisim.assistant.AssistantConfig``: guards, speeds, distances)."""

    diver: AssistName | None = None
    track: Literal["truth", "sonar"] = "truth"
    camera: AssistName | None = None
    sonar: AssistName | None = None
    channels: tuple[ChannelName, ...] = ("marker", "gesture", "sonar")
    markers: dict[int, str] = Field(default_factory=dict)
    tools: dict[AssistName, AssistName] | None = None
    sites: tuple[AssistName, ...] | None = None
    params: dict[str, Any] = Field(default_factory=dict)
