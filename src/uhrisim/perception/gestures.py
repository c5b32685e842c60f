"""The diver's gesture language: timed arm and hand poses that stand for commands.

A subset of the CADDY project's CADDIAN language (D. Chiarella, M. Bibuli, G. Bruzzone,
M. Caccia, A. Ranieri, E. Zereik, L. Marconi, P. Cutugno, "A Novel Gesture-Based
Language for Underwater Human–Robot Interaction", J. Mar. Sci. Eng. 6(3) 91, 2018) and
of the recreational diver signals it builds on, with the gesture classes of the CADDY
dataset (A. Gomez Chavez, A. Ranieri, D. Chiarella, E. Zereik, A. Babić, A. Birk, "CADDY
Underwater Stereo-Vision Dataset for Human–Robot Interaction (HRI) in the Context of
Diver Activities", J. Mar. Sci. Eng. 7(1) 16, 2019). Each gesture is data
(``perception/data/gestures.json``): a command and a list of keyframes, each the joint
targets (degrees, by joint name) the articulated diver reaches at time ``t`` (s) from
the gesture's start. docs/hri.md lists them.

**Joints** are those of the articulated diver (issue 25's body model,
``dynamics/diver_body.py`` on the teamwork branch): ``posture``, ``waist``,
``neck_flex``, ``neck_rot`` and per side ``{side}_shoulder_flex``, ``_shoulder_abd``,
``_shoulder_rot``, ``_elbow``, ``_wrist``, ``_fingers`` (one curl joint per hand: 0 open,
72° a closed grip), legs not used. ``{s}`` stands for the signalling arm and ``{o}`` for
the other; :meth:`Gesture.timeline` resolves them for a side.

**Keyframes.** The first names a pose (``signal_ready``: every arm joint 0, then the
pose's angles); each later one changes the joints it names and keeps the rest. ``hand``
annotates the signalling hand's shape (``ok_ring``, ``point``, ``thumb_up``, ...): the
body model has one finger joint, so a shape shows as open or curled fingers; the
annotation is there for a finer hand. ``bring_tool`` goes on with one ``count`` block per
unit of the tool's number (``tool_numbers``; a scenario gives its own) and then its
``end`` keyframes (times from the last count's end): each count a stroke of the whole
arm, the end the arm dropped, so that the camera sees how many and when they are done.

**Assumptions.** Joint angles are relative to the trunk, so a gesture reads the same for
a diver upright in the water (as one signals) and one standing on weighted boots. The
timings are chosen so that every move between keyframes fits the body model's joint
speeds with its acceleration time to spare (:meth:`GestureSet.check_motion`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from uhrisim.core.errors import ConfigError
from uhrisim.perception.signals import CHANNELS, Channel, Command, load_json

Side = Literal["left", "right"]
#: joint kinds of each arm, and the trunk's joints a gesture may name
ARM_JOINTS = ("shoulder_flex", "shoulder_abd", "shoulder_rot", "elbow", "wrist", "fingers")
TRUNK_JOINTS = ("posture", "waist", "neck_flex", "neck_rot")
HAND_SHAPES = ("open", "flat", "fist", "point", "thumb_up", "ok_ring")


@dataclass(frozen=True)
class Keyframe:
    """Joint targets (rad, by joint name, every joint named so far) reached at ``t`` (s)
    and the signalling hand's shape."""

    t: float
    joints: Mapping[str, float]
    hand: str | None


@dataclass(frozen=True)
class Gesture:
    """One gesture: its command, channel, keyframes (degrees, ``{s}``/``{o}`` names) and
    the optional ``count`` block (period s, keyframes relative to the block's start) and
    the keyframes after the last count (relative to its end)."""

    name: str
    command: str
    channel: Channel
    source: str
    description: str
    keyframes: tuple[tuple[float, Mapping[str, float], str | None], ...]
    count_period_s: float | None = None
    count_keyframes: tuple[tuple[float, Mapping[str, float], str | None], ...] = ()
    end_keyframes: tuple[tuple[float, Mapping[str, float], str | None], ...] = ()

    def timeline(self, side: Side = "right", count: int | None = None) -> tuple[Keyframe, ...]:
        """The keyframes for the signalling arm ``side``, angles in radians, each with
        every joint named up to it; ``count`` (1..9) repeats the count block (needed by
        gestures that have one, refused by the others), then come the end keyframes."""
        if side not in ("left", "right"):
            raise ConfigError(f"side must be 'left' or 'right', got {side!r}",
                              f"gesture {self.name}")
        if (count is None) != (self.count_period_s is None):
            raise ConfigError("needs a count (the tool's number)" if count is None
                              else "takes no count", f"gesture {self.name}")
        other = "left" if side == "right" else "right"
        frames = list(self.keyframes)
        if count is not None:
            if not 1 <= count <= 9:
                raise ConfigError(f"count must be 1..9, got {count!r}", f"gesture {self.name}")
            start = frames[-1][0]
            assert self.count_period_s is not None
            for k in range(count):
                base = start + k * self.count_period_s
                frames += [(base + t, joints, hand) for t, joints, hand in self.count_keyframes]
            done = start + count * self.count_period_s
            frames += [(done + t, joints, hand) for t, joints, hand in self.end_keyframes]
        out: list[Keyframe] = []
        current: dict[str, float] = {}
        hand: str | None = None
        for t, joints, shape in frames:
            for name, degrees in joints.items():
                current[name.format(s=side, o=other)] = math.radians(degrees)
            hand = shape or hand
            out.append(Keyframe(t, dict(current), hand))
        return tuple(out)

    def duration_s(self, count: int | None = None) -> float:
        return self.timeline(count=count)[-1].t


def pose_at(frames: tuple[Keyframe, ...], t: float) -> dict[str, float]:
    """Joint angles (rad, by name) ``t`` s into a timeline: linear between keyframes, the
    first before it starts and the last after it ends."""
    if t <= frames[0].t:
        return dict(frames[0].joints)
    for a, b in itertools.pairwise(frames):
        if t <= b.t:
            w = (t - a.t) / (b.t - a.t)
            return {j: (1 - w) * a.joints.get(j, 0.0) + w * b.joints[j] for j in b.joints}
    return dict(frames[-1].joints)


@dataclass(frozen=True)
class GestureSet:
    """The gestures of a language file, with its tool numbers (tool name → count)."""

    gestures: Mapping[str, Gesture]
    tool_numbers: Mapping[str, int]

    def for_command(self, command: Command, channel: Channel = "gesture"
                    ) -> tuple[Gesture, int | None]:
        """The gesture that says ``command`` on ``channel`` and its count (the tool's
        number for bring_tool)."""
        for g in self.gestures.values():
            if g.command == command.name and g.channel == channel:
                if g.count_period_s is None:
                    return g, None
                if command.argument not in self.tool_numbers:
                    raise ConfigError(f"no number for tool {command.argument!r} (have "
                                      f"{', '.join(self.tool_numbers)})", "gesture tool_numbers")
                return g, self.tool_numbers[command.argument]
        raise ConfigError(f"no {channel} gesture says {command.name!r}", "gestures")

    def check_motion(self, limits: Mapping[str, tuple[float, float]],
                     max_speed: Mapping[str, float], acceleration_time_s: float = 0.25
                     ) -> list[str]:
        """Problems with executing the gestures on a body with joint ``limits`` (rad,
        lower and upper) and ``max_speed`` (rad/s) by joint name: unknown joints, angles
        outside the limits, and moves between keyframes shorter than the joint needs
        (distance / speed + ``acceleration_time_s``). Both sides, the largest count."""
        problems = []
        for g in self.gestures.values():
            count = max(self.tool_numbers.values()) if g.count_period_s is not None else None
            for side in ("left", "right"):
                previous: Keyframe | None = None
                for k in g.timeline(side, count):
                    for name, angle in k.joints.items():
                        if name not in limits or name not in max_speed:
                            problems.append(f"{g.name}: the body has no joint {name!r}")
                            continue
                        lo, hi = limits[name]
                        if not lo - 1e-9 <= angle <= hi + 1e-9:
                            problems.append(
                                f"{g.name} at {k.t:g} s: {name} {math.degrees(angle):.0f}° "
                                f"outside [{math.degrees(lo):.0f}°, {math.degrees(hi):.0f}°]")
                        if previous is not None:  # the first keyframe is led into
                            move = abs(angle - previous.joints.get(name, 0.0))
                            need = move / max_speed[name] + (acceleration_time_s if move else 0)
                            if need > k.t - previous.t + 1e-9:
                                problems.append(
                                    f"{g.name} {previous.t:g}-{k.t:g} s: {name} moves "
                                    f"{math.degrees(move):.0f}° in {k.t - previous.t:.2f} s, "
                                    f"needs {need:.2f} s")
                    previous = k
        return sorted(set(problems))

    @staticmethod
    def from_mapping(data: object, where: str = "gestures") -> GestureSet:
        """From the JSON layout of ``perception/data/gestures.json``; errors name the
        field (``<file>: gestures.<name>.keyframes[<i>].joints.<joint>: ...``)."""
        if not isinstance(data, Mapping) or not isinstance(data.get("gestures"), Mapping):
            raise ConfigError("must be a mapping with 'gestures'", where)
        poses = data.get("poses", {})
        if not isinstance(poses, Mapping):
            raise ConfigError("must map pose names to joint angles", f"{where}: poses")
        tools = data.get("tool_numbers", {})
        if not isinstance(tools, Mapping) or not all(
                isinstance(v, int) and 1 <= v <= 9 for v in tools.values()):
            raise ConfigError("must map tool names to numbers 1..9", f"{where}: tool_numbers")
        gestures = {name: _gesture(name, spec, poses, f"{where}: gestures.{name}")
                    for name, spec in data["gestures"].items()}
        return GestureSet(gestures, dict(tools))

    @staticmethod
    def load(path: str | Path | None = None) -> GestureSet:
        """The gestures in the JSON file ``path``, or the shipped language."""
        data, where = load_json(path, "gestures.json", "gesture language")
        return GestureSet.from_mapping(data, where)


def _joint_name(name: object, where: str) -> str:
    """``name`` if a gesture may move it (module docstring), else a ConfigError."""
    text = str(name)
    side, _, kind = text.partition("_")
    if text in TRUNK_JOINTS or (side in ("{s}", "{o}", "left", "right") and kind in ARM_JOINTS):
        return text
    raise ConfigError(f"unknown joint {text!r} (arm joints are {{s}}_ or {{o}}_ with "
                      f"{', '.join(ARM_JOINTS)}; trunk: {', '.join(TRUNK_JOINTS)})", where)


def _angles(joints: object, where: str) -> dict[str, float]:
    if not isinstance(joints, Mapping):
        raise ConfigError("must map joint names to angles in degrees", where)
    out = {}
    for name, value in joints.items():
        key = _joint_name(name, f"{where}.{name}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
                value):
            raise ConfigError(f"must be a finite angle in degrees, got {value!r}",
                              f"{where}.{name}")
        out[key] = float(value)
    return out


def _keyframes(frames: object, poses: Mapping, where: str, first_pose: bool
               ) -> tuple[tuple[float, Mapping[str, float], str | None], ...]:
    if not isinstance(frames, list) or not frames:
        raise ConfigError("must be a non-empty list of keyframes", where)
    out = []
    last_t = -math.inf
    for i, frame in enumerate(frames):
        at = f"{where}[{i}]"
        if not isinstance(frame, Mapping) or set(frame) - {"t", "joints", "pose", "hand"}:
            raise ConfigError("a keyframe has t, and joints or pose (and hand)", at)
        t = frame.get("t")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not t > last_t:
            raise ConfigError(f"t must be a number after the previous keyframe's, got {t!r}",
                              f"{at}.t")
        if first_pose and i == 0 and t != 0:
            raise ConfigError("the first keyframe is at t = 0", f"{at}.t")
        last_t = float(t)
        if "pose" in frame:
            if not (first_pose and i == 0):
                raise ConfigError("only the first keyframe names a pose", f"{at}.pose")
            if frame["pose"] not in poses:
                raise ConfigError(f"unknown pose {frame['pose']!r} (have {', '.join(poses)})",
                                  f"{at}.pose")
            joints = {f"{side}_{kind}": 0.0 for side in ("{s}", "{o}") for kind in ARM_JOINTS}
            joints |= _angles(poses[frame["pose"]], f"poses.{frame['pose']}")
        elif first_pose and i == 0:
            raise ConfigError("the first keyframe names the pose the gesture starts from", at)
        else:
            joints = _angles(frame.get("joints", {}), f"{at}.joints")
        hand = frame.get("hand")
        if hand is not None and hand not in HAND_SHAPES:
            raise ConfigError(f"unknown hand shape {hand!r} (have {', '.join(HAND_SHAPES)})",
                              f"{at}.hand")
        out.append((float(t), joints, hand))
    return tuple(out)


def _gesture(name: str, spec: object, poses: Mapping, where: str) -> Gesture:
    if not isinstance(spec, Mapping):
        raise ConfigError("must be a mapping", where)
    unknown = set(spec) - {"command", "channel", "source", "description", "keyframes", "count",
                           "end"}
    if unknown:
        raise ConfigError(f"unknown field(s) {sorted(unknown)}", where)
    command = str(spec.get("command", ""))
    try:
        Command(command, "x" if command == "bring_tool" else None)
    except ConfigError as error:
        raise ConfigError(str(error).removeprefix("command: "), f"{where}.command") from None
    channel = spec.get("channel", "gesture")
    if channel not in CHANNELS:
        raise ConfigError(f"must be one of {CHANNELS}, got {channel!r}", f"{where}.channel")
    keyframes = _keyframes(spec.get("keyframes"), poses, f"{where}.keyframes", True)
    count = spec.get("count")
    period, count_frames = None, ()
    if (count is None) == (command == "bring_tool"):
        raise ConfigError("bring_tool, and only it, has a count block", f"{where}.count")
    if count is not None:
        if not isinstance(count, Mapping) or set(count) != {"period_s", "keyframes"}:
            raise ConfigError("must have period_s and keyframes", f"{where}.count")
        period = count["period_s"]
        if isinstance(period, bool) or not isinstance(period, (int, float)) or not period > 0:
            raise ConfigError(f"must be a number > 0, got {period!r}", f"{where}.count.period_s")
        count_frames = _keyframes(count["keyframes"], poses, f"{where}.count.keyframes", False)
        if count_frames[0][0] <= 0.0 or count_frames[-1][0] > period:
            raise ConfigError("count keyframes lie in (0, period_s]",
                              f"{where}.count.keyframes")
    end_frames = ()
    if "end" in spec:
        if count is None:
            raise ConfigError("only a gesture with a count has end keyframes", f"{where}.end")
        end_frames = _keyframes(spec["end"], poses, f"{where}.end", False)
        if end_frames[0][0] <= 0.0:
            raise ConfigError("end keyframes come after the last count (t > 0)",
                              f"{where}.end[0].t")
    return Gesture(name, command, channel, str(spec.get("source", "")),
                   str(spec.get("description", "")), keyframes,
                   None if period is None else float(period), count_frames, end_frames)
