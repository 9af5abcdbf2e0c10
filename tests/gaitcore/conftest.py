"""Fixtures shared by the gaitcore tests."""

from __future__ import annotations

import cv2
import pytest

from tests.gaitcore.test_segmentation import scene

SCENE_FRAMES = 16


@pytest.fixture(scope="module")
def scene_images(tmp_path_factory):
    """The synthetic trotting scene (``SCENE_FRAMES`` frames) as a folder of PNG images, and
    its true masks."""
    folder = tmp_path_factory.mktemp("scene") / "images"
    folder.mkdir()
    frames, truth = scene(SCENE_FRAMES)
    for t, img in enumerate(frames):
        cv2.imwrite(str(folder / f"{t:05d}.png"), img)
    return folder, truth


@pytest.fixture
def saliency_rates(monkeypatch) -> list[int]:
    """The rate (every N frames) each salient-object track of the engine was made with,
    in order; empty where the network is not installed."""
    import gaitcore.silhouettes.roto.passes as passes

    asked: list[int] = []

    class Recorded(passes.SaliencyTrack):
        def __init__(self, model, every):
            asked.append(every)
            super().__init__(model, every)

    monkeypatch.setattr(passes, "SaliencyTrack", Recorded)
    return asked
