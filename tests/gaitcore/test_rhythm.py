"""The gait's rhythm below a drift: the cycle from the repeats, the pair it lives in."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.analysis.analyze import AnalysisSettings, analyze_features
from gaitcore.analysis.rhythm import (
    MIN_CYCLES,
    cycle_lag,
    find_rhythm,
    longest_period,
    repeat_curve,
    slow_trend,
)
from gaitcore.analysis.spectrum import diagnose, fisher_periodicity_p


def _drifting(n=60, period=17.0, seed=0):
    """A loop of the given period in components 3 and 4, under two large drifts."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    drift = np.column_stack([8 * t / n, 6 * (t / n) ** 2])
    w = 2 * np.pi * t / period
    loop = np.column_stack([np.cos(w), np.sin(w)])
    return np.column_stack([drift, loop, 0.3 * rng.standard_normal((n, 3))])


def test_the_cycle_is_found_below_the_drift_in_the_components_that_carry_it():
    rhythm = find_rhythm(_drifting())
    assert rhythm.lag_frames == pytest.approx(17.0, rel=0.05)
    assert set(rhythm.order[:2]) == {2, 3}
    assert rhythm.drift_share[0] > 0.9 and rhythm.drift_share[2] < 0.25
    # PC1 (the drift) would have given the paper's diagnosis a period as long as the clip
    assert diagnose(_drifting()).period_frames > 40


def test_a_walk_whose_half_cycles_differ_a_little_has_its_whole_cycle():
    t = np.arange(120)
    stride = 24.0
    w = 2 * np.pi * t / stride
    # the silhouette repeats every half stride, but the two halves are not quite alike
    x = np.column_stack([np.cos(2 * w), np.sin(2 * w), 0.4 * np.cos(w), 0.4 * np.sin(w)])
    rhythm = find_rhythm(x)
    # the first deep repeat is the half stride; the walk's cycle is twice the pair's loop
    assert rhythm.period_frames == pytest.approx(stride / 2, abs=0.3)
    assert rhythm.period_frames * rhythm.loops_per_cycle == pytest.approx(stride, abs=0.6)


def test_silhouettes_that_repeat_exactly_each_half_cycle_are_read_as_a_walk():
    t = np.arange(100)
    w = 2 * np.pi * t / 20.0
    rhythm = find_rhythm(np.column_stack([np.cos(w), np.sin(w)]))
    assert rhythm.lag_frames == pytest.approx(20.0, abs=0.3) and not rhythm.half_dip
    assert rhythm.loops_per_cycle == 2  # the paper's reading: two turns per walk cycle


def test_no_gait_in_noise_nor_a_cycle_in_a_drift_nor_in_a_single_repeat():
    settings = AnalysisSettings(key_time_limit_s=2.0)
    verdicts = [analyze_features(np.random.default_rng(s).standard_normal((80, 4)),
                                 settings).diagnosis.verdict.value for s in range(30)]
    assert "usable" not in verdicts  # a chance dip of the repeat curve is no rhythm
    t = np.linspace(0, 1, 80)
    assert find_rhythm(np.column_stack([t, t**2, t**3])).lag_frames is None
    # an animal that walks on and comes back once: the lag is longer than half the clip
    w = 2 * np.pi * np.arange(60) / 40.0
    once = find_rhythm(np.column_stack([np.cos(w), np.sin(w)]))
    assert once.lag_frames is None and once.slow_lag_frames == pytest.approx(40, abs=1.5)
    assert longest_period(60) == 60 / MIN_CYCLES


def test_the_first_deep_dip_not_its_multiple():
    curve = np.ones(40)
    curve[9], curve[19], curve[29] = 0.3, 0.2, 0.25  # dips at lags 10, 20, 30
    assert cycle_lag(curve) == pytest.approx(10.0, abs=0.5)
    curve[9] = 0.95  # a shallow wobble is not a dip
    assert cycle_lag(curve) == pytest.approx(20.0, abs=0.5)


def test_repeat_curve_and_trend_shapes():
    x = _drifting(48)
    assert repeat_curve(x, 10).shape == (10,)
    assert slow_trend(x[:, 0], 20).shape == (48,)
    long = np.sin(np.arange(600) / 3.0)  # a fast rhythm on a long clip: no trend to take
    assert np.abs(slow_trend(long, 100)).max() < 0.1


def test_the_pair_loop_is_a_stronger_test_than_one_component():
    rng = np.random.default_rng(2)
    t = np.arange(43)
    w = 2 * np.pi * t / 17.0
    a = np.cos(w) + 0.8 * rng.standard_normal(43)
    b = np.sin(w) + 0.8 * rng.standard_normal(43)
    assert fisher_periodicity_p(a + 1j * b) < fisher_periodicity_p(a)
    noise = [fisher_periodicity_p(np.random.default_rng(s).standard_normal(64)
                                  + 1j * np.random.default_rng(s + 999).standard_normal(64))
             for s in range(200)]
    assert sum(p < 0.01 for p in noise) <= 6  # p is uniform under the null hypothesis
