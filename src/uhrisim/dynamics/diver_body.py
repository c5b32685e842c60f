"""The diver's articulated body: a kinematic skeleton beside the swimming model (eqs 10-13).

:mod:`uhrisim.dynamics.diver` moves the diver as a whole (position and heading); this
module poses its limbs. Frames and units follow ``docs/conventions.md``: the **body
frame** is FRD (x forward, y to the diver's right, z down), metres, with its origin at the
hip centre (the pelvis). The zero configuration ``q = 0`` is a diver standing upright in
the anatomical position: arms hanging, palms forward, legs straight, feet flat.

**Kinematics.** Every joint is a revolute axis through a pivot, both given in the body
frame at ``q = 0``. A link's pose is the product of exponentials of the joints on its
chain, root first (Brockett 1984; Murray, Li & Sastry, *A Mathematical Introduction to
Robotic Manipulation*, 1994, ch. 3)::

    T_link(q) = exp(xi_1 q_1) exp(xi_2 q_2) ... exp(xi_k q_k)

a 4x4 map from the link's rest-pose coordinates to its posed coordinates, both in the
body frame. That is the transform :class:`uhrisim.world.bodies.Part` applies to a rest-pose
mesh, so the meshes of :mod:`uhrisim.world.diver_figure` are posed by exactly these
matrices. The root joint ``posture`` pitches the whole body about the hips: 0 standing,
90° prone (the swimming attitude, head forward).

**Segment lengths** (stature ``H`` = 1.75 m, about the 50th-percentile man of NASA-STD-3000
Vol. I §3.3.1) use the segment/stature ratios of D. A. Winter, *Biomechanics and Motor
Control of Human Movement*, 4th ed., Wiley 2009, Fig. 4.1 (after Drillis & Contini 1966):
shoulder height 0.818H, biacromial width 0.259H, upper arm 0.186H, forearm 0.146H, hand
0.108H, hip (greater trochanter) 0.530H, thigh 0.245H, shank 0.246H, ankle height
0.039H, foot length 0.152H. The hip joint centres' spacing (±0.09 m) and the grip point
(palm centre, 0.4 of the hand length past the wrist) are assumptions.

**Joint limits** are the normal active ranges of motion of the American Academy of
Orthopaedic Surgeons (*Joint Motion: Method of Measuring and Recording*, 1965), the
ranges MIL-HDBK-759 / NASA-STD-3000 Vol. I §3.3.4 tabulate for design, multiplied by
``DRY_SUIT_ROM_FACTOR`` = 0.8 about the neutral position. The factor is an **assumption**:
a dry suit with a thick undergarment and dry gloves binds at the shoulder, elbow and knee
as protective coveralls do (Adams & Keyserling, AIHA J. 56:333-340, 1995, measured such
losses garment by garment; space-suit mobility tests, e.g. Aitchison, NASA NTRS
20120004286, 2012, measure them for pressure suits); no dry-suit range-of-motion data set
was found, so the factor is stated once here and can be changed.

**Joint speeds** are assumptions. Arms and head for deliberate work in water (human
voluntary joint speeds on land exceed several hundred °/s; a diver in a dry suit moving
against drag that grows with speed squared works far slower): shoulder 90°/s, elbow and
wrist 120°/s, fingers 144°/s (open to closed in 0.5 s), neck 60°/s, posture 30°/s. Legs
as fast as walking and finning need (below the swing-phase peaks of walking on land,
which reach several rad/s at the knee): hip flexion 200°/s, hip abduction 120°/s, knee
300°/s, ankle 200°/s (a fin blade also flexes passively).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.compiled import jit
from uhrisim.core.errors import ConfigError

Side = Literal["left", "right"]
SIDES: tuple[Side, Side] = ("left", "right")

#: Stature (m) of the default diver and Winter's segment/stature ratios (module docstring).
STATURE_M = 1.75
SHOULDER_HEIGHT_RATIO = 0.818
BIACROMIAL_RATIO = 0.259
UPPER_ARM_RATIO = 0.186
FOREARM_RATIO = 0.146
HAND_RATIO = 0.108
HIP_HEIGHT_RATIO = 0.530
THIGH_RATIO = 0.245
SHANK_RATIO = 0.246
ANKLE_HEIGHT_RATIO = 0.039
FOOT_LENGTH_RATIO = 0.152
NECK_HEIGHT_RATIO = 0.845  # between shoulder (0.818) and chin (0.870): assumed pivot
HEAD_CENTRE_RATIO = 0.936  # eye height
#: Assumptions (module docstring): hip joint centres' half spacing, the trunk's bending
#: pivot (lumbosacral, above the hip centre), grip point on the hand.
HIP_HALF_SPACING_M = 0.09
WAIST_PIVOT_HEIGHT_M = 0.10
GRIP_FRACTION_OF_HAND = 0.4
#: Range-of-motion factor of a dry suit (assumption, module docstring).
DRY_SUIT_ROM_FACTOR = 0.8


@dataclass(frozen=True)
class JointSpec:
    """One revolute joint (body frame at q = 0; angles in radians, speeds in rad/s).

    ``parent`` is the joint before this one on its chain (None: the root). ``lower`` and
    ``upper`` bound the angle, ``max_speed`` its rate. Positive angles are the anatomical
    direction named in :data:`JOINT_MEANINGS`.
    """

    name: str
    pivot: tuple[float, float, float]
    axis: tuple[float, float, float]
    lower: float
    upper: float
    max_speed: float
    parent: str | None


#: What a positive angle of each joint kind means (the rest are "0 = anatomical position").
JOINT_MEANINGS = {
    "posture": "whole body pitched forward about the hips (0 standing, 90° prone)",
    "waist": "trunk bent forward over the hips (thoracolumbar flexion)",
    "neck_flex": "chin towards the chest",
    "neck_rot": "face turned to the right",
    "shoulder_flex": "arm raised forward (180°: overhead)",
    "shoulder_abd": "arm raised sideways, away from the body",
    "shoulder_rot": "internal rotation (forearm towards the belly when the elbow is bent)",
    "elbow": "flexion",
    "wrist": "flexion (palm towards the forearm)",
    "fingers": "fingers curled: 0 open hand, upper limit a closed grip",
    "hip_flex": "thigh raised forward",
    "hip_abd": "leg spread sideways",
    "knee": "flexion (heel towards the buttock)",
    "ankle": "dorsiflexion (toes up); negative: plantar flexion (toes pointed)",
}

#: AAOS (1965) normal active ranges, degrees (negative: the opposite movement), before the
#: dry-suit factor; and the assumed maximum speeds (°/s). Keys: joint kinds.
_RANGE_DEG: dict[str, tuple[float, float, float]] = {
    "waist": (-25.0, 80.0, 45.0),
    "neck_flex": (-45.0, 45.0, 60.0),
    "neck_rot": (-60.0, 60.0, 60.0),
    "shoulder_flex": (-60.0, 180.0, 90.0),
    "shoulder_abd": (-45.0, 180.0, 90.0),
    "shoulder_rot": (-90.0, 70.0, 90.0),
    "elbow": (0.0, 150.0, 120.0),
    "wrist": (-70.0, 80.0, 120.0),
    "fingers": (0.0, 90.0, 144.0),
    "hip_flex": (-30.0, 120.0, 200.0),
    "hip_abd": (-30.0, 45.0, 120.0),
    "knee": (0.0, 135.0, 300.0),
    "ankle": (-50.0, 20.0, 200.0),
}
#: The posture joint is no human joint: 0-90° at 30°/s (assumed), not scaled.
_POSTURE_DEG = (0.0, 90.0, 30.0)


def _unit(v: tuple[float, float, float]) -> tuple[float, float, float]:
    n = math.sqrt(sum(c * c for c in v))
    return (v[0] / n, v[1] / n, v[2] / n)


@dataclass(frozen=True)
class Anthropometry:
    """Body dimensions (m) from a stature and Winter's ratios (module docstring)."""

    stature_m: float = STATURE_M

    def __post_init__(self) -> None:
        if not (math.isfinite(self.stature_m) and 1.4 <= self.stature_m <= 2.1):
            raise ConfigError(f"must be in [1.4, 2.1] m, got {self.stature_m!r}",
                              where="Anthropometry.stature_m")

    def _h(self, ratio: float) -> float:
        """Body-frame z (m, down) of a landmark at ``ratio`` × stature above the sole."""
        return -(ratio - HIP_HEIGHT_RATIO) * self.stature_m

    @property
    def shoulder_z(self) -> float:
        return self._h(SHOULDER_HEIGHT_RATIO)

    @property
    def shoulder_half_width(self) -> float:
        return 0.5 * BIACROMIAL_RATIO * self.stature_m

    @property
    def neck_z(self) -> float:
        return self._h(NECK_HEIGHT_RATIO)

    @property
    def head_centre_z(self) -> float:
        return self._h(HEAD_CENTRE_RATIO)

    @property
    def upper_arm(self) -> float:
        return UPPER_ARM_RATIO * self.stature_m

    @property
    def forearm(self) -> float:
        return FOREARM_RATIO * self.stature_m

    @property
    def hand(self) -> float:
        return HAND_RATIO * self.stature_m

    @property
    def thigh(self) -> float:
        return THIGH_RATIO * self.stature_m

    @property
    def shank(self) -> float:
        return SHANK_RATIO * self.stature_m

    @property
    def ankle_height(self) -> float:
        return ANKLE_HEIGHT_RATIO * self.stature_m

    @property
    def foot_length(self) -> float:
        return FOOT_LENGTH_RATIO * self.stature_m

    @property
    def hip_height(self) -> float:
        """Height (m) of the hip centre (the body origin) above the soles when standing."""
        return HIP_HEIGHT_RATIO * self.stature_m


def _joints(body: Anthropometry, rom_factor: float) -> list[JointSpec]:
    """The joint table (module docstring): posture, neck, arms, legs."""

    def spec(kind: str, name: str, pivot, axis, parent: str | None) -> JointSpec:
        lo, hi, speed = _RANGE_DEG[kind]
        return JointSpec(name, tuple(float(c) for c in pivot), _unit(axis),
                         math.radians(lo * rom_factor), math.radians(hi * rom_factor),
                         math.radians(speed), parent)

    lo, hi, speed = _POSTURE_DEG
    joints = [JointSpec("posture", (0.0, 0.0, 0.0), (0.0, -1.0, 0.0), math.radians(lo),
                        math.radians(hi), math.radians(speed), None)]
    neck = (0.0, 0.0, body.neck_z)
    joints += [spec("waist", "waist", (0.0, 0.0, -WAIST_PIVOT_HEIGHT_M), (0.0, -1.0, 0.0),
                    "posture"),
               spec("neck_flex", "neck_flex", neck, (0.0, -1.0, 0.0), "waist"),
               spec("neck_rot", "neck_rot", neck, (0.0, 0.0, 1.0), "neck_flex")]
    for side in SIDES:
        s = 1.0 if side == "right" else -1.0
        shoulder = (0.0, s * body.shoulder_half_width, body.shoulder_z)
        elbow = (0.0, shoulder[1], shoulder[2] + body.upper_arm)
        wrist = (0.0, shoulder[1], elbow[2] + body.forearm)
        knuckles = (0.0, shoulder[1], wrist[2] + 0.5 * body.hand)
        hip = (0.0, s * HIP_HALF_SPACING_M, 0.0)
        knee = (0.0, hip[1], body.thigh)
        ankle = (0.0, hip[1], body.thigh + body.shank)
        p = f"{side}_"
        joints += [
            spec("shoulder_flex", p + "shoulder_flex", shoulder, (0.0, 1.0, 0.0), "waist"),
            spec("shoulder_abd", p + "shoulder_abd", shoulder, (-s, 0.0, 0.0),
                 p + "shoulder_flex"),
            spec("shoulder_rot", p + "shoulder_rot", shoulder, (0.0, 0.0, -s),
                 p + "shoulder_abd"),
            spec("elbow", p + "elbow", elbow, (0.0, 1.0, 0.0), p + "shoulder_rot"),
            spec("wrist", p + "wrist", wrist, (0.0, 1.0, 0.0), p + "elbow"),
            spec("fingers", p + "fingers", knuckles, (0.0, 1.0, 0.0), p + "wrist"),
            spec("hip_flex", p + "hip_flex", hip, (0.0, 1.0, 0.0), "posture"),
            spec("hip_abd", p + "hip_abd", hip, (-s, 0.0, 0.0), p + "hip_flex"),
            spec("knee", p + "knee", knee, (0.0, -1.0, 0.0), p + "hip_abd"),
            spec("ankle", p + "ankle", ankle, (0.0, 1.0, 0.0), p + "knee"),
        ]
    return joints


def _links(with_fins: bool) -> dict[str, str]:
    """Link name -> the joint that moves it (the last joint of its chain)."""
    links = {"pelvis": "posture", "torso": "waist", "tank": "waist", "head": "neck_rot"}
    for side in SIDES:
        p = f"{side}_"
        links |= {p + "upper_arm": p + "shoulder_rot", p + "forearm": p + "elbow",
                  p + "hand": p + "wrist", p + "fingers": p + "fingers",
                  p + "thigh": p + "hip_abd", p + "shank": p + "knee", p + "foot": p + "ankle"}
        if with_fins:
            links[p + "fin"] = p + "ankle"
    return links


def _rodrigues(axes: NDArray[np.float64], angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """(J, 3, 3) rotations by ``angles`` (J,) about unit ``axes`` (J, 3)."""
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    c, s = np.cos(angles), np.sin(angles)
    k = 1.0 - c
    return np.stack([
        np.stack([c + k * x * x, k * x * y - s * z, k * x * z + s * y], axis=-1),
        np.stack([k * x * y + s * z, c + k * y * y, k * y * z - s * x], axis=-1),
        np.stack([k * x * z - s * y, k * y * z + s * x, c + k * z * z], axis=-1),
    ], axis=1)


@dataclass(frozen=True)
class DiverSkeleton:
    """The joints and links of one diver (module docstring). Immutable; state is ``q``.

    ``q`` is a (J,) array of joint angles (radians) in the order of :attr:`joint_names`;
    ``kind`` "scuba" has fins on the feet, "boots" (the commercial diver) has none.
    """

    body: Anthropometry = field(default_factory=Anthropometry)
    kind: Literal["scuba", "boots"] = "scuba"
    rom_factor: float = DRY_SUIT_ROM_FACTOR
    joints: tuple[JointSpec, ...] = field(init=False)
    links: Mapping[str, str] = field(init=False)
    _index: Mapping[str, int] = field(init=False, repr=False)
    _parents: NDArray[np.int64] = field(init=False, repr=False)
    _tables: Mapping[str, NDArray[np.float64]] = field(init=False, repr=False)
    #: the last :meth:`joint_transforms` (its q's bytes, the read-only result): a tick
    #: asks for the same pose several times (both hands, the reach, the acts)
    _last: list[tuple[bytes, NDArray[np.float64]]] = field(
        init=False, repr=False, compare=False, default_factory=list)
    #: each joint's transform (:meth:`transform_of`) for the angles of its chain (their
    #: bytes): a hand's frame does not change with the legs' kick or stride
    _by_joint: dict[int, tuple[bytes, NDArray[np.float64]]] = field(
        init=False, repr=False, compare=False, default_factory=dict)
    _chains: tuple[NDArray[np.intp], ...] = field(init=False, repr=False, compare=False)
    #: each hand's last frame in NED (:meth:`hand_frame_ned`): (the bytes of its wrist
    #: chain's angles and of the body pose, the read-only frame)
    _hands_ned: dict[str, tuple[bytes, NDArray[np.float64]]] = field(
        init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in ("scuba", "boots"):
            raise ConfigError(f"must be 'scuba' or 'boots', got {self.kind!r}",
                              where="DiverSkeleton.kind")
        if not (math.isfinite(self.rom_factor) and 0.3 <= self.rom_factor <= 1.0):
            raise ConfigError(f"must be in [0.3, 1], got {self.rom_factor!r}",
                              where="DiverSkeleton.rom_factor")
        joints = tuple(_joints(self.body, self.rom_factor))
        index = {j.name: i for i, j in enumerate(joints)}
        parents = np.array([-1 if j.parent is None else index[j.parent] for j in joints])
        assert all(p < i for i, p in enumerate(parents))  # parents come first
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "links", _links(self.kind == "scuba"))
        object.__setattr__(self, "_index", index)
        object.__setattr__(self, "_parents", parents)
        tables = {"axes": np.array([j.axis for j in joints]),
                  "pivots": np.array([j.pivot for j in joints]),
                  "lower": np.array([j.lower for j in joints]),
                  "upper": np.array([j.upper for j in joints]),
                  "max_speed": np.array([j.max_speed for j in joints])}
        for table in tables.values():
            table.setflags(write=False)
        object.__setattr__(self, "_tables", tables)
        object.__setattr__(self, "_chains", tuple(np.array(self.chain(j.name), dtype=np.intp)
                                                  for j in joints))

    # ------------------------------------------------------------------ tables
    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def lower(self) -> NDArray[np.float64]:
        """(J,) lower limits (rad, read-only)."""
        return self._tables["lower"]

    @property
    def upper(self) -> NDArray[np.float64]:
        """(J,) upper limits (rad, read-only)."""
        return self._tables["upper"]

    @property
    def max_speed(self) -> NDArray[np.float64]:
        """(J,) maximum speeds (rad/s, read-only)."""
        return self._tables["max_speed"]

    def index(self, joint: str) -> int:
        """Position of ``joint`` in ``q``; ConfigError naming the joints otherwise."""
        try:
            return self._index[joint]
        except KeyError:
            raise ConfigError(f"no joint {joint!r} (have {', '.join(self._index)})",
                              where="DiverSkeleton") from None

    def chain(self, joint: str) -> tuple[int, ...]:
        """Indices of the joints from the root to ``joint`` (inclusive)."""
        out = []
        i = self.index(joint)
        while i >= 0:
            out.append(i)
            i = int(self._parents[i])
        return tuple(reversed(out))

    def arm_joints(self, side: Side) -> tuple[int, ...]:
        """Indices of one arm's joints, shoulder to fingers."""
        return tuple(self.index(f"{side}_{k}") for k in
                     ("shoulder_flex", "shoulder_abd", "shoulder_rot", "elbow", "wrist",
                      "fingers"))

    def zeros(self) -> NDArray[np.float64]:
        """The zero configuration (standing, anatomical position)."""
        return np.zeros(self.n_joints)

    def vector(self, angles: Mapping[str, float], base: ArrayLike | None = None
               ) -> NDArray[np.float64]:
        """``q`` from joint name -> angle (rad), the rest from ``base`` (default zeros)."""
        q = self.zeros() if base is None else np.array(base, dtype=float)
        for name, value in angles.items():
            q[self.index(name)] = float(value)
        return q

    def clip(self, q: ArrayLike) -> NDArray[np.float64]:
        """``q`` clipped into the joint limits."""
        return np.clip(np.asarray(q, dtype=float), self.lower, self.upper)

    def limit_violations(self, q: ArrayLike, tol: float = 1e-9) -> list[str]:
        """Joints of ``q`` outside their limits, as 'name: angle° not in [lo°, hi°]'."""
        q = np.asarray(q, dtype=float)
        out = []
        for j, a in zip(self.joints, q, strict=True):
            if not (j.lower - tol <= a <= j.upper + tol):
                out.append(f"{j.name}: {math.degrees(a):.1f}° not in "
                           f"[{math.degrees(j.lower):.1f}°, {math.degrees(j.upper):.1f}°]")
        return out

    # ------------------------------------------------------------------ kinematics
    def joint_transforms(self, q: ArrayLike) -> NDArray[np.float64]:
        """(J, 4, 4) product of exponentials up to and including each joint: the
        rest→posed body-frame transform of everything that joint moves."""
        q = self._checked(q)
        key = q.tobytes()
        if self._last and self._last[0][0] == key:
            return self._last[0][1]
        axes, pivots = self._tables["axes"], self._tables["pivots"]
        rot = _rodrigues(axes, q)
        local = np.zeros((self.n_joints, 4, 4))
        local[:, :3, :3] = rot
        local[:, :3, 3] = pivots - np.einsum("jab,jb->ja", rot, pivots)
        local[:, 3, 3] = 1.0
        out = np.empty_like(local)
        for i, parent in enumerate(self._parents):
            out[i] = local[i] if parent < 0 else out[parent] @ local[i]
        out.setflags(write=False)
        self._last[:] = [(key, out)]
        return out

    def _checked(self, q: ArrayLike) -> NDArray[np.float64]:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ConfigError(f"q must have shape ({self.n_joints},), got {q.shape}",
                              where="DiverSkeleton.joint_transforms")
        return q

    def transform_of(self, q: ArrayLike, joint: int) -> NDArray[np.float64]:
        """``joint_transforms(q)[joint]`` (read-only), kept for the angles of the joint's
        chain, the only ones it depends on (the same values: worked out by
        :meth:`joint_transforms` on a ``q`` with those angles)."""
        q = self._checked(q)
        key = q[self._chains[joint]].tobytes()
        last = self._by_joint.get(joint)
        if last is not None and last[0] == key:
            return last[1]
        t = self.joint_transforms(q)[joint]
        self._by_joint[joint] = (key, t)
        return t

    def link_transforms(self, q: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Link name -> its 4x4 rest→posed transform (body frame)."""
        t = self.joint_transforms(q)
        return {link: t[self.index(joint)] for link, joint in self.links.items()}

    def grip_point_rest(self, side: Side) -> NDArray[np.float64]:
        """Grip point of a hand (palm centre) at q = 0, body frame (m)."""
        j = self.joints[self.index(f"{side}_wrist")]
        return np.array(j.pivot) + np.array([0.0, 0.0, GRIP_FRACTION_OF_HAND * self.body.hand])

    def grip_point(self, q: ArrayLike, side: Side) -> NDArray[np.float64]:
        """Posed grip point of a hand, body frame (m)."""
        t = self.transform_of(q, self.index(f"{side}_wrist"))
        return t[:3, :3] @ self.grip_point_rest(side) + t[:3, 3]

    def hand_frame(self, q: ArrayLike, side: Side) -> NDArray[np.float64]:
        """4x4 pose of a hand in the body frame: origin at the grip point, z along the
        fingers, x out of the palm (at q = 0: z down, x forward)."""
        t = self.transform_of(q, self.index(f"{side}_wrist")).copy()
        t[:3, 3] = t[:3, :3] @ self.grip_point_rest(side) + t[:3, 3]
        return t

    def hand_frame_ned(self, q: ArrayLike, side: Side, body_pose: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
        """``body_pose @ hand_frame(q, side)`` (read-only): the hand's frame in NED for the
        body pose (4x4 body→NED), kept for the same angles of its arm and the same body
        pose (the very array again: what the hand carries is kept then too)."""
        q = self._checked(q)
        wrist = self.index(f"{side}_wrist")
        key = q[self._chains[wrist]].tobytes() + np.asarray(body_pose, dtype=float).tobytes()
        last = self._hands_ned.get(side)
        if last is not None and last[0] == key:
            return last[1]
        frame = body_pose @ self.hand_frame(q, side)
        frame.setflags(write=False)
        self._hands_ned[side] = (key, frame)
        return frame

    def grip_closure(self, q: ArrayLike, side: Side) -> float:
        """How closed a hand is: 0 open, 1 at the fingers' upper limit."""
        i = self.index(f"{side}_fingers")
        return float(np.asarray(q, dtype=float)[i] / self.joints[i].upper)

    def shoulder(self, q: ArrayLike, side: Side) -> NDArray[np.float64]:
        """Posed shoulder centre, body frame (m)."""
        j = self.joints[self.index(f"{side}_shoulder_flex")]
        t = self.transform_of(q, self.index("waist"))
        return t[:3, :3] @ np.array(j.pivot) + t[:3, 3]

    @property
    def arm_reach(self) -> float:
        """Shoulder to grip point with the elbow straight (m)."""
        return self.body.upper_arm + self.body.forearm + GRIP_FRACTION_OF_HAND * self.body.hand


# ---------------------------------------------------------------------------- poses

#: Named poses, degrees. ``stand`` and ``swim`` are whole-body (every joint not named is
#: 0); the others pose the arms only (``{s}``: the working side, ``{o}``: the other) and
#: keep the posture and legs. Each is held inside the limits by a test.
NAMED_POSES: dict[str, dict[str, float]] = {
    "stand": {"{s}_elbow": 10.0, "{o}_elbow": 10.0},
    "swim": {"posture": 90.0, "neck_flex": -30.0, "{s}_shoulder_flex": 10.0,
             "{o}_shoulder_flex": 10.0, "{s}_elbow": 60.0, "{o}_elbow": 60.0,
             "{s}_shoulder_rot": 50.0, "{o}_shoulder_rot": 50.0,
             "left_ankle": -35.0, "right_ankle": -35.0},
    "reach": {"{s}_shoulder_flex": 80.0, "{s}_elbow": 10.0, "{s}_fingers": 0.0,
              "{o}_shoulder_flex": 0.0, "{o}_elbow": 20.0},
    "hold": {"{s}_shoulder_flex": 35.0, "{s}_elbow": 90.0, "{s}_shoulder_rot": 20.0,
             "{s}_fingers": 72.0, "{o}_shoulder_flex": 35.0, "{o}_elbow": 90.0,
             "{o}_shoulder_rot": 20.0},
    "work": {"{s}_shoulder_flex": 55.0, "{s}_elbow": 70.0, "{s}_wrist": 10.0,
             "{s}_fingers": 72.0, "{o}_shoulder_flex": 45.0, "{o}_elbow": 80.0,
             "{o}_shoulder_rot": 30.0},
    "signal_ready": {"{s}_shoulder_flex": 60.0, "{s}_shoulder_abd": 20.0, "{s}_elbow": 110.0,
                     "{s}_fingers": 0.0, "{o}_shoulder_flex": 0.0, "{o}_elbow": 15.0},
}
WHOLE_BODY_POSES = frozenset({"stand", "swim"})


def pose_goal(skeleton: DiverSkeleton, name: str, q_now: ArrayLike | None = None,
              side: Side = "right") -> NDArray[np.float64]:
    """The joint goal of pose ``name`` (:data:`NAMED_POSES`), working hand ``side``.

    Arm poses keep the posture, neck and legs of ``q_now``; whole-body poses set every
    joint. ConfigError for an unknown pose or side.
    """
    if name not in NAMED_POSES:
        raise ConfigError(f"unknown pose {name!r} (have {', '.join(NAMED_POSES)})",
                          where="pose_goal")
    if side not in SIDES:
        raise ConfigError(f"side must be 'left' or 'right', got {side!r}", where="pose_goal")
    other = "left" if side == "right" else "right"
    whole = name in WHOLE_BODY_POSES or q_now is None
    base = skeleton.zeros() if whole else np.array(q_now, dtype=float)
    if not whole:
        for s in SIDES:
            for i in skeleton.arm_joints(s):
                base[i] = 0.0
    angles = {k.format(s=side, o=other): math.radians(v) for k, v in NAMED_POSES[name].items()}
    return skeleton.vector(angles, base)


# ---------------------------------------------------------------------------- motion

#: Time (s) to reach a joint's top speed from rest (assumed: smooth, deliberate motion).
ACCELERATION_TIME_S = 0.25


def step_motion(skeleton: DiverSkeleton, q: ArrayLike, qdot: ArrayLike, goal: ArrayLike,
                dt: float, compiled: bool = True
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One step ``dt`` (s) of rate-limited, smooth motion of ``q`` towards ``goal``.

    All joints move on one trapezoidal speed profile so that they arrive together (a
    straight line in joint space): the slowest joint (largest distance over maximum speed)
    cruises at its maximum speed, every other at the speed that covers its distance in
    the same time; each speeds up over ``ACCELERATION_TIME_S`` and brakes on the
    discrete-time curve of ``v = sqrt(2 a |error|)`` so it stops at the goal. Slowing
    down (or turning round when the goal changes) may use the full
    ``max_speed / ACCELERATION_TIME_S``. The goal
    is clipped into the limits first. Returns ``(q, qdot)``; never exceeds a limit or a
    maximum speed. Pure. With numba installed and ``compiled``, one compiled loop over the
    joints (:func:`_step_motion_joints`, the same numbers bit for bit; the numpy path is
    its reference, ``UHRISIM_NUMBA=0``).
    """
    if not (math.isfinite(dt) and dt > 0.0):
        raise ConfigError(f"dt must be a finite number > 0, got {dt!r}", where="step_motion")
    q = np.asarray(q, dtype=float)
    v = np.asarray(qdot, dtype=float)
    kernel = _compiled_step_motion() if compiled else None
    if kernel is not None:
        new_q, new_v = np.empty_like(q), np.empty_like(q)
        kernel(np.ascontiguousarray(q), np.ascontiguousarray(v),
               np.ascontiguousarray(goal, dtype=float), skeleton.lower, skeleton.upper,
               skeleton.max_speed, dt, ACCELERATION_TIME_S, new_q, new_v)
        return new_q, new_v
    vmax = skeleton.max_speed
    error = skeleton.clip(goal) - q
    if not (error.any() or v.any()):  # still, on the goal: stays (the common case)
        return q.copy(), v.copy()
    distance = np.abs(error)
    slowest = float((distance / vmax).max())
    cruise = np.minimum(distance / slowest, vmax) if slowest > 0.0 else np.zeros_like(vmax)
    accel = cruise / ACCELERATION_TIME_S  # the shared profile, scaled per joint
    # the fastest speed from which braking at ``accel`` in steps of dt stops on the goal
    brake = accel * (np.sqrt(0.25 * dt * dt + 2.0 * distance / np.maximum(accel, 1e-300))
                     - 0.5 * dt)
    desired = np.sign(error) * np.minimum(cruise, brake)
    speeding_up = (np.abs(desired) > np.abs(v)) & (desired * v >= 0.0)
    limit = np.where(speeding_up, accel, vmax / ACCELERATION_TIME_S) * dt
    v = v + np.clip(desired - v, -limit, limit)
    v = np.where(np.abs(v) * dt > distance, error / dt, v)  # land on the goal, not past it
    new_q = skeleton.clip(q + np.clip(v, -vmax, vmax) * dt)
    return new_q, (new_q - q) / dt


def _step_motion_joints(q, v, goal, lower, upper, vmax, dt, acceleration_time,  # type: ignore[no-untyped-def]
                        new_q, new_v):
    """:func:`step_motion`'s numpy path joint by joint (compiled by numba), into ``new_q``
    and ``new_v``: its operations in its order, and numpy's choices between equal values
    (``np.maximum``/``np.minimum``/``np.clip`` of arrays keep the second of two equal
    zeros; ``np.sign`` of a zero is +0)."""
    n = q.shape[0]
    error = np.empty(n)
    still = True
    for j in range(n):
        g = goal[j] if goal[j] > lower[j] else lower[j]  # the goal clipped into the limits
        g = g if g < upper[j] else upper[j]
        error[j] = g - q[j]
        if error[j] != 0.0 or v[j] != 0.0:
            still = False
    if still:  # still, on the goal: stays
        for j in range(n):
            new_q[j], new_v[j] = q[j], v[j]
        return
    slowest = 0.0
    for j in range(n):
        ratio = abs(error[j]) / vmax[j]
        if j == 0 or ratio > slowest or ratio != ratio:
            slowest = ratio
    half_dt2 = 0.25 * dt * dt
    for j in range(n):
        distance = abs(error[j])
        if slowest > 0.0:
            cruise = distance / slowest
            cruise = cruise if cruise < vmax[j] else vmax[j]
        else:
            cruise = 0.0
        accel = cruise / acceleration_time
        floor = accel if accel > 1e-300 else 1e-300
        brake = accel * (math.sqrt(half_dt2 + 2.0 * distance / floor) - 0.5 * dt)
        sign = 1.0 if error[j] > 0.0 else (-1.0 if error[j] < 0.0 else 0.0 * error[j] + 0.0)
        desired = sign * (cruise if cruise < brake else brake)
        speeding_up = abs(desired) > abs(v[j]) and desired * v[j] >= 0.0
        limit = (accel if speeding_up else vmax[j] / acceleration_time) * dt
        change = desired - v[j]
        change = change if change > -limit else -limit
        change = change if change < limit else limit
        speed = v[j] + change
        if abs(speed) * dt > distance:  # land on the goal, not past it
            speed = error[j] / dt
        speed_capped = speed if speed > -vmax[j] else -vmax[j]
        speed_capped = speed_capped if speed_capped < vmax[j] else vmax[j]
        moved = q[j] + speed_capped * dt
        moved = moved if moved > lower[j] else lower[j]
        moved = moved if moved < upper[j] else upper[j]
        new_q[j] = moved
        new_v[j] = (moved - q[j]) / dt


@cache
def _compiled_step_motion() -> Any:
    """:func:`_step_motion_joints` compiled; None without numba."""
    return jit(_step_motion_joints, numpy_errors=True)


# ---------------------------------------------------------------------------- reach

#: Swivel (humeral rotation) samples the reach solver tries.
_SWIVEL_SAMPLES = 61


@dataclass(frozen=True)
class ReachSolution:
    """Result of :func:`solve_reach`: ``q`` (the whole configuration with the arm set,
    or None) and, when the point cannot be reached, why."""

    q: NDArray[np.float64] | None
    reason: str = ""

    @property
    def ok(self) -> bool:
        return self.q is not None


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _solve_arm(skeleton: DiverSkeleton, side: Side, target: NDArray[np.float64],
               q_now: NDArray[np.float64]) -> ReachSolution:
    """Arm-only reach (see :func:`solve_reach`)."""
    trunk = skeleton.transform_of(q_now, skeleton.index("waist"))
    shoulder = np.array(skeleton.joints[skeleton.index(f"{side}_shoulder_flex")].pivot)
    # the target in the arm's rest frame (undo posture and waist), relative to the shoulder
    t = trunk[:3, :3].T @ (target - trunk[:3, 3]) - shoulder
    d = float(np.linalg.norm(t))
    a = skeleton.body.upper_arm
    b = skeleton.body.forearm + GRIP_FRACTION_OF_HAND * skeleton.body.hand
    flex_i, abd_i, rot_i, elbow_i, wrist_i, _ = skeleton.arm_joints(side)
    elbow_spec = skeleton.joints[elbow_i]
    if d > a + b - 1e-9:
        return ReachSolution(None, f"out of reach: {d:.2f} m from the {side} shoulder, "
                                   f"the arm reaches {a + b:.2f} m")
    elbow = math.acos(max(-1.0, min(1.0, (d * d - a * a - b * b) / (2.0 * a * b))))
    if elbow > elbow_spec.upper:
        return ReachSolution(None, f"too close to the {side} shoulder ({d:.2f} m): the "
                                   f"elbow would bend {math.degrees(elbow):.0f}°, limit "
                                   f"{math.degrees(elbow_spec.upper):.0f}°")
    sigma = -1.0 if side == "right" else 1.0  # abduction axis is (sigma, 0, 0)
    rot_spec = skeleton.joints[rot_i]
    swivel = np.linspace(rot_spec.lower, rot_spec.upper, _SWIVEL_SAMPLES)
    # forearm+hand vector after elbow flexion, then humeral rotation about (0, 0, sigma)
    c, s = np.cos(sigma * swivel), np.sin(sigma * swivel)
    fx, fz = b * math.sin(elbow), a + b * math.cos(elbow)
    vx, vy, vz = fx * c, fx * s, np.full_like(swivel, fz)
    rho = np.hypot(vy, vz)
    ratio = t[1] / np.maximum(rho, 1e-12)
    feasible = np.abs(ratio) <= 1.0
    delta = np.arctan2(vz, vy)
    q_best, cost_best = None, math.inf
    for branch in (1.0, -1.0):
        beta = branch * np.arccos(np.clip(ratio, -1.0, 1.0)) - delta  # abduction about x
        cb, sb = np.cos(beta), np.sin(beta)
        wx, wz = vx, vy * sb + vz * cb  # R_x(beta) v: x unchanged, z = y sin + z cos
        flex = _wrap(np.arctan2(t[0], t[2]) - np.arctan2(wx, wz))
        abd = _wrap(sigma * beta)
        candidates = np.stack([flex, abd, swivel], axis=1)
        lo = skeleton.lower[[flex_i, abd_i, rot_i]]
        hi = skeleton.upper[[flex_i, abd_i, rot_i]]
        ok = feasible & np.all((candidates >= lo - 1e-12) & (candidates <= hi + 1e-12), axis=1)
        if not ok.any():
            continue
        current = q_now[[flex_i, abd_i, rot_i]]
        cost = np.where(ok, np.sum((candidates - current) ** 2, axis=1), np.inf)
        k = int(np.argmin(cost))
        if cost[k] < cost_best:
            cost_best = float(cost[k])
            q_best = q_now.copy()
            q_best[[flex_i, abd_i, rot_i]] = np.clip(candidates[k], lo, hi)
            q_best[elbow_i] = elbow
            q_best[wrist_i] = 0.0
    if q_best is None:
        return ReachSolution(None, f"out of reach: no {side} arm posture within the dry-suit "
                                   "limits puts the hand there")
    error = float(np.linalg.norm(skeleton.grip_point(q_best, side) - target))
    if error > 1e-6:  # the closed form is exact; this guards the algebra
        return ReachSolution(None, f"reach solver missed by {error:.2e} m")
    return ReachSolution(q_best)


#: Waist and posture (the pelvis's forward tilt) angles the reach solver tries when
#: ``bend`` is allowed.
_WAIST_SAMPLES = 15
_TILT_SAMPLES = 7


def solve_reach(skeleton: DiverSkeleton, side: Side, target_body: ArrayLike,
                q_now: ArrayLike, bend: bool = False, max_tilt: float | None = None
                ) -> ReachSolution:
    """Joint angles that put hand ``side``'s grip point on ``target_body`` (body frame, m).

    Analytic: the elbow angle follows from the shoulder-to-target distance (law of
    cosines); for each humeral rotation (the arm's swivel, sampled over its range) the
    shoulder flexion and abduction follow in closed form (two branches). The wrist is set
    straight; posture, neck, legs and the other arm stay as in ``q_now``. Among the
    solutions inside every limit the one nearest ``q_now`` is returned; checked by forward
    kinematics to 1 µm. With ``bend``, when the arm alone cannot, the diver also bends
    (or straightens) at the waist — the smallest change of the waist angle that works —
    and, if that is not enough, tilts its pelvis too (``posture``: bending over from the
    hips, as one reaches for the floor; legs on the floor are re-solved by their own
    inverse kinematics; ``max_tilt`` (rad) caps the tilt, e.g. at what the hips' flexion
    leaves). Position only: the hand's orientation is not solved.
    """
    q_now = np.asarray(q_now, dtype=float)
    if side not in SIDES:
        raise ConfigError(f"side must be 'left' or 'right', got {side!r}", where="solve_reach")
    target = np.asarray(target_body, dtype=float).reshape(3)
    solution = _solve_arm(skeleton, side, target, q_now)
    if solution.ok or not bend:
        return solution
    i, j = skeleton.index("waist"), skeleton.index("posture")
    waists = sorted(np.linspace(skeleton.lower[i], skeleton.upper[i], _WAIST_SAMPLES),
                    key=lambda w: abs(w - q_now[i]))
    top = skeleton.upper[j] if max_tilt is None else min(skeleton.upper[j], max_tilt)
    tilts = sorted(np.linspace(skeleton.lower[j], top, _TILT_SAMPLES),
                   key=lambda p: abs(p - q_now[j]))
    for tilt in [q_now[j], *tilts]:
        for waist in waists:
            bent = _solve_arm(skeleton, side, target,
                              skeleton.vector({"waist": waist, "posture": tilt}, q_now))
            if bent.ok:
                return bent
    return ReachSolution(None, solution.reason + " (even bending over)")


def can_reach(skeleton: DiverSkeleton, side: Side, target_body: ArrayLike,
              q_now: ArrayLike, bend: bool = False) -> bool:
    """Whether hand ``side`` can put its grip point on ``target_body`` (the reach
    envelope, with posture and legs as in ``q_now``; ``bend``: at the waist too)."""
    return solve_reach(skeleton, side, target_body, q_now, bend).ok
