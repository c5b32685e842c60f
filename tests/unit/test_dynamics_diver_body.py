"""The diver's articulated body: anthropometry, forward kinematics, reach, poses, motion."""

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.dynamics import diver_body as db

SKELETON = db.DiverSkeleton()
H = db.STATURE_M
DT = 1.0 / 60.0


def random_configurations(n, seed=7):
    """``n`` configurations inside the limits, wrists straight (the reach solver's
    convention), from a seeded Generator."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = rng.uniform(SKELETON.lower, SKELETON.upper)
        for side in db.SIDES:
            q[SKELETON.index(f"{side}_wrist")] = 0.0
        yield q


def test_zero_configuration_matches_winters_segment_ratios():
    q0 = SKELETON.zeros()
    # shoulder 0.818 H above the soles, the hip centre (origin) 0.530 H: 0.504 m up (-z)
    shoulder = SKELETON.shoulder(q0, "right")
    np.testing.assert_allclose(shoulder, [0.0, 0.5 * 0.259 * H, -(0.818 - 0.530) * H])
    # hanging arm: grip point = shoulder + upper arm + forearm + 0.4 hand, straight down
    reach = (0.186 + 0.146 + 0.4 * 0.108) * H
    assert SKELETON.arm_reach == pytest.approx(reach)
    np.testing.assert_allclose(SKELETON.grip_point(q0, "right"), shoulder + np.array([0, 0, reach]))
    # the left side mirrors the right
    left = SKELETON.grip_point(q0, "left")
    np.testing.assert_allclose(left, shoulder * [1, -1, 1] + [0, 0, reach])
    # soles 0.530 H below the hip centre
    assert SKELETON.body.hip_height == pytest.approx(0.530 * H)


def test_a_joints_kept_transform_is_that_of_the_whole_pose_bit_for_bit():
    """transform_of keeps a joint's transform for its chain's angles: the legs' kick
    changes no hand; every answer equals joint_transforms of that very q."""
    skeleton = db.DiverSkeleton()
    legs = [skeleton.index(f"{s}_{j}") for s in db.SIDES for j in ("hip_flex", "knee")]
    wrist, waist = skeleton.index("right_wrist"), skeleton.index("waist")
    rng = np.random.default_rng(3)
    for q in random_configurations(20):
        for _ in range(3):  # the same arms, other legs: kept
            q = q.copy()
            q[legs] = rng.uniform(skeleton.lower[legs], skeleton.upper[legs])
            for joint in (wrist, waist):
                kept = skeleton.transform_of(q, joint)
                fresh = db.DiverSkeleton().joint_transforms(q)[joint]
                assert kept.tobytes() == fresh.tobytes()
    with pytest.raises(ConfigError, match="shape"):
        skeleton.transform_of(np.zeros(3), wrist)


def test_shoulder_flexion_of_90_degrees_points_the_straight_arm_forward():
    q = SKELETON.vector({"right_shoulder_flex": math.pi / 2})
    shoulder = SKELETON.shoulder(q, "right")
    np.testing.assert_allclose(SKELETON.grip_point(q, "right"),
                               shoulder + np.array([SKELETON.arm_reach, 0, 0]), atol=1e-12)
    # abduction of 90 degrees takes the right arm out to starboard (+y), the left to port
    q = SKELETON.vector({"right_shoulder_abd": math.pi / 2, "left_shoulder_abd": math.pi / 2})
    np.testing.assert_allclose(SKELETON.grip_point(q, "right") - SKELETON.shoulder(q, "right"),
                               [0, SKELETON.arm_reach, 0], atol=1e-12)
    np.testing.assert_allclose(SKELETON.grip_point(q, "left") - SKELETON.shoulder(q, "left"),
                               [0, -SKELETON.arm_reach, 0], atol=1e-12)


def test_elbow_flexion_brings_the_forearm_forward_and_internal_rotation_inwards():
    q = SKELETON.vector({"right_elbow": math.pi / 2})
    elbow = SKELETON.shoulder(q, "right") + np.array([0, 0, SKELETON.body.upper_arm])
    forearm = SKELETON.arm_reach - SKELETON.body.upper_arm
    np.testing.assert_allclose(SKELETON.grip_point(q, "right"), elbow + np.array([forearm, 0, 0]),
                               atol=1e-12)
    q = SKELETON.vector({"right_elbow": math.pi / 2, "right_shoulder_rot": math.radians(50)})
    assert SKELETON.grip_point(q, "right")[1] < elbow[1]  # towards the body's midline


def test_posture_pitches_the_whole_body_head_forward():
    q = SKELETON.vector({"posture": math.pi / 2})
    t = SKELETON.link_transforms(q)["head"]
    head_rest = np.array([0.0, 0.0, SKELETON.body.head_centre_z])
    np.testing.assert_allclose(t[:3, :3] @ head_rest + t[:3, 3],
                               [-SKELETON.body.head_centre_z, 0, 0], atol=1e-12)
    # the arms pitch with the body: along its sides, towards the feet (-x), level (z = 0)
    rest = SKELETON.grip_point(SKELETON.zeros(), "right")
    np.testing.assert_allclose(SKELETON.grip_point(q, "right"), [-rest[2], rest[1], 0.0],
                               atol=1e-12)


@pytest.mark.parametrize("side", db.SIDES)
def test_reach_solver_round_trips_forward_kinematics_inside_the_limits(side):
    """FK of a random configuration, then IK from the same posture: the solution puts the
    grip point on the same place (1e-9 m) without leaving any limit (400 configurations)."""
    worst = 0.0
    for q in random_configurations(400, seed=11 if side == "left" else 12):
        target = SKELETON.grip_point(q, side)
        start = q.copy()
        start[list(SKELETON.arm_joints(side))] = 0.0
        solution = db.solve_reach(SKELETON, side, target, start)
        assert solution.ok, solution.reason
        assert SKELETON.limit_violations(solution.q) == []
        worst = max(worst, float(np.linalg.norm(SKELETON.grip_point(solution.q, side) - target)))
        # only the arm moved
        others = np.setdiff1d(np.arange(SKELETON.n_joints), SKELETON.arm_joints(side))
        np.testing.assert_array_equal(solution.q[others], start[others])
    assert worst < 1e-9


def test_reach_envelope_boundary_and_reasons():
    q0 = SKELETON.zeros()
    shoulder = SKELETON.shoulder(q0, "right")
    forward = np.array([1.0, 0.0, 0.0])
    assert db.can_reach(SKELETON, "right", shoulder + 0.999 * SKELETON.arm_reach * forward, q0)
    far = db.solve_reach(SKELETON, "right", shoulder + 1.01 * SKELETON.arm_reach * forward, q0)
    assert not far.ok and far.reason.startswith("out of reach: 0.66 m from the right shoulder")
    # a point 10 cm from the shoulder needs the elbow beyond its dry-suit limit (120 deg)
    near = db.solve_reach(SKELETON, "right", shoulder + np.array([0.1, 0.0, 0.0]), q0)
    assert not near.ok and "elbow would bend" in near.reason and "limit 120°" in near.reason
    # straight behind the back at shoulder height: extension beyond the limit
    behind = db.solve_reach(SKELETON, "right", shoulder + np.array([-0.6, 0.0, 0.0]), q0)
    assert not behind.ok and "within the dry-suit limits" in behind.reason


def test_bending_at_the_waist_reaches_lower():
    """Standing, the grip cannot reach 1.2 m below the shoulders' height; bending at the
    waist (the smallest bend that works) it can, and the solution stays in the limits."""
    q0 = SKELETON.zeros()
    target = SKELETON.shoulder(q0, "right") + np.array([0.5, 0.0, 0.8])
    assert not db.solve_reach(SKELETON, "right", target, q0).ok
    bent = db.solve_reach(SKELETON, "right", target, q0, bend=True)
    assert bent.ok and SKELETON.limit_violations(bent.q) == []
    waist = bent.q[SKELETON.index("waist")]
    assert 0.0 < waist <= math.radians(80 * 0.8)
    np.testing.assert_allclose(SKELETON.grip_point(bent.q, "right"), target, atol=1e-9)
    far = db.solve_reach(SKELETON, "right", target + np.array([1.0, 0.0, 0.0]), q0, bend=True)
    assert not far.ok and far.reason.endswith("(even bending over)")


def test_limits_are_the_aaos_ranges_times_the_dry_suit_factor():
    def deg(joint):
        j = SKELETON.joints[SKELETON.index(joint)]
        return math.degrees(j.lower), math.degrees(j.upper)

    assert deg("right_shoulder_flex") == pytest.approx((-60 * 0.8, 180 * 0.8))
    assert deg("left_elbow") == pytest.approx((0.0, 150 * 0.8))
    assert deg("right_knee") == pytest.approx((0.0, 135 * 0.8))
    assert deg("posture") == pytest.approx((0.0, 90.0))  # not a human joint: not scaled
    unrestricted = db.DiverSkeleton(rom_factor=1.0)
    assert math.degrees(unrestricted.upper[unrestricted.index("right_elbow")]) == pytest.approx(150)


@pytest.mark.parametrize("name", sorted(db.NAMED_POSES))
@pytest.mark.parametrize("side", db.SIDES)
def test_named_poses_are_inside_the_limits(name, side):
    swimming = db.pose_goal(SKELETON, "swim")
    goal = db.pose_goal(SKELETON, name, swimming, side=side)
    assert SKELETON.limit_violations(goal) == []
    if name not in db.WHOLE_BODY_POSES:  # arm poses keep the posture and the legs
        assert goal[SKELETON.index("posture")] == swimming[SKELETON.index("posture")]
        assert goal[SKELETON.index("left_ankle")] == swimming[SKELETON.index("left_ankle")]


def test_named_poses_put_the_hands_where_their_names_say():
    q = db.pose_goal(SKELETON, "stand")
    reach = db.pose_goal(SKELETON, "reach", q, side="right")
    shoulder = SKELETON.shoulder(reach, "right")
    grip = SKELETON.grip_point(reach, "right")
    assert grip[0] - shoulder[0] > 0.6  # arm stretched forward
    hold = db.pose_goal(SKELETON, "hold", q)
    assert SKELETON.grip_closure(hold, "right") == pytest.approx(1.0)  # hand closed
    assert SKELETON.grip_closure(reach, "right") == 0.0  # hand open to take something
    signal = db.pose_goal(SKELETON, "signal_ready", q)
    assert SKELETON.grip_point(signal, "right")[2] < shoulder[2]  # hand above the shoulder


def test_unknown_pose_joint_side_and_kind_are_clear_errors():
    with pytest.raises(ConfigError, match=r"unknown pose 'wave'.*have stand, swim"):
        db.pose_goal(SKELETON, "wave")
    with pytest.raises(ConfigError, match="side must be 'left' or 'right'"):
        db.pose_goal(SKELETON, "reach", side="middle")
    with pytest.raises(ConfigError, match="no joint 'right_thumb'"):
        SKELETON.index("right_thumb")
    with pytest.raises(ConfigError, match="must be 'scuba' or 'boots'"):
        db.DiverSkeleton(kind="rebreather")
    with pytest.raises(ConfigError, match=r"q must have shape \(24,\)"):
        SKELETON.joint_transforms(np.zeros(3))


def run_motion(q, goal, seconds):
    qs, vs = [q], [np.zeros_like(q)]
    for _ in range(round(seconds / DT)):
        q, v = db.step_motion(SKELETON, qs[-1], vs[-1], goal, DT)
        qs.append(q)
        vs.append(v)
    return np.array(qs), np.array(vs)


@pytest.mark.parametrize("start,end", [("stand", "swim"), ("swim", "stand")])
def test_motion_never_exceeds_limits_or_speeds_and_arrives(start, end):
    q0 = db.pose_goal(SKELETON, start)
    goal = db.pose_goal(SKELETON, end)
    qs, vs = run_motion(q0, goal, 6.0)
    assert all(SKELETON.limit_violations(q) == [] for q in qs)
    assert np.all(np.abs(vs) <= SKELETON.max_speed * (1 + 1e-12))
    # acceleration bounded: max_speed / ACCELERATION_TIME_S, twice that in the final stop
    accel = SKELETON.max_speed / db.ACCELERATION_TIME_S
    assert np.all(np.abs(np.diff(vs, axis=0)) <= 2.0 * accel * DT + 1e-9)
    # posture 90 deg at 30 deg/s: 3 s cruising + 0.25 s to speed up: done well within 6 s
    np.testing.assert_allclose(qs[-1], goal, atol=1e-9)
    arrived = np.flatnonzero(np.all(np.abs(qs - goal) < 1e-6, axis=1))[0] * DT
    assert 3.0 <= arrived <= 3.6


def test_motion_is_synchronised_a_straight_line_in_joint_space():
    q0 = db.pose_goal(SKELETON, "stand")
    goal = db.pose_goal(SKELETON, "work", q0)
    qs, _ = run_motion(q0, goal, 3.0)
    moving = np.abs(goal - q0) > 1e-3
    progress = (qs[:, moving] - q0[moving]) / (goal - q0)[moving]
    # every moving joint has covered the same fraction of its way at every instant
    assert np.ptp(progress, axis=1).max() < 0.02
    assert np.all(np.diff(progress, axis=0) >= -1e-12)  # and never goes back


def test_goals_outside_the_limits_are_clipped():
    goal = SKELETON.vector({"right_elbow": math.radians(170)})
    qs, _ = run_motion(SKELETON.zeros(), goal, 3.0)
    assert qs[:, SKELETON.index("right_elbow")].max() == pytest.approx(math.radians(120))


def test_compiled_motion_is_the_numpy_path_bit_for_bit():
    """step_motion's compiled joint loop against its numpy path (the reference): random
    states, goals inside and outside the limits, joints still on their goals, signed
    zeros, tiny errors; every bit of q and qdot equal (without numba both are numpy)."""
    rng = np.random.default_rng(7)
    n = SKELETON.n_joints
    for k in range(200):
        q = rng.uniform(SKELETON.lower, SKELETON.upper)
        v = rng.uniform(-1.0, 1.0, n) * SKELETON.max_speed
        goal = rng.uniform(SKELETON.lower - 0.3, SKELETON.upper + 0.3)
        some = rng.random((3, n)) < 0.4
        match k % 5:
            case 1:  # some joints still on their goals, the rest moving
                goal, v = np.where(some[0], q, goal), np.where(some[1], 0.0, v)
            case 2:  # signed zeros
                q, goal = np.where(some[0], 0.0, q), np.where(some[1], -0.0, goal)
                v = np.where(some[2], -0.0, v)
            case 3:  # nearly there
                goal, v = q + rng.normal(0.0, 1e-7, n), v * 1e-4
            case 4 if k % 10 == 4:  # all still on the goal
                goal, v = q.copy(), np.zeros(n)
        dt = (0.05, 1.0 / 60.0)[k % 2]
        fast = db.step_motion(SKELETON, q, v, goal, dt)
        slow = db.step_motion(SKELETON, q, v, goal, dt, compiled=False)
        for a, b in zip(fast, slow, strict=True):
            assert a.tobytes() == b.tobytes(), k


def test_commercial_diver_has_no_fins():
    boots = db.DiverSkeleton(kind="boots")
    assert "right_fin" not in boots.links and "right_fin" in SKELETON.links
    assert boots.joint_names == SKELETON.joint_names
