import numpy as np
import pytest

from gaitcore import GaitInputError, ImagePCA
from gaitcore.progress import Cancelled


def _moving_bar(n=40, size=(12, 16)):
    """A bar whose width oscillates: a small clip with two strong components."""
    t = np.arange(n)
    imgs = np.zeros((n,) + size, dtype=bool)
    for i in t:
        w = 3 + int(round(3 + 3 * np.sin(2 * np.pi * i / 10)))
        h = 2 + int(round(3 + 3 * np.cos(2 * np.pi * i / 10)))
        imgs[i, 1 : 1 + h, 2 : 2 + w] = True
    return imgs


def test_projections_have_unit_variance_and_zero_mean():
    pca = ImagePCA.fit(_moving_bar(), n_components=3)
    p = pca.projections
    assert p.shape == (40, 3)
    np.testing.assert_allclose(p.mean(axis=0), 0, atol=1e-9)
    np.testing.assert_allclose(p.var(axis=0), 1, rtol=1e-9)


def test_matches_covariance_eigendecomposition():
    rng = np.random.default_rng(1)
    imgs = rng.random((15, 4, 5))
    pca = ImagePCA.fit(imgs, n_components=4)
    x = imgs.reshape(15, -1)
    xc = x - x.mean(0)
    cov = xc.T @ xc / 15
    evals, evecs = np.linalg.eigh(cov)
    evals, evecs = evals[::-1][:4], evecs[:, ::-1][:, :4]
    np.testing.assert_allclose(pca.eigenvalues, evals, rtol=1e-9)
    # Same subspace, sign aside.
    np.testing.assert_allclose(np.abs(np.sum(pca.components * evecs.T, axis=1)), 1, atol=1e-9)
    np.testing.assert_allclose(pca.variance_ratio.sum(), evals.sum() / np.trace(cov), rtol=1e-9)


def test_tall_data_uses_the_covariance_and_agrees_with_the_svd():
    rng = np.random.default_rng(2)
    tall = rng.random((30, 3, 3))  # n=30 > d=9: the 9 x 9 covariance route
    pca = ImagePCA.fit(tall, n_components=3)
    xc = tall.reshape(30, -1) - tall.reshape(30, -1).mean(0)
    _, sing, vt = np.linalg.svd(xc, full_matrices=False)
    np.testing.assert_allclose(pca.eigenvalues, sing[:3] ** 2 / 30, rtol=1e-9)
    scores = xc @ vt[:3].T / sing[:3] * np.sqrt(30)
    signs = np.sign((pca.projections * scores).sum(0))
    np.testing.assert_allclose(pca.projections * signs, scores, atol=1e-9)


def test_project_new_frames_equals_fitted_projections():
    imgs = _moving_bar()
    pca = ImagePCA.fit(imgs, n_components=2)
    np.testing.assert_allclose(pca.project(imgs), pca.projections, atol=1e-9)
    np.testing.assert_allclose(pca.project(imgs[3]), pca.projections[3], atol=1e-9)


def test_eigen_images_shape():
    pca = ImagePCA.fit(_moving_bar(), n_components=2)
    e = pca.eigen_images()
    assert e.shape == (2, 3, 12, 16)
    np.testing.assert_allclose(e[:, 1], pca.mean.reshape(12, 16)[None].repeat(2, 0))


def test_uint8_masks_are_scaled_like_bool():
    imgs = _moving_bar()
    a = ImagePCA.fit(imgs, n_components=2)
    b = ImagePCA.fit(imgs.astype(np.uint8) * 255, n_components=2)
    np.testing.assert_allclose(a.projections, b.projections, atol=1e-9)


@pytest.mark.parametrize(
    "images, message",
    [
        (np.zeros((1, 4, 4)), "at least 2 frames"),
        (np.ones((6, 4, 4)), "identical"),
        (np.zeros((4, 4)), "shape"),
        (np.full((3, 2, 2), np.nan), "NaN"),
    ],
)
def test_bad_input(images, message):
    with pytest.raises(GaitInputError, match=message):
        ImagePCA.fit(images)


def test_keeps_at_most_the_available_components():
    imgs = np.zeros((3, 4, 4))
    imgs[1, 0, 0] = 1
    imgs[2, 1, 1] = 1
    assert ImagePCA.fit(imgs, n_components=5).n_components == 2


def test_streamed_randomized_svd_matches_the_dense_route(monkeypatch):
    import gaitcore.analysis.image_pca as module

    imgs = _moving_bar(300, (24, 30)).astype(np.uint8) * 255
    rng = np.random.default_rng(4)
    imgs[rng.random(imgs.shape) < 0.02] ^= 255  # some noise so that many components exist
    dense = ImagePCA.fit(imgs, n_components=4)
    monkeypatch.setattr(module, "DENSE_LIMIT", 1000)
    streamed = ImagePCA.fit(imgs, n_components=4)
    np.testing.assert_allclose(streamed.eigenvalues, dense.eigenvalues, rtol=1e-6)
    np.testing.assert_allclose(streamed.total_variance, dense.total_variance, rtol=1e-9)
    np.testing.assert_allclose(streamed.mean, dense.mean, atol=1e-12)
    np.testing.assert_allclose(np.abs(streamed.projections[:, :2]),
                               np.abs(dense.projections[:, :2]), atol=1e-4)


@pytest.mark.parametrize("limit", [None, 1000])
def test_progress_reaches_the_end_and_changes_nothing(monkeypatch, limit):
    import gaitcore.analysis.image_pca as module

    imgs = _moving_bar(1100, (12, 16))
    if limit is not None:  # the streamed route: 3 chunks of frames, 13 passes
        monkeypatch.setattr(module, "DENSE_LIMIT", limit)
    calls = []
    fitted = ImagePCA.fit(imgs, n_components=3, progress=lambda d, t: calls.append((d, t)))
    plain = ImagePCA.fit(imgs, n_components=3)
    np.testing.assert_array_equal(fitted.projections, plain.projections)
    done = [d for d, _ in calls]
    assert done == sorted(done) and len({t for _, t in calls}) == 1
    assert calls[-1][0] == calls[-1][1] == (1 if limit is None else 3 * 13)


@pytest.mark.parametrize("limit", [None, 1000])
def test_progress_returning_false_cancels(monkeypatch, limit):
    import gaitcore.analysis.image_pca as module

    if limit is not None:
        monkeypatch.setattr(module, "DENSE_LIMIT", limit)
    calls = []

    def stop_at_fifth(done, total):
        calls.append(done)
        return len(calls) < 5 if limit else False

    with pytest.raises(Cancelled, match="PCA cancelled"):
        ImagePCA.fit(_moving_bar(1100, (12, 16)), n_components=3, progress=stop_at_fifth)
    assert len(calls) == (5 if limit else 1)
