"""Frames, angle wrapping and named seeded randomness."""

import numpy as np
import pytest

from uhrisim.core import frames
from uhrisim.core.rng import component_rng


def test_wraps():
    assert frames.wrap_180(350.0 - 10.0) == pytest.approx(-20.0)
    assert frames.wrap_180(10.0 - 350.0) == pytest.approx(20.0)
    assert frames.wrap_180(180.0) == pytest.approx(-180.0)
    assert frames.wrap_360(-90.0) == pytest.approx(270.0)
    assert frames.wrap_pi(3 * np.pi) == pytest.approx(-np.pi)


def test_one_number_gives_the_array_answer_bit_for_bit():
    """The angle helpers' plain-number path (the control loop's) equals their numpy path,
    signed zeros and the wrap boundaries included."""
    rng = np.random.default_rng(5)
    values = np.concatenate([[0.0, -0.0, 180.0, -180.0, 360.0, -360.0, 720.0, 1e-300, -1e-12],
                             rng.uniform(-2000.0, 2000.0, 500)])
    for fn in (frames.wrap_180, frames.wrap_360, frames.heading_deg_from_yaw):
        as_array = fn(values)
        for v, expected in zip(values.tolist(), as_array.tolist(), strict=True):
            got = fn(v)
            assert type(got) is float
            assert got == expected and np.copysign(1.0, got) == np.copysign(1.0, expected)


def test_heading_and_yaw_are_the_same_angle():
    assert frames.heading_deg_from_yaw(np.pi / 2) == pytest.approx(90.0)
    assert frames.heading_deg_from_yaw(-np.pi / 2) == pytest.approx(270.0)
    assert frames.yaw_from_heading_deg(270.0) == pytest.approx(-np.pi / 2)


def test_moos_xy_swaps_axes():
    assert frames.moos_xy_from_ned(3.0, 4.0) == (4.0, 3.0)
    assert frames.ned_from_moos_xy(4.0, 3.0) == (3.0, 4.0)


def test_ned_pose_in_enu():
    # North 3, east 4, depth 2, heading 90 deg (facing east) -> ENU (4, 3, -2), ENU yaw 0.
    np.testing.assert_allclose(frames.enu_from_ned([3.0, 4.0, 2.0]), [4.0, 3.0, -2.0])
    r_enu = frames.enu_rotation_from_ned(frames.rot_z(np.pi / 2))
    np.testing.assert_allclose(r_enu, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(frames.quaternion_from_matrix(r_enu), [0, 0, 0, 1], atol=1e-12)
    # Heading 0 (north) is ENU yaw +90 deg: quaternion (0, 0, sin 45, cos 45).
    q = frames.quaternion_from_matrix(frames.enu_rotation_from_ned(frames.rot_z(0.0)))
    np.testing.assert_allclose(q, [0, 0, np.sqrt(0.5), np.sqrt(0.5)], atol=1e-12)
    np.testing.assert_allclose(frames.flu_from_frd([1.0, 2.0, 3.0]), [1.0, -2.0, -3.0])


def test_rotation_zyx_is_orthonormal_and_matches_rot_z():
    r = frames.rotation_zyx(0.1, -0.2, 0.3)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(frames.rotation_zyx(0, 0, 0.7), frames.rot_z(0.7), atol=1e-12)


def test_quaternion_round_trip_for_random_rotations():
    rng = np.random.default_rng(0)
    for _ in range(50):
        r = frames.rotation_zyx(*rng.uniform(-3, 3, 3))
        x, y, z, w = frames.quaternion_from_matrix(r)
        back = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ])
        np.testing.assert_allclose(back, r, atol=1e-12)


def test_component_streams_are_reproducible_and_independent():
    a1 = component_rng(42, "videoray/sonar").random(5)
    a2 = component_rng(42, "videoray/sonar").random(5)
    b = component_rng(42, "diver/motion").random(5)
    c = component_rng(43, "videoray/sonar").random(5)
    np.testing.assert_array_equal(a1, a2)
    assert not np.allclose(a1, b) and not np.allclose(a1, c)
    with pytest.raises(ValueError):
        component_rng(-1, "x")
