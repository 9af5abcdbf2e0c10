"""Weights of the posed frames over time (paper Fig. 10) and one looping gait cycle."""

import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.analysis.alternates import loop_angle, propose_alternates
from gaitcore.animation.animate import animate
from gaitcore.animation.weights import interpolation_weights, loop_cycle


def _loop(n=120, period=40.0, turns_per_cycle=1):
    w = 2 * np.pi * np.arange(n) / period
    coords = np.column_stack([np.cos(turns_per_cycle * w), np.sin(turns_per_cycle * w)])
    poses = np.column_stack([30 * np.sin(w), 20 * np.cos(w) + 5 * np.sin(2 * w)])
    return coords, poses


def test_weights_are_one_hot_at_the_keys_and_reproduce_animate():
    coords, poses = _loop()
    keys = (3, 13, 23, 33)
    result = interpolation_weights(coords, keys)
    assert result.pose_frames == keys and result.states is None
    np.testing.assert_allclose(result.weights[list(keys)], np.eye(4), atol=1e-12)
    curves = animate(coords, keys, {f: poses[f] for f in keys})
    np.testing.assert_allclose(result.weights @ poses[list(keys)], curves, atol=1e-9)
    assert np.all(np.abs(result.total - 1) < 0.5)


def test_switching_weights_use_the_active_set_only():
    coords, poses = _loop(turns_per_cycle=2)  # the silhouettes repeat every half cycle
    theta = loop_angle(coords)
    keys = (2, 7, 12, 17)
    alts = propose_alternates(coords, keys, theta=theta)
    posed = {f: poses[f] for f in keys + alts}
    result = interpolation_weights(coords, keys, alternate_frames=alts, theta=theta)
    assert sorted(result.pose_frames) == sorted(keys + alts)
    assert result.weights.shape == (120, 8)
    assert np.all(np.count_nonzero(result.weights, axis=1) <= 4)
    stacked = np.stack([posed[f] for f in result.pose_frames])
    curves = animate(coords, keys, posed, alternate_frames=alts, theta=theta)
    active = result.weights != 0
    means = np.stack([stacked[row].mean(axis=0) for row in active])  # each set's mean pose
    blended = means + np.einsum("tp,tpk->tk", result.weights, stacked[None] - means[:, None])
    np.testing.assert_allclose(blended, curves, atol=1e-9)


def test_loop_cycle_closes_on_itself():
    _, poses = _loop(n=100, period=40.0)
    drifting = poses + np.linspace(0, 3, 100)[:, None]
    start, cycle = loop_cycle(drifting, 40.2)
    assert cycle.shape == (40, 2) and 0 <= start <= 60
    # The step from the last frame back to the first is an ordinary step of the cycle.
    steps = np.linalg.norm(np.diff(cycle, axis=0), axis=1)
    assert np.linalg.norm(cycle[0] - cycle[-1]) <= steps.max() + 1e-9
    np.testing.assert_allclose(cycle[0], drifting[start])


def test_loop_cycle_refuses_bad_periods():
    with pytest.raises(GaitInputError, match="period"):
        loop_cycle(np.zeros((50, 2)), float("nan"))
    with pytest.raises(GaitInputError, match="shorter"):
        loop_cycle(np.zeros((30, 2)), 30.0)
