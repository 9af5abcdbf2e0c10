"""analyze_silhouettes as a job: one progress scale over its stages, cancellable in the PCA."""

from __future__ import annotations

import numpy as np
import pytest

import gaitcore.analysis.image_pca as image_pca
from gaitcore.analysis.analyze import AnalysisSettings, analyze_silhouettes
from gaitcore.progress import Cancelled
from gaitcore.silhouettes.tracking import crop_rois
from tests.gaitcore.walker import walker_clip


@pytest.fixture(scope="module")
def roi():
    return crop_rois(walker_clip(300))


@pytest.fixture
def streamed(monkeypatch):
    """Force the chunked PCA, the route long clips take."""
    monkeypatch.setattr(image_pca, "DENSE_LIMIT", 1000)


@pytest.mark.parametrize("stabilize", [True, False])
def test_progress_covers_every_stage_once(roi, streamed, stabilize):
    calls = []
    settings = AnalysisSettings(stabilize_roi=stabilize)
    analysis = analyze_silhouettes(roi, settings, progress=lambda d, t: calls.append((d, t)))
    done = [d for d, _ in calls]
    totals = {t for _, t in calls}
    assert len(totals) == 1 and done == sorted(done)
    assert totals.pop() == 3 * 1000  # cycle search, PCA, keys
    # the cycle search and the PCA report, each up to its end
    assert {1000, 2000} <= set(done)
    np.testing.assert_array_equal(
        analysis.projections, analyze_silhouettes(roi, settings).projections)


def test_cancel_during_the_pca(roi, streamed):
    calls = []

    def cancel_after_three(done, total):  # the third report of the PCA, after the cycle search
        calls.append(done)
        return len([d for d in calls if d > 1000]) < 3

    with pytest.raises(Cancelled, match="PCA"):
        analyze_silhouettes(roi, AnalysisSettings(), progress=cancel_after_three)
    assert len([d for d in calls if d > 1000]) == 3 and max(calls) < 2000
