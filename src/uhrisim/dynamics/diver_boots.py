"""The commercial diver on weighted boots: walks on the sea floor, rises only on buoyancy.

The paper's next diver model: a surface-supplied diver, heavily weighted, who walks on
the bottom. Kinematic gait on the floor, free-body physics in the water:

* **On the floor** (net buoyancy ≤ 0) the diver walks: heading turns at most
  ``max_turn_rate``; speed follows the command at most ``max_speed`` with
  ``acceleration``; a **gait phase** advances at the stride frequency ``speed /
  stride_length`` and moves the legs: each foot is in stance half of the cycle (fixed on
  the floor while the body passes over it) and swings forward the other half, lifted by
  up to ``swing_clearance``. Both feet are placed **on the floor** (its depth under each
  sole, so the body follows the slope): the hip centre sits as high as the lower foot
  allows with the knee at ``knee_reach`` of the straight leg, and each leg's hip and
  knee come from planar two-link inverse kinematics, the ankle keeping the sole parallel
  to the floor. Walking up or down a slope steeper than ``max_slope`` stops the diver.
  To work low (a tool basket on the floor) the diver **crouches**: the legs keep less
  extension, down to the knee's flexion limit, at ``crouch_rate`` (full depth in 2 s);
  a crouching diver does not walk.
* **Buoyancy**: the diver is ``in_water_weight`` heavier than the water it displaces.
  The only way up is gas in the suit (``inflate``: the command's ``suit``); that gas
  follows Boyle's law with depth. When its lift exceeds the weight the diver leaves the
  floor and moves as a free body (:mod:`uhrisim.dynamics.free_body`: drag, added mass;
  a rising diver's gas swells, the blow-up hazard of dry-suit diving) until dumping gas
  (``suit = -1``) brings it down again.

Numbers (assumed where stated):

* walking speed: people walk in water at about a third to a half of their land speed
  (self-selected speed much slower in water: Heywood et al., Gait & Posture 48:120-130,
  2016, a systematic review; Barela, Stolf & Duarte, J. Electromyogr. Kinesiol.
  16:250-256, 2006); a hard-hat diver in heavy gear on the bottom moves slower still:
  ``cruise_speed`` 0.3 m/s, ``max_speed`` 0.5 m/s (assumed within that range);
* stride: stride frequency is lower in water than on land (Kato, Onishi & Kitagawa,
  *Kinematical analysis of underwater walking and running*, Sports Med. Train. Rehabil.
  10:165-182, 2001): stride length 0.7 m (0.43 Hz at 0.3 m/s), swing clearance 8 cm
  (assumed);
* turning on the spot 20°/s; the steepest walkable slope 0.3 (17°) (assumed);
* in-water weight 10 kgf (98 N) — commercial divers weight themselves heavily for
  bottom work (assumed); mass in air 110 kg (diver and gear); suit inflation 1 surface
  litre a second, dump 2 L/s (assumed); a standing diver drags vertically with C_d 1.0 on
  0.15 m² and the added mass of its displaced water (C_a = 1).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.core.checks import require_positive
from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import vector_length
from uhrisim.dynamics import free_body as fb
from uhrisim.dynamics.diver_body import SIDES, DiverSkeleton, Side

#: The sea floor: depth (m, down) at (north, east) (e.g. ``SeaFloor.depth_at``).
FloorDepth = Callable[[float, float], float]


@dataclass(frozen=True)
class BootsParams:
    """The weighted-boots diver's gait and buoyancy (module docstring)."""

    skeleton: DiverSkeleton = field(default_factory=lambda: DiverSkeleton(kind="boots"))
    cruise_speed: float = 0.3
    max_speed: float = 0.5
    acceleration: float = 0.3
    max_turn_rate: float = math.radians(20.0)
    stride_length: float = 0.7
    swing_clearance: float = 0.08
    max_slope: float = 0.3
    knee_reach: float = 0.97
    crouch_rate: float = 0.5
    in_water_weight: float = 10.0 * fb.GRAVITY
    mass: float = 110.0
    vertical_drag_area: float = 0.15
    inflate_lps: float = 1.0
    dump_lps: float = 2.0
    max_suit_litres: float = 30.0

    def __post_init__(self) -> None:
        require_positive(self, ("cruise_speed", "max_speed", "acceleration", "max_turn_rate",
                                "stride_length", "swing_clearance", "max_slope",
                                "in_water_weight", "mass", "vertical_drag_area", "inflate_lps",
                                "dump_lps", "max_suit_litres", "crouch_rate"), "BootsParams")
        if self.cruise_speed > self.max_speed:
            raise ConfigError("cruise_speed must not exceed max_speed", where="BootsParams")
        if not 0.8 <= self.knee_reach < 1.0:
            raise ConfigError(f"must be in [0.8, 1), got {self.knee_reach}",
                              where="BootsParams.knee_reach")

    @cached_property
    def hydro(self) -> fb.Hydro:
        """The diver as a free body; its reference point is the hip centre, the soles a
        standing hip height below it (worked out once: asked every step)."""
        volume = self.mass / fb.WATER_DENSITY - self.in_water_weight / (fb.WATER_DENSITY *
                                                                         fb.GRAVITY)
        return fb.Hydro(self.mass, volume, 1.0, self.vertical_drag_area, 1.0,
                        self.skeleton.body.hip_height)

    @cached_property
    def hip_lateral(self) -> dict[Side, float]:
        """How far (m) each hip joint lies to starboard of the hip centre (worked out once:
        asked several times a step)."""
        sk = self.skeleton
        return {side: sk.joints[sk.index(f"{side}_hip_flex")].pivot[1] for side in SIDES}

    @cached_property
    def leg_reach_span(self) -> tuple[float, float]:
        """Hip-to-ankle distance (m) the legs keep standing and at the deepest crouch (the
        knee's flexion limit less 5°), for :func:`leg_reach` (worked out once)."""
        sk = self.skeleton
        thigh, shank = sk.body.thigh, sk.body.shank
        knee = sk.upper[sk.index("left_knee")] - math.radians(5.0)
        deepest = math.sqrt(thigh ** 2 + shank ** 2 + 2.0 * thigh * shank * math.cos(knee))
        return self.knee_reach * (thigh + shank), deepest


@dataclass(frozen=True)
class BootsState:
    """Hip centre (NED m), heading (rad), walking speed (m/s), gait phase (rad), extra
    suit gas (surface litres), velocity in the water (NED m/s, afloat only), afloat, and
    how deep it crouches (0 standing, 1 the deepest its knees allow)."""

    position: tuple[float, float, float]
    psi: float = 0.0
    speed: float = 0.0
    phase: float = 0.0
    suit_litres: float = 0.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    afloat: bool = False
    crouch: float = 0.0


class BootsCommand(NamedTuple):
    """Desired walking speed (m/s), turn rate (rad/s, > 0 to starboard), suit valve
    (+1 inflate, 0 hold, -1 dump) and crouch (0 stand .. 1 deepest; a crouching diver
    does not walk)."""

    speed: float = 0.0
    turn_rate: float = 0.0
    suit: Literal[-1, 0, 1] = 0
    crouch: float = 0.0


class Footfall(NamedTuple):
    """A foot set down: which, where (NED m, the sole), when (s into the step)."""

    side: Side
    position: NDArray[np.float64]


class BootsStep(NamedTuple):
    state: BootsState
    footfalls: list[Footfall]
    notes: list[str]  # "lift_off", "landed", "too_steep: ..."


def _heading(psi: float) -> NDArray[np.float64]:
    return np.array([math.cos(psi), math.sin(psi)])


def foot_offsets(state: BootsState, params: BootsParams) -> dict[Side, tuple[float, float]]:
    """Each foot's (forward offset from the hip centre (m), lift above the floor (m))
    at the gait phase: the left foot's cycle starts at phase 0, the right's at pi; stance
    for the first half (the foot slides back relative to the body from +S/4 to -S/4),
    swing for the second (forward again, lifted on a half sine)."""
    quarter = 0.25 * params.stride_length
    out = {}
    for side, offset in (("left", 0.0), ("right", math.pi)):
        u = ((state.phase + offset) % (2.0 * math.pi)) / (2.0 * math.pi)
        if u < 0.5:
            out[side] = (quarter * (1.0 - 4.0 * u), 0.0)
        else:
            s = (u - 0.5) * 2.0
            out[side] = (quarter * (-1.0 + 2.0 * s), params.swing_clearance * math.sin(math.pi * s))
    return out


def sole_targets(state: BootsState, params: BootsParams, floor_depth: FloorDepth
                 ) -> dict[Side, NDArray[np.float64]]:
    """NED target of each sole (under the ankle): on the floor, or lifted in swing."""
    h0, h1 = math.cos(state.psi), math.sin(state.psi)  # the heading; across: (-h1, h0)
    north, east = state.position[0], state.position[1]
    out = {}
    for side, (forward, lift) in foot_offsets(state, params).items():
        lateral = params.hip_lateral[side]
        x = north + forward * h0 + lateral * -h1  # (in numpy's order of operations)
        y = east + forward * h1 + lateral * h0
        out[side] = np.array([x, y, float(floor_depth(x, y)) - lift])
    return out


def leg_reach(params: BootsParams, crouch: float) -> float:
    """Hip-to-ankle distance (m) the legs keep: ``knee_reach`` of the straight leg when
    standing, down to the knee's flexion limit (less 5°) at ``crouch`` = 1."""
    standing, deepest = params.leg_reach_span
    return standing + (deepest - standing) * min(max(crouch, 0.0), 1.0)


def standing_hip_depth(state: BootsState, params: BootsParams, floor_depth: FloorDepth) -> float:
    """Depth (m) of the hip centre with both ankles within :func:`leg_reach` (at the
    state's crouch): as high as the lower foot allows."""
    reach = leg_reach(params, state.crouch)
    ankle_h = params.skeleton.body.ankle_height
    across = (-math.sin(state.psi), math.cos(state.psi))
    depth = -math.inf
    for side, sole in sole_targets(state, params, floor_depth).items():
        hip_y = params.hip_lateral[side]
        hip = (state.position[0] + hip_y * across[0], state.position[1] + hip_y * across[1])
        horizontal = vector_length(np.array([sole[0] - hip[0], sole[1] - hip[1]]))
        depth = max(depth, sole[2] - ankle_h - math.sqrt(reach * reach - horizontal ** 2))
    return depth


def floor_slope_ahead(state: BootsState, floor_depth: FloorDepth, probe: float = 0.2) -> float:
    """Rise of the floor per metre along the heading (> 0 uphill), from the depths
    ``probe`` m ahead and behind."""
    return _slope_ahead(state.position, state.psi, floor_depth, probe)


def _slope_ahead(position: tuple[float, ...], psi: float, floor_depth: FloorDepth,
                 probe: float = 0.2) -> float:
    """:func:`floor_slope_ahead` from ``position`` (NED m) along heading ``psi`` (rad)."""
    north, east = position[0], position[1]
    dn, de = probe * math.cos(psi), probe * math.sin(psi)
    ahead = float(floor_depth(north + dn, east + de))
    behind = float(floor_depth(north - dn, east - de))
    return (behind - ahead) / (2.0 * probe)


#: the joints :func:`leg_angles` sets (it reads only the pelvis's ``posture`` of ``q``)
LEG_JOINTS = tuple(f"{side}_{joint}" for side in ("left", "right")
                   for joint in ("hip_flex", "hip_abd", "knee", "ankle"))


def leg_angles(state: BootsState, params: BootsParams, floor_depth: FloorDepth, q: ArrayLike
               ) -> NDArray[np.float64]:
    """``q`` with both legs on their sole targets (module docstring): planar two-link IK
    for hip flexion and knee, hip abduction for the lateral offset, the ankle keeping the
    sole parallel to the floor's slope along the heading. The pelvis keeps the forward
    tilt it has in ``q`` (its ``posture`` angle, bending over to reach low: the hip joints
    lie on its axis, so the feet stay put and the hips flex the more). Clipped into the
    joint limits."""
    sk = params.skeleton
    out = np.array(q, dtype=float)
    tilt = float(out[sk.index("posture")])
    thigh, shank = sk.body.thigh, sk.body.shank
    c, s = math.cos(state.psi), math.sin(state.psi)
    to_body = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # NED -> body (yaw)
    ct, st = math.cos(tilt), math.sin(tilt)
    to_pelvis = np.array([[ct, 0.0, st], [0.0, 1.0, 0.0], [-st, 0.0, ct]])  # undo the tilt
    slope = math.atan(floor_slope_ahead(state, floor_depth))
    for side, sole in sole_targets(state, params, floor_depth).items():
        hip = np.array(sk.joints[sk.index(f"{side}_hip_flex")].pivot)
        ankle = to_body @ (sole - np.asarray(state.position)) - [0.0, 0.0, sk.body.ankle_height]
        v = to_pelvis @ ankle - hip
        d = min(vector_length(v), thigh + shank)
        knee = math.acos(max(-1.0, min(1.0, (d * d - thigh ** 2 - shank ** 2) /
                                       (2.0 * thigh * shank))))
        ux, uz = -shank * math.sin(knee), thigh + shank * math.cos(knee)
        sigma = -1.0 if side == "right" else 1.0  # abduction axis (sigma, 0, 0)
        beta = math.asin(max(-1.0, min(1.0, -v[1] / uz)))
        wz = uz * math.cos(beta)
        flex = math.atan2(v[0], v[2]) - math.atan2(ux, wz)
        p = f"{side}_"
        out[sk.index(p + "hip_flex")] = flex
        out[sk.index(p + "hip_abd")] = sigma * beta
        out[sk.index(p + "knee")] = knee
        out[sk.index(p + "ankle")] = slope + tilt - flex + knee
    return sk.clip(out)


def max_pelvis_tilt(params: BootsParams, q: ArrayLike, margin: float = math.radians(3.0)
                    ) -> float:
    """How far (rad) the diver may tilt its pelvis forward with its feet where they are:
    tilting adds to both hips' flexion, so what the more flexed hip leaves below its
    limit (less ``margin``)."""
    sk = params.skeleton
    q = np.asarray(q, dtype=float)
    tilt = q[sk.index("posture")]
    flex = max(q[sk.index(f"{side}_hip_flex")] for side in SIDES) - tilt
    return float(sk.upper[sk.index("left_hip_flex")] - flex - margin)


def sole_positions(state: BootsState, params: BootsParams, q: ArrayLike
                   ) -> dict[Side, NDArray[np.float64]]:
    """Where forward kinematics puts each sole (the point under the ankle), NED (m)."""
    sk = params.skeleton
    t = sk.joint_transforms(q)
    c, s = math.cos(state.psi), math.sin(state.psi)
    to_ned = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out = {}
    for side in SIDES:
        rest = np.array(sk.joints[sk.index(f"{side}_ankle")].pivot)
        rest[2] += sk.body.ankle_height
        m = t[sk.index(f"{side}_ankle")]
        out[side] = to_ned @ (m[:3, :3] @ rest + m[:3, 3]) + np.asarray(state.position)
    return out


def step(state: BootsState, command: BootsCommand, params: BootsParams, dt: float,
         floor_depth: FloorDepth) -> BootsStep:
    """Advance the walking diver by ``dt`` s. ``floor_depth(north, east)`` (m) is the
    sea floor. Pure: returns the new state, the footfalls (for silt) and notes."""
    if not (math.isfinite(dt) and dt > 0.0):
        raise ConfigError(f"dt must be a finite number > 0, got {dt!r}", where="diver_boots.step")
    notes: list[str] = []
    suit = state.suit_litres
    if command.suit > 0:
        suit = min(suit + params.inflate_lps * dt, params.max_suit_litres)
    elif command.suit < 0:
        suit = max(suit - params.dump_lps * dt, 0.0)
    hydro = params.hydro
    gas = fb.gas_volume(suit, state.position[2])
    if state.afloat or hydro.in_water_weight(gas) < 0.0:
        x = np.array([*state.position, *state.velocity])
        sole_floor = float(floor_depth(state.position[0], state.position[1]))
        if not state.afloat:
            notes.append("lift_off")
            h = _heading(state.psi)
            x[3:5] = state.speed * h
        x, where = fb.step(x, hydro, dt, sole_floor, gas)
        psi = state.psi + max(-params.max_turn_rate, min(params.max_turn_rate,
                                                         command.turn_rate)) * dt
        if where == "floor":
            notes.append("landed")
            new = BootsState(tuple(x[:3]), psi, 0.0, state.phase, suit, crouch=state.crouch)
            return BootsStep(replace(new, position=(x[0], x[1], standing_hip_depth(
                new, params, floor_depth))), [], notes)
        return BootsStep(BootsState(tuple(x[:3]), psi, 0.0, state.phase, suit,
                                    tuple(x[3:]), True, state.crouch), [], notes)
    # on the floor: crouch or stand up; turn, speed up or slow down, walk unless crouching
    # or the slope ahead is too steep
    step_crouch = params.crouch_rate * dt
    wanted = min(max(command.crouch, 0.0), 1.0)
    crouch = state.crouch + max(-step_crouch, min(step_crouch, wanted - state.crouch))
    psi = state.psi + max(-params.max_turn_rate, min(params.max_turn_rate,
                                                     command.turn_rate)) * dt
    target = max(0.0, min(params.max_speed, command.speed)) if crouch < 0.05 else 0.0
    dv = max(-params.acceleration * dt, min(params.acceleration * dt, target - state.speed))
    speed = state.speed + dv
    slope = _slope_ahead(state.position, psi, floor_depth)
    if speed > 0.0 and abs(slope) > params.max_slope:
        notes.append(f"too_steep: slope {slope:+.2f} ahead, limit {params.max_slope:.2f}")
        speed = 0.0
    stride = speed * dt
    north = state.position[0] + stride * math.cos(psi)
    east = state.position[1] + stride * math.sin(psi)
    phase = state.phase + 2.0 * math.pi * speed / params.stride_length * dt
    new = BootsState((north, east, state.position[2]), psi, speed, phase, suit, crouch=crouch)
    footfalls = footfalls_between(state.phase, new, params, floor_depth)
    depth = standing_hip_depth(new, params, floor_depth)
    return BootsStep(BootsState((north, east, depth), psi, speed, phase, suit, crouch=crouch),
                     footfalls, notes)


def footfalls_between(phase_before: float, state: BootsState, params: BootsParams,
                      floor_depth: FloorDepth) -> list[Footfall]:
    """The feet set down while the gait phase went from ``phase_before`` (rad) to
    ``state.phase``: a foot lands when its cycle wraps from swing into stance."""
    out = []
    for side, start in (("left", 0.0), ("right", math.pi)):
        before = math.floor((phase_before + start) / (2.0 * math.pi))
        after = math.floor((state.phase + start) / (2.0 * math.pi))
        if after > before:
            out.append(Footfall(side, sole_targets(state, params, floor_depth)[side]))
    return out
