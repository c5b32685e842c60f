"""Geometry the assistant decides with: separations from the diver, bearings, where the
ROV must be for its jaws to be at a point, and targets kept clear of the guards.

NED metres, compass degrees (docs/conventions.md). The ROV is taken level (a VideoRay is
passively stable in pitch and roll), so its body frame is its heading's rotation.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from uhrisim.assistant.config import AssistantConfig
from uhrisim.assistant.io import DiverTrack
from uhrisim.core.frames import rot_z, wrap_360


def bearing_deg(src: NDArray[np.float64], dst: NDArray[np.float64]) -> float:
    """Compass bearing (deg, [0, 360)) of the horizontal direction from ``src`` to ``dst``."""
    return float(wrap_360(math.degrees(math.atan2(dst[1] - src[1], dst[0] - src[0]))))


def horizontal(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit horizontal part of ``v`` (zero if it has none)."""
    h = np.array([v[0], v[1], 0.0])
    n = float(np.linalg.norm(h))
    return h / n if n > 0.0 else h


def segment_distance(p: NDArray[np.float64], a: NDArray[np.float64],
                     b: NDArray[np.float64]) -> float:
    """Distance (m) from point ``p`` to the segment from ``a`` to ``b``."""
    ab = b - a
    denom = float(ab @ ab)
    s = 0.0 if denom == 0.0 else min(max(float((p - a) @ ab) / denom, 0.0), 1.0)
    return float(np.linalg.norm(p - (a + s * ab)))


def separations(rov_position: NDArray[np.float64], diver: DiverTrack) -> tuple[float, float]:
    """(from the body segment, from the head) of the ROV's centre (m)."""
    return (segment_distance(rov_position, diver.position_ned, diver.neck),
            float(np.linalg.norm(rov_position - diver.head)))


def guard_slack(rov_position: NDArray[np.float64], diver: DiverTrack,
                config: AssistantConfig) -> float:
    """How far (m) the ROV's centre is beyond the nearer of its two guards (< 0: inside),
    for the diver as he is and as he would be upright: a diver rises from swimming or
    working (to signal, to wait, to take a tool) faster than the ROV gets out of his way
    — his head swings ~0.7 m in 2–3 s, the ROV from rest backs ~0.2 m in 2 s
    (docs/hri.md, "The guards") — so the guards keep the ROV clear of both."""
    return min(_slack(rov_position, d, config) for d in (diver, diver.upright()))


def _slack(rov_position: NDArray[np.float64], diver: DiverTrack,
           config: AssistantConfig) -> float:
    body, head = separations(rov_position, diver)
    return min(body - config.body_guard_m, head - config.head_guard_m)


def ahead_of(diver: DiverTrack, seconds: float) -> DiverTrack:
    """Where the diver will be in ``seconds`` going on as he goes (NED m): body, head and
    hand moved together at his speed along his heading, and the head swung on at its
    rate about the body centre (``head_rate_ned``; kept at its distance from it: the
    head of a diver rising upright or bending down moves on a circle round his hips)."""
    shift = diver.speed * seconds * diver.forward
    head = diver.head + shift
    if diver.head_rate_ned is not None:
        arm = diver.head - diver.position_ned
        swung = arm + seconds * diver.head_rate_ned
        length = float(np.linalg.norm(swung))
        if length > 0.0:
            head = diver.position_ned + shift + swung * (float(np.linalg.norm(arm)) / length)
    return replace(diver, position_ned=diver.position_ned + shift, head_ned=head,
                   hand_ned=diver.hand + shift)


def guard_slack_ahead(rov_position: NDArray[np.float64], diver: DiverTrack,
                      config: AssistantConfig) -> float:
    """The smallest :func:`guard_slack` of now, of half ``guard_lookahead_s`` on and of
    ``guard_lookahead_s`` on, the diver going on as he goes (:func:`ahead_of`; the ROV
    where it is): a diver who swims at the ROV, or whose head swings towards it, sets
    its guard off before he is inside it."""
    return min(guard_slack(rov_position, ahead_of(diver, s), config)
               for s in (0.0, 0.5 * config.guard_lookahead_s, config.guard_lookahead_s))


def closing_speed(rov_position: NDArray[np.float64], diver: DiverTrack) -> float:
    """How fast the diver comes at the ROV's centre (m/s, > 0 closing): the larger of his
    body's horizontal speed towards it and his head's (the body's motion plus the head's
    own, ``head_rate_ned``)."""
    body = float(diver.speed * diver.forward @ horizontal(rov_position - diver.position_ned))
    if diver.head_rate_ned is None:
        return body
    towards = rov_position - diver.head
    n = float(np.linalg.norm(towards))
    head = 0.0 if n == 0.0 else float(
        (diver.speed * diver.forward + diver.head_rate_ned) @ towards) / n
    return max(body, head)


def jaw_offset(heading_deg: float, config: AssistantConfig) -> NDArray[np.float64]:
    """The jaws' offset (NED, m) from the ROV's centre at ``heading_deg``."""
    return rot_z(math.radians(heading_deg)) @ np.asarray(config.jaw_frd, dtype=float)


def centre_for_jaw(target: NDArray[np.float64], heading_deg: float,
                   config: AssistantConfig) -> NDArray[np.float64]:
    """Where the ROV's centre must be for its jaws to be at ``target`` at that heading."""
    return target - jaw_offset(heading_deg, config)


def kept_clear(point: NDArray[np.float64], away: NDArray[np.float64], diver: DiverTrack,
               config: AssistantConfig, step_m: float = 0.02, limit_m: float = 3.0
               ) -> NDArray[np.float64]:
    """``point`` moved along the unit direction ``away`` until the ROV's centre there is
    a guard + ``clearance_m`` from the diver (unchanged if it already is)."""
    moved = np.array(point, dtype=float)
    travelled = 0.0
    while guard_slack(moved, diver, config) < config.clearance_m and travelled < limit_m:
        moved += step_m * away
        travelled += step_m
    return moved
