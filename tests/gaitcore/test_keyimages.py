"""Key-image selection (paper Section 3.1) against a brute-force enumeration."""

from __future__ import annotations

import itertools
import time
from math import comb, log

import numpy as np
import pytest

from gaitcore.analysis.keyimages import KeySelection, condition_curve, select_key_images
from gaitcore.errors import GaitInputError
from gaitcore.progress import Cancelled

ALPHA = log(2.0)


def _conds(points: np.ndarray, sets: np.ndarray, alpha: float = ALPHA) -> np.ndarray:
    """cond(HᵀH) of each row of ``sets``; +inf when λmin <= 1e-12 λmax (singular)."""
    d2 = ((points[:, None, :] - points[None, :, :]) ** 2).sum(-1)
    kernel = np.exp(-alpha * d2)
    w = np.linalg.eigvalsh(kernel[sets[:, :, None], sets[:, None, :]])
    lo, hi = w[:, 0], w[:, -1]
    out = np.full(lo.shape, np.inf)
    ok = lo > 1e-12 * hi
    out[ok] = (hi[ok] / lo[ok]) ** 2
    return out


def _brute_force(points, m, *, pinned=(), forbidden=(), alpha=ALPHA) -> float:
    """Smallest cond(HᵀH) over every allowed m-subset (the paper's enumeration)."""
    pinned = sorted(pinned)
    free = [f for f in range(len(points)) if f not in pinned and f not in forbidden]
    combos = np.array(list(itertools.combinations(free, m - len(pinned))), dtype=int)
    sets = np.sort(np.column_stack([np.tile(pinned, (len(combos), 1)).astype(int), combos]), 1)
    return float(_conds(points, sets, alpha).min())


def _assert_same_optimum(points, result: KeySelection, m, pinned=(), forbidden=()):
    best = _brute_force(points, m, pinned=pinned, forbidden=forbidden)
    frames = result.frames
    assert len(frames) == m and list(frames) == sorted(set(frames))
    assert set(pinned) <= set(frames) and not set(forbidden) & set(frames)
    assert result.exact is True
    own = _conds(points, np.array([frames]))[0]
    if np.isinf(best):
        assert np.isinf(result.condition_number)
        return
    # Rounding grows with the conditioning (near-duplicate frames); ties may pick other sets.
    rtol = 1e-8 + 1e-13 * np.sqrt(best)
    assert result.condition_number == pytest.approx(best, rel=rtol)
    assert own == pytest.approx(best, rel=rtol)


def _random_case(rng: np.random.Generator):
    m = int(rng.integers(1, 6))
    n_max = {1: 30, 2: 30, 3: 30, 4: 30, 5: 22}[m]
    n = int(rng.integers(m, n_max + 1))
    c = int(rng.integers(1, 4))
    kind = rng.integers(4)
    if kind == 0:  # scattered
        points = rng.normal(size=(n, c)) * rng.uniform(0.3, 3.0)
    elif kind == 1:  # a noisy loop, like PCA projections of a gait cycle
        phase = 2 * np.pi * rng.uniform(1, 3) * np.arange(n) / n
        points = np.column_stack([np.sin(phase), np.cos(phase), np.sin(2 * phase)])[:, :c]
        points = points * np.sqrt(2) + 0.05 * rng.normal(size=(n, c))
    else:  # clusters of near-duplicates (tiny perturbations of the same point)
        n_centres = max(m, int(rng.integers(1, n + 1)))
        centres = rng.normal(size=(n_centres, c)) * 1.5
        points = centres[rng.integers(n_centres, size=n)]
        points[:n_centres] = centres
        scale = 1e-4 if kind == 2 else [1e-3, 1e-4, 1e-10][int(rng.integers(3))]
        points = points + scale * rng.normal(size=points.shape)
    return points, m


@pytest.mark.parametrize("seed", range(4))
def test_matches_brute_force_on_random_small_cases(seed):
    rng = np.random.default_rng(1000 + seed)
    for _ in range(60):
        points, m = _random_case(rng)
        _assert_same_optimum(points, select_key_images(points, m), m)


def _first_allowed_only(kernel, m, pinned, pool, starts, deadline):
    """A deliberately poor incumbent (the pinned frames and the first allowed ones)."""
    frames = list(pinned) + [int(f) for f in pool[: m - len(pinned)]]
    w = np.linalg.eigvalsh(kernel[np.ix_(frames, frames)])
    return frames, float((w[-1] / w[0]) ** 2) if w[0] > 1e-12 * w[-1] else float("inf")


@pytest.mark.parametrize("seed", range(2))
def test_exact_search_does_not_rely_on_a_good_starting_set(seed, monkeypatch):
    monkeypatch.setattr("gaitcore.analysis.keyimages._local_search", _first_allowed_only)
    rng = np.random.default_rng(2000 + seed)
    for _ in range(60):
        points, m = _random_case(rng)
        _assert_same_optimum(points, select_key_images(points, m), m)


@pytest.mark.parametrize("poor_start", [False, True])
@pytest.mark.parametrize("seed", range(2))
def test_pinned_and_forbidden_frames_are_honoured_and_optimal(seed, poor_start, monkeypatch):
    if poor_start:
        monkeypatch.setattr("gaitcore.analysis.keyimages._local_search", _first_allowed_only)
    rng = np.random.default_rng(3000 + seed)
    for _ in range(25):
        points, m = _random_case(rng)
        n = len(points)
        if np.unique(points, axis=0).shape[0] < n or n < m + 2:
            continue
        order = rng.permutation(n)
        n_pinned, n_forbidden = int(rng.integers(0, m + 1)), int(rng.integers(0, n - m + 1))
        pinned = tuple(int(f) for f in order[:n_pinned])
        forbidden = tuple(int(f) for f in order[n_pinned : n_pinned + n_forbidden])
        result = select_key_images(points, m, pinned=pinned, forbidden=forbidden)
        _assert_same_optimum(points, result, m, pinned, forbidden)


def test_farthest_pair_wins_on_a_line():
    points = np.array([[0.0], [0.4], [1.0], [3.0], [3.2]])
    result = select_key_images(points, 2)
    assert result.frames == (0, 4)
    k = np.exp(-ALPHA * 3.2**2)
    assert result.condition_number == pytest.approx(((1 + k) / (1 - k)) ** 2)


def test_identical_frames_are_never_chosen_together():
    points = np.array([[0.0, 0.0], [0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    result = select_key_images(points, 3)
    assert result.frames == (0, 2, 3)
    # The twin of a pinned frame is no candidate either.
    assert select_key_images(points, 3, pinned=[1]).frames == (1, 2, 3)
    with pytest.raises(GaitInputError, match="only 2 frames are allowed"):
        select_key_images(points, 3, forbidden=[2])


def test_only_singular_sets_left_gives_infinite_condition():
    points = np.array([[0.0], [1e-10], [3.0]])
    result = select_key_images(points, 3)
    assert result.frames == (0, 1, 2) and np.isinf(result.condition_number) and result.exact


POINTS = np.random.default_rng(7).normal(size=(12, 2))


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((POINTS, 0), {}, "integer >= 1"),
        ((POINTS, -2), {}, "integer >= 1"),
        ((POINTS, 2.5), {}, "integer >= 1"),
        ((POINTS, 13), {}, "12 frames"),
        ((POINTS[:, 0], 2), {}, "2-D"),
        ((POINTS[None], 2), {}, "2-D"),
        ((np.zeros((0, 2)), 1), {}, "2-D"),
        ((np.where(np.arange(24).reshape(12, 2) == 5, np.nan, POINTS), 3), {}, "NaN"),
        ((np.where(np.arange(24).reshape(12, 2) == 5, np.inf, POINTS), 3), {}, "NaN"),
        ((np.repeat(POINTS[:2], 6, axis=0), 3), {}, "distinct"),
        ((POINTS, 3), {"pinned": [12]}, "pinned frame 12 is out of range"),
        ((POINTS, 3), {"pinned": [-1]}, "out of range"),
        ((POINTS, 3), {"forbidden": [40]}, "forbidden frame 40"),
        ((POINTS, 3), {"pinned": [1, 2], "forbidden": [2, 5]}, "both pinned and forbidden"),
        ((POINTS, 2), {"pinned": [1, 2, 3]}, "3 frames are pinned"),
        ((POINTS, 4), {"forbidden": range(9)}, "only 3 frames are allowed"),
        ((POINTS, 3), {"alpha": 0.0}, "alpha"),
        ((POINTS, 3), {"pinned": [1.5]}, "integer frame indices"),
        ((POINTS, 3), {"time_limit_s": -1.0}, "time_limit_s"),
    ],
)
def test_bad_input_raises_a_one_line_message(args, kwargs, match):
    with pytest.raises(GaitInputError, match=match) as info:
        select_key_images(*args, **kwargs)
    assert "\n" not in str(info.value)


def test_two_pinned_twins_are_rejected():
    points = np.array([[0.0], [0.0], [1.0], [2.0]])
    with pytest.raises(GaitInputError, match="identical"):
        select_key_images(points, 3, pinned=[0, 1])


def _loop(n: int = 60, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    phase = 2 * np.pi * 2.3 * np.arange(n) / n
    points = np.column_stack([np.sin(phase), np.cos(phase)]) + 0.05 * rng.normal(size=(n, 2))
    return (points - points.mean(0)) / points.std(0)


def test_progress_is_monotone_and_ends_complete():
    calls = []
    result = select_key_images(_loop(), 5, progress=lambda done, total: calls.append((done, total)))
    assert result.exact and len(calls) >= 2
    assert all(0 <= d <= t for d, t in calls)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)
    assert calls[-1][0] == calls[-1][1]


def test_progress_returning_false_cancels():
    with pytest.raises(Cancelled):
        select_key_images(_loop(), 5, progress=lambda done, total: False)


def test_time_limit_returns_a_valid_set_not_proven_optimal():
    points = _loop(137)
    start = time.monotonic()
    result = select_key_images(points, 6, time_limit_s=0.0)
    assert time.monotonic() - start < 2.0
    assert result.exact is False
    assert len(result.frames) == 6 and list(result.frames) == sorted(set(result.frames))
    own = _conds(points, np.array([result.frames]))[0]
    assert result.condition_number == pytest.approx(own, rel=1e-9)


def test_condition_curve_matches_single_searches_and_grows_with_m():
    points = _loop(40)
    curve = condition_curve(points, [4, 2, 3], forbidden=[0])
    assert [len(s.frames) for s in curve] == [4, 2, 3]
    for sel, m in zip(curve, [4, 2, 3]):
        assert sel.exact and 0 not in sel.frames
        alone = select_key_images(points, m, forbidden=[0])
        assert sel.condition_number == pytest.approx(alone.condition_number, rel=1e-9)
    assert curve[1].condition_number <= curve[2].condition_number <= curve[0].condition_number
    with pytest.raises(GaitInputError, match="at least one"):
        condition_curve(points, [])
    with pytest.raises(GaitInputError, match="40 frames"):
        condition_curve(points, [3, 41])


def test_benchmark_sized_clip_is_exact_and_matches_a_sampled_lower_bound():
    # 137 frames, m = 4: every one of 20,000 random 4-subsets is no better than the result.
    points = _loop(137, seed=3)
    result = select_key_images(points, 4)
    assert result.exact
    rng = np.random.default_rng(0)
    sets = np.sort(np.array([rng.choice(137, 4, replace=False) for _ in range(20_000)]), 1)
    assert _conds(points, sets).min() >= result.condition_number * (1 - 1e-9)
    assert comb(137, 4) > 100 * result.nodes_visited


@pytest.mark.parametrize("max_level_rows", [4_000_000, 3, 0])
def test_branching_above_the_levelwise_depth_is_exact(max_level_rows, monkeypatch):
    # m >= 6 branches on its first frames before growing sets level by level; with a tiny
    # memory guard the level-wise searches give up and branch further.
    monkeypatch.setattr("gaitcore.analysis.keyimages._local_search", _first_allowed_only)
    monkeypatch.setattr("gaitcore.analysis.keyimages._MAX_LEVEL_ROWS", max_level_rows)
    rng = np.random.default_rng(4000 + max_level_rows)
    for _ in range(4):
        n, m = int(rng.integers(9, 15)), int(rng.integers(6, 8))
        points = _loop(n, seed=int(rng.integers(1000)))[:, : int(rng.integers(1, 3))]
        pinned = [int(rng.integers(n))] if rng.random() < 0.5 else []
        calls = []
        result = select_key_images(points, m, pinned=pinned, progress=lambda d, t: calls.append(d))
        _assert_same_optimum(points, result, m, pinned)
        assert calls == sorted(calls) and calls[-1] == 1_000_000


def test_long_clips_are_thinned_and_reported_not_exact():
    # 5,000 frames of a noisy loop: the kernel over every frame would take 200 MB and the
    # search would crawl; candidates are thinned to one per cell of a PCA-space grid.
    t = np.arange(5000)
    rng = np.random.default_rng(0)
    p = np.column_stack([np.cos(t / 16 * 2 * np.pi), np.sin(t / 16 * 2 * np.pi)])
    p += 0.05 * rng.standard_normal(p.shape)
    sel = select_key_images(p, 4, time_limit_s=30)
    assert sel.exact is False
    assert len(set(sel.frames)) == 4 and all(0 <= f < 5000 for f in sel.frames)
    # The thinned search is no worse (5 % slack) than the exact optimum over the first 137
    # frames, which run round the same loop.
    small = select_key_images(p[:137], 4)
    assert sel.condition_number <= 1.05 * small.condition_number
