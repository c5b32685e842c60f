"""Properties of a ping that hold for any mount and vehicle pose (hypothesis)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from uhrisim.core.frames import rot_z
from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, SonarSpec

SPEC = SonarSpec("prop", 900e3, 30.0, 24, 1.0, 20.0, 100.0, 0.05, 15.0, source="test")


class Floor:
    """Flat floor at NED z = 8 m (label 0, μ = 0.02)."""

    def cast(self, origins, directions, max_range, exclude=frozenset()):
        d = np.asarray(directions)
        o = np.broadcast_to(np.asarray(origins), d.shape)  # (3,): one shared origin
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (8.0 - o[:, 2]) / d[:, 2]
        hit = (d[:, 2] > 0) & (t > 0) & (t <= max_range)
        n = len(d)

        class H:
            distance = np.where(hit, t, np.inf)
            label = np.where(hit, 0, -1).astype(np.int32)
            normal = np.tile([0.0, 0.0, -1.0], (n, 1))
            reflectivity = np.where(hit, 0.02, 0.0)
            body = np.full(n, -1, np.int32)

        return H()


@settings(max_examples=25, deadline=None)
@given(
    tilt=st.floats(-30.0, 60.0),
    yaw=st.floats(-60.0, 60.0),
    heading=st.floats(-180.0, 180.0),
    mount=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)),
    depth=st.floats(1.0, 7.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_ping_invariants(tilt, yaw, heading, mount, depth, seed) -> None:
    cfg = SonarConfig(
        spec=SPEC, range_max_m=15.0, rays_per_beam=12, tilt_deg=tilt, yaw_deg=yaw,
        mount_position_frd=mount, fan_size_px=128, rate_hz=10.0, labels=True,
    )  # fmt: skip
    sonar = ImagingSonar(cfg, np.random.default_rng(seed))
    R = rot_z(math.radians(heading))
    ping = sonar.ping(Floor(), np.array([0.0, 0.0, depth]), R, 0.0)
    assert ping.polar.min() >= 0.0 and ping.polar.max() <= 1.0
    assert set(np.unique(ping.label_polar).tolist()) <= {-1, 0}
    assert set(np.unique(ping.label_fan).tolist()) <= {-1, 0}
    # Every hit lies on the floor, inside the range window, in the sonar's field of view.
    pts = ping.hit_points_sonar
    if len(pts):
        np.testing.assert_allclose(ping.hit_points_ned[:, 2], 8.0, atol=1e-9)
        r = np.linalg.norm(pts, axis=1)
        assert r.max() < 15.0
        assert np.degrees(np.abs(np.arctan2(pts[:, 1], pts[:, 0]))).max() <= 15.0 + 1e-9
    # The cell of every hit (its range bin, its beam) is labelled.
    c = ping.cloud
    hit_rays = np.flatnonzero(np.isfinite(c.x))
    if hit_rays.size:
        beams = hit_rays % c.num_points_per_plane
        rng = np.sqrt(c.x[hit_rays] ** 2 + c.y[hit_rays] ** 2 + c.z[hit_rays] ** 2)
        bins = np.minimum((rng / cfg.bin_m).astype(int), cfg.n_bins - 1)
        assert (ping.label_polar[bins, beams] == 0).all()
    # The sonar pose composes the vehicle pose and the mount.
    np.testing.assert_allclose(ping.position_ned, [0, 0, depth] + R @ np.array(mount))
    axis = ping.rotation_ned_from_sonar[:, 0]
    assert math.degrees(math.asin(np.clip(axis[2], -1, 1))) == approx(tilt)
    # The cloud holds every ray, NaN exactly where a ray missed.
    assert c.x.size == c.num_planes * c.num_points_per_plane == sonar.n_rays
    assert np.isfinite(c.x).sum() == len(pts)


def approx(v: float, tol: float = 1e-6):
    import pytest

    return pytest.approx(v, abs=tol)
