"""The diver's commands to the ROV, and a signal recognized on some channel.

One vocabulary for every channel (docs/hri.md): a marker on a slate, a gesture, and (part
2) a large arm motion on the sonar each stand for a :class:`Command`; a reader that
recognizes one reports a :class:`RecognizedSignal` with its confidence. The assistant
(:mod:`uhrisim.assistant`) acts on them.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from uhrisim.core.errors import ConfigError
from uhrisim.core.files import read_text_file

#: command -> its argument: "none", "required" (bring_tool <tool>) or "optional"
#: (light_here [<site>]: without one, where the diver's hands are)
COMMANDS: dict[str, str] = {
    "follow_me": "none",
    "stop": "none",
    "come_here": "none",
    "go_up": "none",
    "bring_tool": "required",
    "light_here": "optional",
    "ok": "none",
    "done": "none",
}

Channel = Literal["marker", "gesture", "sonar"]
CHANNELS: tuple[Channel, ...] = ("marker", "gesture", "sonar")


@dataclass(frozen=True)
class Command:
    """A command of :data:`COMMANDS` with its argument (a tool or site name), if any."""

    name: str
    argument: str | None = None

    def __post_init__(self) -> None:
        rule = COMMANDS.get(self.name)
        if rule is None:
            raise ConfigError(f"unknown command {self.name!r} (have {', '.join(COMMANDS)})",
                              "command")
        if rule == "required" and not self.argument:
            raise ConfigError(f"{self.name} needs an argument, e.g. '{self.name} wrench'",
                              "command")
        if rule == "none" and self.argument is not None:
            raise ConfigError(f"{self.name} takes no argument, got {self.argument!r}",
                              "command")

    @staticmethod
    def parse(text: object, where: str = "command") -> Command:
        """``"bring_tool lift_bag"`` → Command("bring_tool", "lift_bag")."""
        words = str(text).split()
        if not 1 <= len(words) <= 2:
            raise ConfigError(f"a command is a name and at most one argument, got {text!r}",
                              where)
        try:
            return Command(words[0], words[1] if len(words) == 2 else None)
        except ConfigError as error:
            raise ConfigError(str(error).removeprefix("command: "), where) from None

    def __str__(self) -> str:
        return self.name if self.argument is None else f"{self.name} {self.argument}"


@dataclass(frozen=True)
class RecognizedSignal:
    """A command read on ``channel`` at time ``t`` (s) with ``confidence`` in [0, 1]."""

    command: Command
    channel: Channel
    confidence: float
    t: float

    def __post_init__(self) -> None:
        if self.channel not in CHANNELS:
            raise ConfigError(f"channel must be one of {CHANNELS}, got {self.channel!r}",
                              "RecognizedSignal")
        if not (math.isfinite(self.confidence) and 0.0 <= self.confidence <= 1.0):
            raise ConfigError(f"confidence must be in [0, 1], got {self.confidence!r}",
                              "RecognizedSignal")


def load_json(path: str | Path | None, shipped: str, kind: str) -> tuple[Any, str]:
    """(data, where) of the JSON file ``path``, or of the package's ``perception/data/
    <shipped>`` when ``path`` is None; ``where`` names the file for error messages."""
    if path is None:
        text = resources.files("uhrisim.perception").joinpath(f"data/{shipped}").read_text(
            encoding="utf-8")
        where = f"uhrisim/perception/data/{shipped}"
    else:
        text, where = read_text_file(path, kind), str(path)
    try:
        return json.loads(text), where
    except json.JSONDecodeError as error:
        raise ConfigError(f"not JSON: {error.msg} (line {error.lineno})", where) from None
