"""The blend floor: exact for one key set, a proven lower bound over all sets."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gaitcore.bench.blend_floor import MAX_SETS, best_blend_floor, blend_floor
from gaitcore.errors import GaitInputError
from gaitcore.progress import Cancelled


def test_hand_computed_floor():
    # key (1, 0) blends to (w, 0); the frame (0, 1) keeps |0 - w| + |1 - 0| >= 1 over 2 angles
    truth = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert blend_floor(truth, [0]) == pytest.approx(0.5 * 0.5)  # frame 0 exact, frame 1 0.5
    assert blend_floor(truth, [0, 1]) == pytest.approx(0.0, abs=1e-12)


def test_motion_in_the_span_of_two_poses_has_no_floor():
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(2, 12)) * 30
    truth = np.outer(np.cos(t), a) + np.outer(np.sin(t), b)
    assert blend_floor(truth, [3, 17]) == pytest.approx(0.0, abs=1e-9)
    best = best_blend_floor(truth, 2)
    assert best.achieved_deg == pytest.approx(0.0, abs=1e-9)
    assert best.lower_deg <= 1e-9


def test_repeated_cycles_count_like_one():
    rng = np.random.default_rng(2)
    cycle = rng.normal(size=(9, 7)) * 20
    once = best_blend_floor(cycle, 3)
    thrice = best_blend_floor(np.vstack([cycle] * 3), 3)
    assert thrice.n_sets == once.n_sets == 84
    assert thrice.lower_deg == pytest.approx(once.lower_deg)
    assert thrice.achieved_deg == pytest.approx(once.achieved_deg)
    assert blend_floor(np.vstack([cycle] * 3), [0, 1, 2]) == pytest.approx(
        blend_floor(cycle, [0, 1, 2]))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(4, 9), k=st.integers(2, 8),
       m=st.integers(1, 3))
def test_lower_bound_never_exceeds_the_exact_floor(seed, n, k, m):
    rng = np.random.default_rng(seed)
    truth = rng.normal(size=(n, k)) * rng.uniform(1, 50, size=k)
    m = min(m, n)
    exact = [blend_floor(truth, s) for s in combinations(range(n), m)]
    best = best_blend_floor(truth, m)
    assert best.lower_deg <= min(exact) + 1e-9
    assert best.achieved_deg >= min(exact) - 1e-9
    assert best.achieved_deg == pytest.approx(blend_floor(truth, best.key_frames))


def test_bound_is_close_on_a_gait():
    from gaitcore.bench.gaits import generate_gait
    from gaitcore.rig.templates import load_template

    horse = load_template("horse")
    truth = generate_gait(horse, "gallop", 48, period_frames=12)[:, horse.sagittal_angle_indices]
    best = best_blend_floor(truth, 3)
    exact = min(blend_floor(truth, s) for s in combinations(range(12), 3))
    assert best.n_sets == 220
    assert 0.6 * exact <= best.lower_deg <= exact <= best.achieved_deg + 1e-9


@pytest.mark.parametrize(
    ("truth", "keys", "match"),
    [
        (np.ones((3, 2)), [3], "key frames must be in 0..2"),
        (np.ones((3, 2)), [], "key frames"),
        (np.array([[1.0, np.nan]]), [0], "NaN"),
        (np.ones(3), [0], r"\(n frames, k angles\)"),
    ],
)
def test_blend_floor_rejects_bad_input(truth, keys, match):
    with pytest.raises(GaitInputError, match=match):
        blend_floor(truth, keys)


def test_best_floor_rejects_bad_input():
    truth = np.random.default_rng(0).normal(size=(6, 3))
    with pytest.raises(GaitInputError, match="between 1 and the 6 distinct poses"):
        best_blend_floor(truth, 7)
    with pytest.raises(GaitInputError, match=f"more than {MAX_SETS}"):
        best_blend_floor(np.random.default_rng(0).normal(size=(200, 3)), 5)
    with pytest.raises(Cancelled, match="stopped"):
        best_blend_floor(truth, 2, progress=lambda done, total: False)
