"""The sonar's reading of the two-arm wave (perception/sonar_wave.py)."""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.experiments.signal_range import sonar_trial
from uhrisim.perception.sonar_wave import MIN_PERIODICITY, MIN_STRENGTH, wave_score

RATE = 5.0


def _window(signal, seed=0, noise=0.05):
    t = np.arange(40) / RATE
    rng = np.random.default_rng(seed)
    return 1.0 + signal(t) + noise * rng.standard_normal(t.size)


def test_a_swing_at_the_cycle_is_periodic_and_strong():
    periodicity, strength = wave_score(_window(lambda t: 0.4 * np.cos(2 * np.pi * t / 2.6)),
                                       RATE)
    # the biased autocorrelation: a pure swing gives the overlap share at one cycle, ~0.54
    assert periodicity > 0.45 and strength > 0.2


@pytest.mark.parametrize("signal", [
    lambda t: 0.0 * t,                            # speckle alone
    lambda t: 0.6 * (t > 3.0),                    # the arms come out and stay (``done``)
    lambda t: 0.4 * np.cos(2 * np.pi * t / 1.0),  # a beckon's quick stroke
])
def test_speckle_a_step_or_a_quick_stroke_is_no_wave(signal):
    for seed in range(5):
        periodicity, strength = wave_score(_window(signal, seed), RATE)
        assert periodicity < MIN_PERIODICITY or strength < MIN_STRENGTH


@pytest.mark.slow
def test_the_rendered_wave_is_read_at_3_m_and_no_other_gesture_is():
    # articulated diver, P900-90 level at his chest, pings at 5 Hz; read: the wave said
    # come_here while he waved; false: another gesture said it
    trial = sonar_trial(3.0, seed=1, names=("wave_both_arms", "done", "come_here", "go_up"))
    assert (trial.read, trial.false) == (1, 0)
    far = sonar_trial(10.0, seed=1, names=("wave_both_arms",))
    assert far.read == 0  # the fan's ±10° covers the raised arms out there: no swing to see
