import numpy as np
import pytest

from gaitcore import GaitInputError
from gaitcore.analysis.alternates import loop_angle, propose_alternates
from gaitcore.analysis.keyimages import select_key_images
from gaitcore.animation.rbf import RBFPoseMap
from gaitcore.animation.switching import SwitchingModel, switching_sets


def test_sets_are_the_papers_sigma():
    expected = np.array([[1, 2, 3, 4], [3, 4, 5, 6], [5, 6, 7, 8], [7, 8, 1, 2]]) - 1
    np.testing.assert_array_equal(switching_sets(8, 4), expected)


def test_sets_refuse_uneven_splits():
    with pytest.raises(GaitInputError):
        switching_sets(8, 3)
    with pytest.raises(GaitInputError):
        switching_sets(7, 4)


def _ambiguous_walk(n=120, period=40.0, noise=0.0, seed=0):
    """Silhouettes repeat every half-cycle (the loop is run twice per cycle); poses do not."""
    t = np.arange(n)
    w = 2 * np.pi * t / period
    coords = np.column_stack([np.cos(2 * w), np.sin(2 * w)])
    coords += noise * np.random.default_rng(seed).standard_normal(coords.shape)
    poses = np.column_stack([30 * np.sin(w), 20 * np.cos(w) + 5 * np.sin(2 * w)])
    return coords, poses


def test_loop_angle_counts_turns_and_never_goes_back():
    coords, _ = _ambiguous_walk(noise=0.15)
    theta = loop_angle(coords)
    assert np.all(np.diff(theta) >= 0)
    assert (theta[-1] - theta[0]) / (2 * np.pi) == pytest.approx(6.0, abs=0.5)
    # Direction of travel is normalised.
    assert np.all(np.diff(loop_angle(coords[:, ::-1])) >= 0)


def test_alternates_are_in_the_other_half_cycle():
    coords, _ = _ambiguous_walk()
    theta = loop_angle(coords)
    keys = (2, 7, 12, 17)
    alts = propose_alternates(coords, keys, theta=theta)
    half = np.floor((theta - theta[0]) / (2 * np.pi)).astype(int) % 2
    for k, a in zip(keys, alts):
        assert abs(k - a) >= 3
        assert half[k] != half[a]
        # Same silhouette: the nearest frame of the other half-cycle is exactly 20 frames off.
        assert abs(k - a) % 40 == 20


def test_switching_recovers_the_whole_cycle_where_one_model_cannot():
    coords, poses = _ambiguous_walk(noise=0.02)
    theta = loop_angle(coords)
    keys = select_key_images(coords, 4).frames
    alts = propose_alternates(coords, keys, theta=theta)
    posed = {f: poses[f] for f in keys + alts}
    model = SwitchingModel.fit(coords, theta, keys, alts, posed)
    switched = model.predict(coords, theta)
    single = RBFPoseMap.fit(coords[list(keys)], poses[list(keys)]).predict(coords)
    err_switched = np.abs(switched - poses).mean()
    err_single = np.abs(single - poses).mean()
    assert err_switched < 0.25 * err_single
    np.testing.assert_allclose(switched[list(keys + alts)], poses[list(keys + alts)], atol=1e-6)


def test_states_follow_the_paper_order_and_switch_at_keys():
    coords, poses = _ambiguous_walk()
    theta = loop_angle(coords)
    keys = (1, 6, 11, 16)
    alts = propose_alternates(coords, keys, theta=theta)
    model = SwitchingModel.fit(coords, theta, keys, alts, {f: poses[f] for f in keys + alts})
    states = model.states(theta)
    changes = np.nonzero(np.diff(states))[0] + 1
    # The state only ever advances by one set, cyclically.
    assert np.all((states[changes] - states[changes - 1]) % 4 == 1)
    # It changes when the clip reaches the phase of the last pose of the outgoing set
    # (the same frame modulo the 40-frame cycle, give or take the sampling of one frame).
    last_pose_frames = np.array([model.pose_frames[s[-1]] for s in model.sets])
    offset = (changes[:, None] - last_pose_frames[None, :]) % 40
    assert np.all(np.min(np.minimum(offset, 40 - offset), axis=1) <= 1)


def test_bad_input():
    coords, poses = _ambiguous_walk()
    theta = loop_angle(coords)
    with pytest.raises(GaitInputError, match="no pose"):
        SwitchingModel.fit(coords, theta, (1, 6), (21, 26), {1: poses[1]})
    with pytest.raises(GaitInputError, match="one alternate"):
        SwitchingModel.fit(coords, theta, (1, 6), (21,), {})
    with pytest.raises(GaitInputError, match="both as a key"):
        SwitchingModel.fit(coords, theta, (1, 6), (6, 26), {})
    with pytest.raises(GaitInputError, match="too short"):
        propose_alternates(coords[:3], (1,))


def test_alternates_are_an_odd_number_of_turns_away_for_every_key():
    # Regression: half-cycle parity taken as floor(turns since frame 0) split a key lying
    # just past a boundary (1.02 turns) from the same pose one cycle later (2.97 turns), and
    # that frame was proposed as its "alternate". What counts is the turns between the two.
    coords, _ = _ambiguous_walk(n=120, period=40.0)
    w = 2 * np.pi * np.arange(120) / 40.0
    coords = coords + 0.15 * np.column_stack([np.cos(w), np.sin(w)])  # half-cycles differ a bit
    theta = loop_angle(coords)
    keys = tuple(range(0, 120, 17))  # a frame (and a silhouette) poses one thing only
    for key, alt in zip(keys, propose_alternates(coords, keys, theta=theta)):
        turns = abs(theta[alt] - theta[key]) / (2 * np.pi)
        assert abs(turns % 2 - 1) < 0.5, (key, alt, turns)
