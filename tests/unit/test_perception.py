"""Perception stages on synthetic pings with known answers (tests/support/synthetic_sonar.py):
detection within one bin and one beam, constant false alarms in speckle, ego-motion
compensation, the Kalman tracker's consistency (NEES), M-of-N confirmation and coasting,
the classifier file, and damaged pings."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from scipy.stats import chi2

from tests.support import synthetic_sonar as syn
from uhrisim.core.errors import ConfigError
from uhrisim.perception.blobs import Blob, BlobParams, extract_blobs
from uhrisim.perception.classify import FEATURES, DiverClassifier
from uhrisim.perception.detect import BackgroundModel, DetectorParams, cfar_mask
from uhrisim.perception.pipeline import SonarPerception
from uhrisim.perception.tracker import (
    FanView,
    MultiTargetTracker,
    TrackerParams,
    measurement_covariance,
)

RANGES = syn.bins()


def blobs_of(level):
    params = DetectorParams()
    mask, smooth, _, background = cfar_mask(level, RANGES, params)
    return extract_blobs(mask, smooth, np.zeros((1, 1), np.float32), background, RANGES,
                         syn.BEAMS, np.zeros(3), np.eye(3), params.edge_beams, BlobParams())


@pytest.mark.parametrize("floor_db", [-35.0, -42.0, None])
@pytest.mark.parametrize(("r0", "th0_deg", "level_db"),
                         [(6.0, 7.3, -10.0), (2.47, -15.0, -20.0), (8.6, 0.4, -25.0)])
def test_point_target_found_within_one_bin_and_one_beam(floor_db, r0, th0_deg, level_db):
    # Speckled floors at levels 0.3 and 0.16 (the target 10-25 dB above) and a clean image.
    rng = np.random.default_rng(7)
    th0 = math.radians(th0_deg)
    level = syn.polar_image(RANGES, [syn.Target(r0, th0, level_db)], rng, floor_db)
    found = blobs_of(level).blobs
    assert len(found) == 1, [(b.range_m, b.bearing_rad) for b in found]
    b = found[0]
    assert abs(b.range_m - r0) <= syn.BIN_M
    assert abs(b.bearing_rad - th0) <= syn.BEAM_STEP
    assert b.north_m == pytest.approx(r0 * math.cos(th0), abs=0.03)
    assert b.east_m == pytest.approx(r0 * math.sin(th0), abs=0.03)


@pytest.mark.parametrize("floor_db", [-45.0, -35.0, -25.0])
def test_speckle_alone_gives_no_blobs_at_any_floor_level(floor_db):
    # The threshold follows the local level: the same settings hold at three floors 20 dB
    # apart (levels 0.1 to 0.5) without a false blob in 20 pings (2 M cells).
    rng = np.random.default_rng(3)
    for _ in range(20):
        assert blobs_of(syn.polar_image(RANGES, [], rng, floor_db)).blobs == ()


def test_extended_near_target_does_not_hide_itself():
    # A diver-sized patch (1 m) at 2 m covers ~160 beams: an order-statistic background
    # keeps it detected as one blob of about its size.
    rng = np.random.default_rng(5)
    level = syn.polar_image(RANGES, [syn.Target(2.0, 0.05, -15.0, extent_m=1.0)], rng)
    found = blobs_of(level).blobs
    assert len(found) == 1
    b = found[0]
    assert b.range_m == pytest.approx(2.0, abs=0.15)
    assert 0.8 <= b.cross_extent_m <= 1.4 and 0.8 <= b.range_extent_m <= 1.4


def test_background_is_held_in_the_world_while_the_sonar_moves():
    # A static object (0.3 m) seen from a turning, advancing sonar stays on its background
    # blocks (small motion contrast); one that moved 1 m between pings stands out.
    grid = (RANGES.size // 4, syn.N_BEAMS // 4)
    model = BackgroundModel(RANGES, syn.BEAMS, grid, alpha=1.0)
    naive = BackgroundModel(RANGES, syn.BEAMS, grid, alpha=1.0)  # told nothing moved
    world = np.array([6.0, 1.0])
    contrast_static = contrast_moving = contrast_naive = 0.0
    for k in range(4):
        north, east, yaw = 0.3 * k, 0.1 * k, math.radians(4.0 * k)
        d = world - [north, east]
        c, s = math.cos(yaw), math.sin(yaw)
        x, y = c * d[0] + s * d[1], -s * d[0] + c * d[1]
        mover = (math.hypot(x, y) - 1.0 * k, math.atan2(y, x) - 0.1)
        level = syn.polar_image(RANGES, [
            syn.Target(math.hypot(x, y), math.atan2(y, x), extent_m=0.3),
            syn.Target(*mover, extent_m=0.3)], None, None)
        blocks = cv2.resize(level, grid[::-1], interpolation=cv2.INTER_AREA)
        contrast = cv2.resize(model.update(blocks, (north, east, yaw)), level.shape[::-1],
                              interpolation=cv2.INTER_NEAREST)
        fixed = cv2.resize(naive.update(blocks, (0.0, 0.0, 0.0)), level.shape[::-1],
                           interpolation=cv2.INTER_NEAREST)
        if k:
            i, j = np.unravel_index(np.argmin(abs(RANGES[:, None] - math.hypot(x, y))
                                              + abs(syn.BEAMS[None, :] - math.atan2(y, x))),
                                    level.shape)
            contrast_static = max(contrast_static, float(contrast[i, j]))
            contrast_naive = max(contrast_naive, float(fixed[i, j]))
            i, j = np.argmin(abs(RANGES - mover[0])), np.argmin(abs(syn.BEAMS - mover[1]))
            contrast_moving = min(contrast_moving or 1.0, float(contrast[i, j]))
    assert contrast_static < 0.15 < 0.3 < contrast_naive  # the compensation is what holds it
    assert contrast_moving > 0.5


def _point_blob(north, east, view):
    d_n, d_e = north - view.north, east - view.east
    r, b = math.hypot(d_n, d_e), math.atan2(d_e, d_n) - view.yaw
    return Blob(r, b, r * math.cos(b), r * math.sin(b), north, east, 0.0, 0.0, 20, 1, 0.8,
                0.7, 0.0, False)


@pytest.mark.slow
def test_constant_velocity_target_tracked_with_the_filters_predicted_error():
    # Truth moves by the filter's own model (white-noise acceleration); measurements carry
    # exactly the filter's measurement covariance. Then the normalised estimation error
    # squared (NEES) averaged over M runs is chi2(4M)/M distributed at every step
    # (Bar-Shalom et al. 2001, 5.4.2): check it lies in the 95 % interval at >= 90 % of
    # the steps and that the RMS position error matches the filter's predicted sigma.
    params = TrackerParams(accel_std=0.2, confirm_m=1, confirm_n=1, gate_chi2=40.0)
    view = FanView(0.0, 0.0, 0.0, 0.5, 30.0, math.radians(22.5))
    rng = np.random.default_rng(11)
    runs, steps, dt = 40, 120, 1.0 / 15.0
    nees = np.zeros((runs, steps))
    sq_err = np.zeros((runs, steps))
    predicted = np.zeros((runs, steps))
    q = params.accel_std ** 2
    Q = np.array([[dt**3 / 3, 0, dt**2 / 2, 0], [0, dt**3 / 3, 0, dt**2 / 2],
                  [dt**2 / 2, 0, dt, 0], [0, dt**2 / 2, 0, dt]]) * q
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    for run in range(runs):
        tracker = MultiTargetTracker(params)
        x = np.array([8.0, -1.0, -0.3, 0.4])
        for k in range(steps):
            if k:
                x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
            blob = _point_blob(x[0], x[1], view)
            R = measurement_covariance(blob, view.yaw, params)
            z = x[:2] + rng.multivariate_normal(np.zeros(2), R)
            tracker.step(k * dt, [_point_blob(z[0], z[1], view)], view)
            (tr,) = tracker.tracks
            if k == 0:  # a new track starts at rest: give it the truth's velocity prior
                tr.x[2:] = x[2:] + rng.normal(0, params.initial_speed_std, 2)
            e = tr.x - x
            nees[run, k] = e @ np.linalg.solve(tr.P, e)
            sq_err[run, k] = e[0] ** 2 + e[1] ** 2
            predicted[run, k] = tr.P[0, 0] + tr.P[1, 1]
    avg = nees[:, 10:].mean(axis=0)
    lo, hi = chi2.ppf([0.025, 0.975], 4 * runs) / runs
    assert np.mean((avg >= lo) & (avg <= hi)) >= 0.9
    assert 3.6 <= avg.mean() <= 4.4
    rms, model = math.sqrt(sq_err[:, 10:].mean()), math.sqrt(predicted[:, 10:].mean())
    assert rms == pytest.approx(model, rel=0.1)


def test_m_of_n_confirmation_coasting_and_deletion():
    params = TrackerParams(confirm_m=3, confirm_n=5, max_coast_s=1.0, max_coast_outside_s=3.0)
    view = FanView(0.0, 0.0, 0.0, 0.5, 10.0, math.radians(22.5))
    dt = 0.1
    # Seen twice then never: tentative, then deleted when 3 of 5 can no longer happen.
    tracker = MultiTargetTracker(params)
    for k in range(6):
        tracker.step(k * dt, [_point_blob(5.0, 0.0, view)] if k < 2 else [], view)
    assert tracker.tracks == [] and tracker.deleted[0].status == "tentative"
    # Seen 3 times: confirmed; then missed inside the fan: coasts max_coast_s, then goes.
    tracker = MultiTargetTracker(params)
    for k in range(3):
        tracker.step(k * dt, [_point_blob(5.0, 0.0, view)], view)
    assert tracker.tracks[0].confirmed
    t = 2 * dt
    while tracker.tracks:
        t += dt
        tracker.step(t, [], view)
    assert params.max_coast_s - 1e-9 <= t - 2 * dt <= params.max_coast_s + dt + 1e-9
    # A confirmed track whose prediction is outside the fan coasts max_coast_outside_s.
    tracker = MultiTargetTracker(params)
    for k in range(3):
        tracker.step(k * dt, [_point_blob(5.0, 0.0, view)], view)
    away = FanView(0.0, 0.0, math.pi, 0.5, 10.0, math.radians(22.5))  # looking backwards
    t = 2 * dt
    while tracker.tracks:
        t += dt
        tracker.step(t, [], away)
        if tracker.tracks:
            assert not tracker.tracks[0].visible
    assert params.max_coast_outside_s - 1e-9 <= t - 2 * dt <= params.max_coast_outside_s + dt + 1e-9


def test_two_crossing_targets_keep_their_identities():
    params = TrackerParams(confirm_m=2, confirm_n=3)
    view = FanView(0.0, 0.0, 0.0, 0.5, 20.0, math.radians(22.5))
    tracker = MultiTargetTracker(params)
    dt = 1.0 / 15.0
    for k in range(150):
        t = k * dt
        a = (6.0 + 0.5 * t, -2.0 + 0.4 * t)  # north-east
        b = (7.2 + 0.5 * t, 2.0 - 0.4 * t)  # north-west: they pass 1.2 m apart at t = 5 s
        pairs = tracker.step(t, [_point_blob(*a, view), _point_blob(*b, view)], view)
        if k == 10:
            ids = {j: i for i, j in pairs.items()}
    final = {j: i for i, j in pairs.items()}
    assert final == ids


def test_classifier_file_round_trip_and_refusals(tmp_path):
    shipped = DiverClassifier.load()
    assert DiverClassifier.from_dict(shipped.to_dict()) == shipped
    assert len(shipped.diver_mean) == len(FEATURES)
    bad = tmp_path / "c.json"
    bad.write_text('{"features": ["speed"]}')
    with pytest.raises(ConfigError, match="features must be"):
        DiverClassifier.load(bad)
    bad.write_text("{not json")
    with pytest.raises(ConfigError, match="not JSON"):
        DiverClassifier.load(bad)
    with pytest.raises(ConfigError, match="cannot read"):
        DiverClassifier.load(tmp_path / "missing.json")
    # A vote is the clipped Gaussian log-likelihood ratio: at the diver means it favours
    # the diver, at the clutter means the clutter.
    assert shipped.vote(np.array(shipped.diver_mean)) > 0
    assert shipped.vote(np.array(shipped.clutter_mean)) < 0


def test_nan_cells_and_empty_pings_do_not_break_the_pipeline():
    rng = np.random.default_rng(2)
    perception = SonarPerception()
    for k in range(60):
        level = syn.polar_image(RANGES, [syn.Target(5.0, 0.1, -10.0)] if k < 10 else [], rng)
        if k == 5:
            level[100:110, 50:60] = np.nan
            level[0, 0] = np.inf
        frame = perception.process(syn.Ping(k / 15.0, level, RANGES, syn.BEAMS))
        assert frame.bad_cells == (101 if k == 5 else 0)
        if k == 9:
            assert any(tr.confirmed for tr in frame.tracks)
    assert frame.blobs.blobs == () and frame.tracks == ()


def test_bad_settings_are_refused_naming_the_field():
    with pytest.raises(ConfigError, match=r"DetectorParams\.smooth_bins"):
        DetectorParams(smooth_bins=2)
    with pytest.raises(ConfigError, match=r"TrackerParams\.confirm_m"):
        TrackerParams(confirm_m=5, confirm_n=3)
    with pytest.raises(ConfigError, match=r"BlobParams\.min_cells"):
        BlobParams(min_cells=0)
