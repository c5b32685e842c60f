"""The paper's open-loop experiment (Figs 5-8), checked quantitatively."""

import csv

import numpy as np
import pytest

from uhrisim.experiments.openloop import CSV_COLUMNS, make_openloop, run_openloop


@pytest.fixture(scope="module")
def run():
    return run_openloop()


def signed_area(north: np.ndarray, east: np.ndarray) -> float:
    """Shoelace area in the (east, north) plane seen from above: > 0 counter-clockwise."""
    return 0.5 * float(np.sum(east[:-1] * north[1:] - east[1:] * north[:-1]))


def test_turns_counter_clockwise_seen_from_above(run):
    thrusting = run.t <= 5.0
    s = run.states[thrusting]
    assert signed_area(s[:, 0], s[:, 1]) > 0.5  # m^2, a clear CCW arc (Fig. 5)
    assert np.all(s[50:, 7] < 0.0)  # yaw rate negative: heading decreases, i.e. to port
    assert s[-1, 3] < -np.pi  # more than half a turn to port in 5 s


def test_gets_deeper(run):
    depth = run.states[:, 2]
    assert depth[500] > 1.0 and np.all(np.diff(depth) >= -1e-12)  # Fig. 7


def test_velocities_decay_after_thrust_stops_with_no_rotation(run):
    tail = run.states[run.t >= 6.0]
    for column in (4, 5, 6):
        speed = np.abs(tail[:, column])
        assert np.all(np.diff(speed) <= 1e-12), f"state {column} does not decay"
        assert speed[-1] < 0.05 * max(speed[0], 1e-9) + 1e-6
    # No rotation in the tail: yaw damping stops the turn within ~2 s (J/|Nr| ~ 0.5 s).
    assert np.max(np.abs(run.states[run.t >= 8.0, 7])) < 1e-3  # rad/s
    heading_drift = tail[-1, 3] - tail[0, 3]
    assert abs(heading_drift) < 0.01  # rad, after t = 6 s


def test_rk4_agrees_with_adaptive_lsoda_like_the_authors(run):
    lsoda = run_openloop(method="lsoda")
    assert np.max(np.abs(lsoda.states[:, :3] - run.states[:, :3])) < 1e-3  # metres


def test_csv_and_figures_are_written(tmp_path):
    paths = make_openloop(tmp_path)
    names = sorted(p.name for p in paths)
    assert names == sorted(["openloop.csv", "openloop_track.png", "openloop_inputs.png",
                            "openloop_positions.png", "openloop_velocities.png"])
    with (tmp_path / "openloop.csv").open() as handle:
        rows = list(csv.reader(handle))
    assert tuple(rows[0]) == CSV_COLUMNS
    assert len(rows) == 1 + 3001  # 0..30 s every 0.01 s
    assert float(rows[-1][0]) == pytest.approx(30.0)
    for path in paths[1:]:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
