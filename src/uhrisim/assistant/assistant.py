"""The assistant: signals in, a task, a tick of the tree, helm postings out, traced.

One :meth:`Assistant.step` per helm tick (4 Hz in the paper): take the signals recognized
since the last tick (on a channel it does not ``obey``, or below ``min_confidence``:
ignored and logged), tick the tree
(:mod:`.trees`), post the helm variables that changed (while backing off: the manual
override and DESIRED_* every tick), and keep the tick in :attr:`Assistant.trace`.

Signals: a command replaces the task in hand (its branch starts from its beginning);
the same command again changes nothing; ``done`` ends the task; ``ok`` is logged;
``bring_tool X`` for a tool the map does not have and ``light_here S`` for an unknown
site are refused (logged). With no task the ROV does ``default_task`` — idle, it asks
a hovering diver to say it again when nothing was read for a while, closing in to
arm's reach first (:class:`~uhrisim.assistant.behaviours.AskAgain`, then
:class:`~uhrisim.assistant.behaviours.CueAgain`; ``ASSIST_QUERY = say_again`` while it
shows the cue).
"""

from __future__ import annotations

from dataclasses import replace
from importlib import resources
from pathlib import Path

import numpy as np
import py_trees
from numpy.typing import NDArray

from uhrisim.assistant.behaviours import TreeContext
from uhrisim.assistant.config import AssistantConfig
from uhrisim.assistant.io import AssistantInputs, AssistantOutputs, Posting
from uhrisim.assistant.trees import active_path, build_tree
from uhrisim.perception.signals import Command, RecognizedSignal

#: the decision domain of the helm in ``assistant/data/assistant.bhv`` (pHelmIvP style)
HELM_DOMAIN = ("course:0:359:360", "speed:0:1.0:101", "depth:0:50:5001:optional")
_OVERRIDE_VARS = ("DESIRED_HEADING", "DESIRED_SPEED", "DESIRED_DEPTH")


def assistant_bhv() -> Path:
    """The shipped helm file the assistant drives (``assistant/data/assistant.bhv``)."""
    return Path(str(resources.files("uhrisim.assistant").joinpath("data/assistant.bhv")))


class Assistant:
    """The diver's assistant above the helm (module docstring)."""

    def __init__(self, config: AssistantConfig | None = None) -> None:
        self.config = config or AssistantConfig()
        self.ctx = TreeContext(self.config)
        self.root, self._tasks = build_tree(self.ctx)
        self._posted: dict[str, str | float] = {}
        self._trim, self._trim_t = 0.0, None  # the depth trim (m, < 0: shallower), since
        self._head: tuple[float, NDArray[np.float64]] | None = None  # (t, head - body)
        #: every tick's outputs, in order
        self.trace: list[AssistantOutputs] = []

    def step(self, inputs: AssistantInputs) -> AssistantOutputs:
        """One tick: what to post, the gripper command, the task, the active path."""
        ctx = self.ctx
        inputs = self._with_head_rate(inputs)
        ctx.inputs = inputs
        ctx.wants, ctx.events = {}, []
        ctx.override, ctx.gripper_command, ctx.asking = False, None, False
        if ctx.diver is not None:
            ctx.last_diver = ctx.diver
        for signal in sorted(inputs.signals, key=lambda s: s.t):
            self._take(signal)
        if ctx.task is None and self.config.default_task != "idle":
            self._start(Command(self.config.default_task), "by default")
        self.root.tick_once()
        active = active_path(self.root)
        wants: dict[str, str | float] = {"MOOS_MANUAL_OVERRIDE": str(ctx.override).lower()}
        wants |= self._trimmed(ctx.wants, inputs)
        wants["ASSIST_TASK"] = str(ctx.task) if ctx.task is not None else "idle"
        wants["ASSIST_ACTIVE"] = active
        wants["ASSIST_QUERY"] = "say_again" if ctx.asking else "none"
        posts: list[Posting] = []
        for var, value in wants.items():
            if self._posted.get(var) != value or (ctx.override and var in _OVERRIDE_VARS):
                posts.append((var, value))
                self._posted[var] = value
        out = AssistantOutputs(inputs.t, tuple(posts), ctx.gripper_command,  # type: ignore[arg-type]
                               wants["ASSIST_TASK"], active, tuple(ctx.events))  # type: ignore[arg-type]
        self.trace.append(out)
        return out

    def _with_head_rate(self, inputs: AssistantInputs) -> AssistantInputs:
        """The inputs with the diver's head rate (relative to his body, NED m/s) from
        this fresh track's head and the last one's, when the tracker gave a head but no
        rate (the guards look ahead with it: a diver rising upright swings his head
        ~0.7 m in ~2 s)."""
        d = inputs.diver
        if d is None or d.head_ned is None or d.age_s > self.config.lost_after_s:
            self._head = None
            return inputs
        arm = d.head_ned - d.position_ned
        last, self._head = self._head, (inputs.t, arm)
        if d.head_rate_ned is not None or last is None or inputs.t <= last[0]:
            return inputs
        rate = (arm - last[1]) / (inputs.t - last[0])
        return replace(inputs, diver=replace(d, head_rate_ned=rate))

    def _trimmed(self, wants: dict[str, str | float], inputs: AssistantInputs
                 ) -> dict[str, str | float]:
        """The depth asked for, trimmed while a tool is held: a vehicle whose depth
        control is proportional sags under a load (the VideoRay ~0.65 m under a 0.86 N
        light, docs/teamwork.md); the trim integrates the sag (``depth_trim_rate`` per s
        per m, within ``depth_trim_max_m``) and is dropped when the gripper is empty."""
        cfg, target = self.config, self._depth_target(wants)
        if inputs.gripper.holding is None or target is None:
            self._trim, self._trim_t = 0.0, None
            return wants
        if self._trim_t is not None:
            sag = float(inputs.rov.position_ned[2]) - target
            self._trim = min(0.0, max(-cfg.depth_trim_max_m, self._trim - cfg.depth_trim_rate
                                      * sag * (inputs.t - self._trim_t)))
        self._trim_t = inputs.t
        out = dict(wants)
        if "DEPTH_UPDATES" in out:
            out["DEPTH_UPDATES"] = f"depth={max(0.0, target + self._trim):.2f}"
        if "DESIRED_DEPTH" in out:
            out["DESIRED_DEPTH"] = max(0.0, target + self._trim)
        return out

    @staticmethod
    def _depth_target(wants: dict[str, str | float]) -> float | None:
        if "DESIRED_DEPTH" in wants:
            return float(wants["DESIRED_DEPTH"])
        text = str(wants.get("DEPTH_UPDATES", ""))
        return float(text.removeprefix("depth=")) if text.startswith("depth=") else None

    def _start(self, command: Command, why: str) -> None:
        ctx = self.ctx
        if ctx.task is not None:
            ctx.event(f"task {ctx.task} replaced by {command}")
        ctx.task = command
        ctx.plan.clear()
        self._tasks.stop(py_trees.common.Status.INVALID)
        ctx.event(f"task {command} {why}")

    def _take(self, signal: RecognizedSignal) -> None:
        ctx, c = self.ctx, signal.command
        heard = f"{c} ({signal.channel}, confidence {signal.confidence:.2f})"
        if signal.channel not in self.config.obey:
            ctx.event(f"ignored {heard}: this ROV obeys {', '.join(self.config.obey)} only")
            return
        if signal.confidence < self.config.min_confidence:
            ctx.event(f"ignored {heard}: below {self.config.min_confidence:g}")
            return
        ctx.heard_t = ctx.t
        if c.name == "ok":
            ctx.event(f"ok {heard}")
        elif c.name == "done":
            if ctx.task is not None:
                ctx.finish_task(f"done: {heard}")
                self._tasks.stop(py_trees.common.Status.INVALID)
        elif c.name == "bring_tool" and c.argument not in ctx.now.tools and (
                ctx.now.gripper.holding != c.argument):
            ctx.event(f"refused {heard}: no tool {c.argument!r} on the map")
        elif c.name == "light_here" and c.argument is not None and (
                c.argument not in ctx.now.sites):
            ctx.event(f"refused {heard}: no work site {c.argument!r} on the map")
        elif c != ctx.task:
            self._start(c, f"from {heard}")
