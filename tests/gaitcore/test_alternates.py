"""Alternates half a stride away, never beside their keys; a warning when they are."""

from __future__ import annotations

import pytest

from gaitcore import GaitInputError
from gaitcore.analysis.alternates import (
    left_right_swaps,
    loop_angle,
    propose_alternates,
    swap_warning,
)
from tests.gaitcore.test_switching import _ambiguous_walk

HALF = 20.0  # the loop's period: half the 40-frame gait cycle of _ambiguous_walk


def test_a_short_noisy_clip_gets_alternates_half_a_stride_away():
    # 1.5 turns of the loop: too short for the loop angle alone, which then allowed any
    # frame 3 or more frames away, the neighbours of the key among them.
    keys = (3, 9, 14, 25)
    for seed in range(6):
        coords, _ = _ambiguous_walk(n=34, noise=0.5, seed=seed)  # seeds 1, 3, 4 fooled it
        theta = loop_angle(coords)
        alts = propose_alternates(coords, keys, theta=theta, period_frames=HALF)
        for k, a in zip(keys, alts):
            assert abs(abs(a - k) - HALF) <= HALF / 4, (seed, k, a)


def test_never_within_a_quarter_period_even_with_noise():
    for seed in range(5):
        coords, _ = _ambiguous_walk(n=120, noise=0.3, seed=seed)
        theta = loop_angle(coords)
        keys = (5, 31, 58, 90)
        alts = propose_alternates(coords, keys, theta=theta, period_frames=HALF)
        for k, a in zip(keys, alts):
            off = abs(a - k) % (2 * HALF)
            assert min(off, 2 * HALF - off) >= HALF / 2, (seed, k, a)


def test_no_frame_half_a_stride_away_is_said():
    coords, _ = _ambiguous_walk(n=16)
    with pytest.raises(GaitInputError, match="about 20 frames .half a stride. from key 2"):
        propose_alternates(coords, (2,), theta=loop_angle(coords), period_frames=HALF)


def test_swaps_per_cycle_and_the_warning():
    coords, _ = _ambiguous_walk(n=120)
    theta = loop_angle(coords)
    keys = (2, 7, 12, 17)
    good = propose_alternates(coords, keys, theta=theta, period_frames=HALF)
    assert left_right_swaps(theta, keys, good) == 2
    assert swap_warning(theta, keys, good) is None
    beside = tuple(k + 3 for k in keys)  # what the nearest frame 3 away gives
    assert left_right_swaps(theta, keys, beside) == 8
    warning = swap_warning(theta, keys, beside)
    assert "8 times per gait cycle" in warning and "twice" in warning
    assert swap_warning(theta, keys, ()) is None


@pytest.mark.slow
def test_synthetic_walk_with_mask_noise_keeps_alternates_half_a_stride_away():
    from gaitcore.bench.evaluate import BenchSettings, evaluate_gait

    ev = evaluate_gait(BenchSettings(gait="walk", mask_noise=0.05), pcs=(2,), keys=(4,),
                       switching=True)
    cell = ev.cell(2, 4, switching=True)
    assert cell.mean_deg <= 2.5
    half = ev.period_frames  # PC1's period: half the walk's cycle
    keys = ev.analyses[(2, 4)].key_frames
    for k, a in zip(keys, cell.alternate_frames):
        off = abs(a - k) % (2 * half)
        assert min(off, 2 * half - off) >= half / 2, (k, a)  # a quarter cycle at least
