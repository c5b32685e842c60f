"""ROS 2 bridge, the parts that need no ROS: frame/stamp conversions, rate gates, the
Pacer, the specs. Expected numbers are worked out by hand from docs/conventions.md
(NED/FRD inside, REP-103 ENU/FLU outside)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.bridges.ros2 import AgentBridgeSpec, AgentCommands, Pacer, apply_env_defaults
from uhrisim.bridges.ros2.spec import FASTDDS_PROFILE, check_domain_id
from uhrisim.core.errors import ConfigError, NumericalError
from uhrisim.ros.convert import (
    RateGate,
    cloud_xyzi_flu,
    odom_fields_from_ned,
    pose_enu_from_ned,
    stamp_from_sim_time,
)


def test_stamp_splits_seconds_and_nanoseconds() -> None:
    assert stamp_from_sim_time(0.0) == (0, 0)
    assert stamp_from_sim_time(12.5) == (12, 500_000_000)
    # 0.1 s steps accumulate binary error; the stamp rounds to the nearest ns.
    assert stamp_from_sim_time(sum([0.1] * 10)) == (1, 0)
    assert stamp_from_sim_time(1.9999999999) == (2, 0)
    with pytest.raises(NumericalError):
        stamp_from_sim_time(float("nan"))


def test_known_pose_north3_east4_depth2_heading90() -> None:
    """The pose named in the task: NED (3, 4, 2), heading 90 deg (facing east).

    ENU position is (east, north, up) = (4, 3, -2). Facing east is ENU yaw 0, so the
    quaternion is the identity (w = 1)."""
    f = odom_fields_from_ned([3.0, 4.0, 2.0], math.pi / 2, [0.5, 0.1, -0.2], 0.3)
    np.testing.assert_allclose(f.position_enu, (4.0, 3.0, -2.0), atol=1e-12)
    np.testing.assert_allclose(f.orientation_xyzw, (0.0, 0.0, 0.0, 1.0), atol=1e-12)
    # FRD (u, v, w) = (0.5 fwd, 0.1 starboard, -0.2 down) -> FLU (0.5, -0.1, 0.2).
    np.testing.assert_allclose(f.linear_flu, (0.5, -0.1, 0.2), atol=1e-12)
    # r = 0.3 rad/s clockwise from above is a negative (clockwise) ENU z rate.
    np.testing.assert_allclose(f.angular_flu, (0.0, 0.0, -0.3), atol=1e-12)


@pytest.mark.parametrize("heading_deg", [0.0, 30.0, 90.0, 135.0, 180.0, 270.0, 359.0])
def test_enu_yaw_is_90_minus_compass_heading(heading_deg: float) -> None:
    """ENU yaw (counter-clockwise from east) = 90 deg - compass heading."""
    q = odom_fields_from_ned([0, 0, 0], math.radians(heading_deg), [0, 0, 0], 0.0)
    x, y, z, w = q.orientation_xyzw
    assert abs(x) < 1e-12 and abs(y) < 1e-12  # no roll, no pitch
    yaw_enu = math.degrees(2.0 * math.atan2(z, w))
    err = (yaw_enu - (90.0 - heading_deg) + 180.0) % 360.0 - 180.0
    assert abs(err) < 1e-9


def test_forward_velocity_maps_to_world_direction() -> None:
    """Heading 30 deg, surge 1 m/s: the ENU world velocity R_enu @ v_flu is
    (sin 30, cos 30, 0) = (east 0.5, north 0.866)."""
    f = odom_fields_from_ned([0, 0, 0], math.radians(30.0), [1.0, 0, 0], 0.0)
    x, y, z, w = f.orientation_xyzw
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    np.testing.assert_allclose(r @ np.array(f.linear_flu), [0.5, math.sqrt(3) / 2, 0], atol=1e-12)


def test_odom_rejects_bad_input() -> None:
    with pytest.raises(ConfigError):
        odom_fields_from_ned([1, 2], 0.0, [0, 0, 0], 0.0)
    with pytest.raises(NumericalError):
        odom_fields_from_ned([1, 2, float("inf")], 0.0, [0, 0, 0], 0.0)
    with pytest.raises(NumericalError):
        odom_fields_from_ned([1, 2, 3], float("nan"), [0, 0, 0], 0.0)


def test_marker_pose_identity_object_points_north() -> None:
    """An object with identity rotation in NED/FRD has its x axis along north, which in
    ENU is yaw +90 deg about z (its FRD z axis, down, becomes FLU z, up):
    quaternion (0, 0, sin 45, cos 45)."""
    pos, q = pose_enu_from_ned([1.0, 2.0, 3.0])
    np.testing.assert_allclose(pos, (2.0, 1.0, -3.0))
    h = math.sqrt(0.5)
    np.testing.assert_allclose(q, (0.0, 0.0, h, h), atol=1e-12)
    # an object yawed to heading 90 deg (x east) is the ENU identity
    _, q_east = pose_enu_from_ned([0, 0, 0], [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_allclose(q_east, (0.0, 0.0, 0.0, 1.0), atol=1e-12)
    with pytest.raises(ConfigError):
        pose_enu_from_ned([0, 0, 0], np.diag([1.0, 1.0, -1.0]))  # a reflection


def test_cloud_rows_are_flu_float32() -> None:
    pts = np.array([[1.0, 2.0, 3.0], [4.0, -5.0, 0.5]])
    rows = cloud_xyzi_flu(pts, [7.0, 8.0])
    assert rows.dtype == np.dtype("<f4") and rows.flags.c_contiguous
    np.testing.assert_array_equal(rows, [[1, -2, -3, 7], [4, 5, -0.5, 8]])
    assert cloud_xyzi_flu(np.zeros((0, 3))).shape == (0, 4)
    np.testing.assert_array_equal(cloud_xyzi_flu(pts)[:, 3], [0.0, 0.0])
    with pytest.raises(ConfigError):
        cloud_xyzi_flu(pts, [1.0])


def test_pose_rotation_check_is_allclose_to_a_proper_rotation() -> None:
    """The written-out orthonormality test accepts and refuses what
    ``np.allclose(r @ r.T, I, atol=1e-6)`` and ``det(r) > 0`` do, NaN included."""
    rng = np.random.default_rng(3)
    for scale in (0.0, 1e-8, 3e-7, 1e-6, 1e-5, 1e-3):
        for _ in range(40):
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            r = q + scale * rng.normal(size=(3, 3))
            proper = bool(np.allclose(r @ r.T, np.eye(3), atol=1e-6)
                          and np.linalg.det(r) >= 0.0)
            if proper:
                pose_enu_from_ned([0, 0, 0], r)
            else:
                with pytest.raises(ConfigError):
                    pose_enu_from_ned([0, 0, 0], r)
    with pytest.raises(ConfigError):
        pose_enu_from_ned([0, 0, 0], np.full((3, 3), np.nan))


@pytest.mark.parametrize(("rate", "dt"), [(15.0, 0.01), (10.0, 0.01), (15.0, 0.02), (7.0, 0.05)])
def test_rate_gate_keeps_average_rate_on_a_tick_grid(rate: float, dt: float) -> None:
    """Over T seconds of ticks the gate fires floor(T * rate) + 1 times (+-1 for the
    tick quantisation), and never twice within one tick."""
    gate = RateGate(rate)
    n_ticks = round(20.0 / dt)
    fired = [k * dt for k in range(n_ticks + 1) if gate.due(k * dt)]
    expected = 20.0 * rate + 1
    assert abs(len(fired) - expected) <= 1
    gaps = np.diff(fired)
    assert gaps.min() >= 1.0 / rate - dt - 1e-9
    assert gaps.max() <= 1.0 / rate + dt + 1e-9


def test_rate_gate_fires_on_multiples_of_its_period() -> None:
    """A 20 Hz gate first asked at any tick of a 60 Hz loop fires on the ticks at 0.05,
    0.10, ... s; two gates of one rate share their ticks, and a 10 Hz gate fires on every
    other one of them; wake_time says when the gate can next be due."""
    ticks = [k / 60 for k in range(1, 601)]
    late = RateGate(20.0)
    fired_late = [t for t in ticks[7:] if late.due(t)]
    early = RateGate(20.0)
    fired_early = [t for t in ticks if early.due(t)]
    assert fired_late == [t for t in fired_early if t >= ticks[7]]
    np.testing.assert_allclose(fired_early, 0.05 * np.arange(1, 201), atol=1e-12)
    ten = RateGate(10.0)
    assert [t for t in ticks if ten.due(t)] == fired_early[1::2]
    g = RateGate(20.0)
    assert g.wake_time == -math.inf and g.due(0.05)
    assert g.wake_time == pytest.approx(0.1) and not g.is_due(0.0999) and g.is_due(0.1)
    assert g.due(0.37) and g.wake_time == pytest.approx(0.4)  # fell behind: next multiple


def test_rate_gate_none_and_time_reset() -> None:
    g = RateGate(None)
    assert all(g.due(t) for t in (0.0, 0.0, 0.001))
    g10 = RateGate(10.0)
    assert g10.due(5.0) and not g10.due(5.05) and g10.due(5.1)
    assert g10.due(0.0)  # time went backwards: a new run restarts the gate
    with pytest.raises(ConfigError):
        RateGate(0.0)


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.sleeps.append(s)
        self.now += s


def test_pacer_real_time_factor_sets_wall_duration() -> None:
    """At factor 2, 10 sim-seconds of instantaneous ticks take 5 wall seconds."""
    fc = FakeClock()
    p = Pacer(2.0, clock=fc.clock, sleep=fc.sleep)
    p.reset(0.0)
    for k in range(1, 101):
        assert p.wait(0.1 * k) == 0.0
    assert fc.now - 100.0 == pytest.approx(5.0)
    assert p.stats().slept_s == pytest.approx(5.0)


def test_pacer_reports_lag_and_reanchors_after_max_lag() -> None:
    fc = FakeClock()
    p = Pacer(1.0, max_lag_s=0.5, clock=fc.clock, sleep=fc.sleep)
    p.reset(0.0)
    fc.now += 0.3  # a tick took 0.3 s for 0.1 s of sim time
    assert p.wait(0.1) == pytest.approx(0.2)
    assert p.stats().slips == 0
    fc.now += 1.0
    assert p.wait(0.2) == pytest.approx(1.1)
    assert p.stats().slips == 1
    # re-anchored at (wall now, t=0.2): t=0.3 is due 0.1 s later, not at once
    p.wait(0.3)
    assert fc.sleeps[-1] == pytest.approx(0.1)


def test_pacer_free_running_never_sleeps() -> None:
    fc = FakeClock()
    for factor in (None, math.inf):
        p = Pacer(factor, clock=fc.clock, sleep=fc.sleep)
        assert p.free_running
        p.reset(0.0)
        assert p.wait(1e6) == 0.0
    assert fc.sleeps == []
    with pytest.raises(ConfigError):
        Pacer(0.0)


def test_specs_validate() -> None:
    s = AgentBridgeSpec("rov", accept=["desired"], sonar_rate_hz=15, odom_rate_hz=10)
    assert s.accept == ("desired",)
    with pytest.raises(ConfigError, match="accept"):
        AgentBridgeSpec("rov", accept=("helm",))
    with pytest.raises(ConfigError, match="name"):
        AgentBridgeSpec("my rov")
    with pytest.raises(ConfigError, match="odom_rate_hz"):
        AgentBridgeSpec("rov", odom_rate_hz=-1.0)
    assert check_domain_id(None) is None and check_domain_id(42) == 42
    with pytest.raises(ConfigError):
        check_domain_id(300)
    c = AgentCommands()
    assert not c.received and not c.has_desired and not c.stale


def test_env_defaults_only_fill_missing() -> None:
    """Loopback discovery and uhrisim's Fast DDS profile (an existing file, shipped
    with the package), each only where the user has not chosen."""
    env: dict[str, str] = {}
    profile = str(FASTDDS_PROFILE)
    assert FASTDDS_PROFILE.is_file() and "<segment_size>8388608<" in FASTDDS_PROFILE.read_text()
    expected = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                "FASTDDS_DEFAULT_PROFILES_FILE": profile}
    assert apply_env_defaults(env) == expected
    assert env == expected  # nothing else is set
    env2 = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "FASTDDS_DEFAULT_PROFILES_FILE": "my.xml"}
    assert apply_env_defaults(env2) == {}
    assert env2 == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET",
                    "FASTDDS_DEFAULT_PROFILES_FILE": "my.xml"}
    env3 = {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}  # another middleware: no profile
    assert apply_env_defaults(env3) == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
