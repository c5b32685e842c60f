"""Diver bubble plumes: kinematics with known answers, and the sonar sees them."""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.world.bubbles import PARKED_NED, BubbleParams, BubblePlume, cluster_mesh


def test_a_burst_rises_spreads_drifts_and_leaves_at_the_surface():
    params = BubbleParams(period_s=4.0, clusters=3, rise_speed=0.3, spread_speed=0.1,
                          current_ned=(0.05, -0.02), max_age_s=12.0)
    plume = BubblePlume(params, np.random.default_rng(4))
    assert plume.next_burst_time() == pytest.approx(2.0)
    origin = np.array([1.0, 2.0, 1.5])
    plume.release(2.0, origin)
    assert plume.next_burst_time() == pytest.approx(6.0)
    at_release, later = plume.positions(2.0)[:3], plume.positions(4.0)[:3]
    np.testing.assert_allclose(at_release, np.tile(origin, (3, 1)))
    np.testing.assert_allclose(later[:, 2], 1.5 - 0.3 * 2.0)  # rose 0.6 m in 2 s
    # Each cloud drifts at its own velocity plus the current: they spread apart.
    drift = (later[:, :2] - origin[:2]) / 2.0 - np.array([0.05, -0.02])
    assert np.all(np.abs(drift) < 0.5) and np.ptp(drift[:, 0]) > 0
    # At 1.5 / 0.3 = 5 s after release it reaches the surface and is parked.
    np.testing.assert_allclose(plume.positions(2.0 + 5.01)[:3], np.tile(PARKED_NED, (3, 1)))
    # Not yet released clouds are parked too.
    parked = np.tile(PARKED_NED, (plume.n_clouds - 3, 1))
    np.testing.assert_allclose(plume.positions(3.0)[3:], parked)


def test_bodies_are_reused_round_robin():
    params = BubbleParams(period_s=1.0, clusters=2, max_age_s=2.0)
    plume = BubblePlume(params, np.random.default_rng(0))
    assert params.bursts_alive == 3 and plume.n_clouds == 6
    for k in range(4):
        plume.release(0.5 + k, np.array([0.0, 0.0, 5.0 + k]))
    # The fourth burst took the first burst's slot.
    np.testing.assert_allclose(plume.positions(3.5)[:2, 2], 8.0)


def test_cluster_mesh_fits_its_ball():
    params = BubbleParams(radius_m=0.03, cluster_radius_m=0.12, bubbles_per_cluster=6)
    mesh = cluster_mesh(params, np.random.default_rng(1))
    assert len(mesh.split()) == 6
    assert np.linalg.norm(mesh.vertices, axis=1).max() <= 0.12 + 0.03 + 1e-9


def test_bad_settings_are_refused():
    with pytest.raises(ConfigError, match=r"BubbleParams\.period_s"):
        BubbleParams(period_s=0.0)
    with pytest.raises(ConfigError, match=r"BubbleParams\.clusters"):
        BubbleParams(clusters=0)


@pytest.mark.slow
def test_the_sonar_sees_the_bubbles_rise_away_from_the_diver(tmp_path):
    # A diver hovering 4 m ahead of a still ROV at its depth breathes out: bubble cells
    # appear in the label images, then the burst rises out of the 20 deg beam.
    from uhrisim.scenario.load import load_scenario
    from uhrisim.sim.simulation import Simulation

    path = tmp_path / "b.yaml"
    path.write_text(
        "name: b\nseed: 3\nagents:\n"
        "  - {name: diver, model: diver, driver: none, start: {north: 4, east: 0, depth: 3},"
        " bubbles: {period: 2.0}}\n"
        "  - name: rov\n    model: videoray\n    driver: none\n"
        "    start: {north: 0, east: 0, depth: 3, heading_deg: 0}\n"
        "    sensors: [{preset: P900-45, range_min_m: 0.5, range_max_m: 8, rays_per_beam: 32,"
        " labels: true, rate_hz: 10, mount_position_frd: [0.2, 0, 0], tilt_deg: 0}]\n")
    sim = Simulation(load_scenario(path))
    bubbles = sim.scene.labels.index("bubbles")
    seen = []
    while sim.t < 6.0:
        frame = sim.step()
        ping = frame.pings.get("rov/sonar")
        if ping is not None:
            seen.append(int(np.count_nonzero(ping.label_polar == bubbles)))
    assert max(seen) > 20  # strong, visible returns
    assert seen[-1] < max(seen)  # the burst rose out of the beam
    # Bubbles are not obstacles: the diver swam through its own with no collision.
    assert sim.collisions == 0
