from math import log

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from gaitcore import GaitInputError, RBFPoseMap
from gaitcore.analysis.kernel import gaussian_kernel


def test_kernel_is_half_at_unit_distance():
    k = gaussian_kernel(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0], [0.0, 0.0]]))
    np.testing.assert_allclose(k, [[0.5, 1.0]])


def test_matches_paper_pseudo_inverse_formula():
    rng = np.random.default_rng(3)
    p = rng.normal(size=(4, 2))
    x = rng.normal(size=(4, 6))
    q = rng.normal(size=(10, 2))
    h = np.exp(-log(2) * ((p[:, None] - p[None]) ** 2).sum(-1))
    hq = np.exp(-log(2) * ((q[:, None] - p[None]) ** 2).sum(-1))
    weights = hq @ np.linalg.inv(h.T @ h) @ h.T  # paper eq. (13)
    rbf = RBFPoseMap.fit(p, x)
    np.testing.assert_allclose(rbf.weights(q), weights, atol=1e-9)
    blend = np.clip(weights, 0, None)  # no negative weight, and never more than one in all
    blend /= np.maximum(blend.sum(axis=1, keepdims=True), 1.0)
    np.testing.assert_allclose(rbf.blend(q), blend, atol=1e-9)
    mean = x.mean(axis=0)  # what the weights leave goes to the keys' mean
    np.testing.assert_allclose(rbf.predict(q), mean + blend @ (x - mean), atol=1e-9)


def test_a_point_thrown_off_the_keys_cannot_swing_the_pose_beyond_them():
    p = np.array([[0.0, 0.0], [0.2, 0.0], [0.0, 2.0], [2.0, 2.0]])  # two keys close together
    x = np.array([[0.0], [1.0], [0.5], [0.2]])
    rbf = RBFPoseMap.fit(p, x)
    q = np.array([[-0.6, -0.1], [0.8, 0.0], [0.1, -0.5]])
    assert np.abs(rbf.weights(q)).max() > 2  # the paper's weights overshoot there...
    pose = rbf.predict(q)
    assert (pose >= x.min() - 1e-9).all() and (pose <= x.max() + 1e-9).all()  # ...the pose not


def test_far_from_the_keys_the_pose_falls_back_to_their_mean():
    p = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    x = np.array([[10.0, 0.0], [12.0, 2.0], [14.0, -2.0]])
    rbf = RBFPoseMap.fit(p, x)
    np.testing.assert_allclose(rbf.predict(p), x, atol=1e-9)  # exact at the keys
    np.testing.assert_allclose(rbf.predict(np.array([40.0, 40.0])), x.mean(axis=0), atol=1e-9)


def test_clamp_limits_weights():
    p = np.array([[0.0, 0.0], [0.3, 0.0], [0.0, 2.0]])
    rbf = RBFPoseMap.fit(p, np.eye(3), clamp=(0.0, 1.0))
    w = rbf.weights(np.array([[5.0, -5.0], [0.1, 0.1]]))
    assert w.min() >= 0.0 and w.max() <= 1.0
    assert RBFPoseMap.fit(p, np.eye(3)).weights(np.array([0.15, -1.0])).min() < 0.0


def test_one_dimensional_poses_and_single_point():
    rbf = RBFPoseMap.fit([[0.0], [1.0]], [10.0, 20.0])
    assert rbf.predict(np.array([1.0])).shape == (1,)
    np.testing.assert_allclose(rbf.predict(np.array([[0.0], [1.0]]))[:, 0], [10.0, 20.0])


@pytest.mark.parametrize(
    "coords, poses, message",
    [
        ([[0.0, 0.0], [0.0, 0.0], [1.0, 1.0]], np.zeros((3, 2)), "identical PCA coordinates"),
        ([[0.0, 0.0], [1.0, 1.0]], [[1.0, np.nan], [0.0, 0.0]], "NaN"),
        ([[0.0, 0.0], [1.0, 1.0]], np.zeros((3, 2)), "one pose per key"),
        ([[0.0, 0.0], [1e-9, 0.0], [1.0, 1.0]], np.zeros((3, 2)), "too close"),
        (np.zeros((0, 2)), np.zeros((0, 2)), "at least one"),
    ],
)
def test_bad_input(coords, poses, message):
    with pytest.raises(GaitInputError, match=message):
        RBFPoseMap.fit(coords, poses)


def test_wrong_number_of_components_at_prediction():
    rbf = RBFPoseMap.fit([[0.0, 0.0], [1.0, 1.0]], [[1.0], [2.0]])
    with pytest.raises(GaitInputError, match="components"):
        rbf.predict(np.zeros((3, 3)))


@st.composite
def _keys(draw):
    m = draw(st.integers(1, 6))
    c = draw(st.integers(1, 3))
    coords = draw(arrays(float, (m, c), elements=st.floats(-3, 3, allow_nan=False)))
    poses = draw(arrays(float, (m, draw(st.integers(1, 5))), elements=st.floats(-180, 180)))
    return coords, poses


def _min_distance(coords):
    d = np.sqrt(((coords[:, None] - coords[None]) ** 2).sum(-1))
    return d[np.triu_indices(len(coords), 1)].min(initial=np.inf)


@settings(max_examples=300, deadline=None)
@given(_keys())
def test_exact_at_keys_and_weights_sum_to_one(data):
    coords, poses = data
    assume(_min_distance(coords) >= 0.25)
    rbf = RBFPoseMap.fit(coords, poses)
    np.testing.assert_allclose(rbf.predict(coords), poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rbf.weights(coords).sum(axis=1), 1.0, rtol=0, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(_keys())
def test_close_keys_are_refused_or_fitted_never_garbage(data):
    coords, poses = data
    try:
        rbf = RBFPoseMap.fit(coords, poses)
    except GaitInputError:
        return
    cond = np.linalg.cond(np.exp(-log(2) * ((coords[:, None] - coords[None]) ** 2).sum(-1)))
    assert cond <= 1e12
    scale = 1 + np.abs(poses).max()
    np.testing.assert_allclose(rbf.predict(coords), poses, rtol=0, atol=1e-13 * cond * scale)
