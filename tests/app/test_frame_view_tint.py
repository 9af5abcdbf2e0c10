"""The silhouette tint on HD footage follows the outline, not the 160-pixel crop's blocks."""

from __future__ import annotations

import cv2
import numpy as np

from app.widgets.frame_view import TINT_MAX_SIDE, _smooth_upscale


def _ellipse(rows: int, cols: int) -> np.ndarray:
    m = np.zeros((rows, cols), np.uint8)
    cv2.ellipse(m, (cols // 2, rows // 2), (int(cols * 0.4), int(rows * 0.3)), 20, 0, 360, 1, -1)
    return m > 0


def test_upscaled_tint_is_closer_to_the_true_outline_than_blocks():
    crop = cv2.resize(_ellipse(480, 640).astype(np.uint8), (160, 120),
                      interpolation=cv2.INTER_AREA) > 0  # as the ROI crops are made
    tint = _smooth_upscale(crop, 640, 480)
    assert tint.shape == (384, 512)  # capped at TINT_MAX_SIDE
    assert max(tint.shape) == TINT_MAX_SIDE
    truth = _ellipse(384, 512)
    blocks = cv2.resize(crop.astype(np.uint8), (512, 384), interpolation=cv2.INTER_NEAREST) > 0

    def iou(a, b):
        return (a & b).sum() / (a | b).sum()

    assert iou(tint, truth) > iou(blocks, truth)


def test_small_windows_keep_the_crop():
    crop = _ellipse(120, 160)
    assert _smooth_upscale(crop, 100, 80) is crop
