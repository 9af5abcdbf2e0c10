"""Tests of sketched silhouettes: rasterization, ROI crops, carrying and propagating strokes."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.progress import Cancelled
from gaitcore.silhouettes.annotations import Stroke
from gaitcore.silhouettes.sketch import (
    carry_strokes,
    crop_sketches,
    propagate_strokes,
    rasterize_strokes,
    sketch_masks,
    strokes_of_frame,
)


def test_rasterize_is_white_on_black_without_anti_aliasing():
    mask = rasterize_strokes([Stroke([[10, 20], [50, 20]], 5, 0)], (40, 64))
    assert mask.dtype == np.uint8 and set(np.unique(mask)) == {0, 255}
    rows = np.nonzero(mask[:, 30])[0]  # OpenCV's thick lines come out 0-2 px wider
    assert 5 <= len(rows) <= 7 and rows.mean() == 20 and np.ptp(rows) == len(rows) - 1
    cols = np.nonzero(mask[20])[0]
    assert cols.min() >= 7 and cols.max() <= 53 and mask[20, 10:51].all()


def test_rasterize_one_point_stroke_is_a_dot_and_shape_is_checked():
    mask = rasterize_strokes([Stroke([[8, 8]], 6, 0)], (16, 16))
    assert mask[8, 8] == 255 and 20 <= (mask > 0).sum() <= 50
    with pytest.raises(GaitInputError, match="shape"):
        rasterize_strokes([], (0, 10))


def test_sketches_enter_the_roi_pipeline_and_empty_frames_are_lost():
    spine = [[20, 30], [60, 28]]
    strokes = [
        Stroke(spine, 4, 0), Stroke([[25, 30], [22, 50]], 3, 0),
        Stroke(np.array(spine) + [5, 0], 4, 1),
        Stroke(np.array(spine) + [10, 0], 4, 3), Stroke([[35, 30], [40, 52]], 3, 3),
    ]
    roi = crop_sketches(strokes, 4, (64, 96), max_side=None)
    assert roi.lost.tolist() == [False, False, True, False]
    assert roi.crops.shape[0] == 4 and not roi.crops[2].any()
    assert roi.centers_xy[1, 0] - roi.centers_xy[0, 0] != 0
    # A stroke that touches no other still belongs to the sketch (e.g. the head).
    head = Stroke([[80, 10], [88, 14]], 3, 0)
    with_head = crop_sketches(strokes + [head], 4, (64, 96), max_side=None)
    assert with_head.crops[0].sum() > roi.crops[0].sum()
    assert with_head.centers_xy[0, 0] > roi.centers_xy[0, 0]
    with pytest.raises(Cancelled):
        crop_sketches(strokes, 4, (64, 96), progress=lambda done, total: done < 2)
    masks = list(sketch_masks(strokes, 4, (64, 96)))
    assert len(masks) == 4 and not masks[2].any() and masks[3].any()
    assert len(strokes_of_frame(strokes, 3)) == 2


def test_sketch_errors():
    with pytest.raises(GaitInputError, match="frame 5"):
        crop_sketches([Stroke([[1, 1], [5, 5]], 2, 5)], 3, (10, 10))
    with pytest.raises(GaitInputError, match="no subject"):
        crop_sketches([], 3, (10, 10))


def test_carry_strokes_copies_to_another_frame():
    s = Stroke([[1, 2], [3, 4]], 2.5, 7)
    [c] = carry_strokes([s], 8)
    assert c.frame == 8 and c.width_px == 2.5 and np.array_equal(c.points_xy, s.points_xy)
    assert s.frame == 7


def textured(rows: int = 120, cols: int = 160, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.uniform(0, 255, (rows, cols)).astype(np.float32), (0, 0), 2)
    img = cv2.normalize(noise, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    return cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)


def test_propagate_strokes_follows_the_motion():
    a = textured()
    shift = np.float32([[1, 0, 3], [0, 1, -2]])  # the content moves 3 right, 2 up
    b = cv2.warpAffine(a, shift, (a.shape[1], a.shape[0]), borderMode=cv2.BORDER_REFLECT)
    strokes = [Stroke([[50, 60], [80, 62], [100, 70]], 4, 2), Stroke([[70, 40]], 3, 2)]
    moved = propagate_strokes(strokes, a, b)
    assert [s.frame for s in moved] == [3, 3] and moved[0].width_px == 4
    for before, after in zip(strokes, moved):
        np.testing.assert_allclose(after.points_xy - before.points_xy,
                                   np.tile([3, -2], (len(before.points_xy), 1)), atol=0.5)
    assert propagate_strokes(strokes, a, b, to_frame=9)[0].frame == 9
    assert propagate_strokes([], a, b) == []


def test_propagate_strokes_near_the_border_stays_in_the_frame():
    a = textured(40, 40)
    b = np.roll(a, 2, axis=1)
    [s] = propagate_strokes([Stroke([[39, 5], [39, 30]], 2, 0)], a, b)
    assert (s.points_xy[:, 0] <= 39).all() and (s.points_xy >= 0).all()


def test_propagate_strokes_bad_frames():
    a = textured()
    with pytest.raises(GaitInputError, match="differ in size"):
        propagate_strokes([Stroke([[1, 1]], 1, 0)], a, a[:-1])
    with pytest.raises(GaitInputError, match="8-bit"):
        propagate_strokes([Stroke([[1, 1]], 1, 0)], a.astype(np.float32), a)


def test_propagate_strokes_on_a_crop_of_a_large_colour_frame():
    # Regression: the flow runs on a window around the strokes, a non-contiguous view that
    # OpenCV's DIS refused.
    a = textured(300, 400)
    shift = np.float32([[1, 0, 2], [0, 1, 1]])
    b = cv2.warpAffine(a, shift, (a.shape[1], a.shape[0]), borderMode=cv2.BORDER_REFLECT)
    [s] = propagate_strokes([Stroke([[200, 150], [220, 160]], 3, 0)], a, b)
    np.testing.assert_allclose(s.points_xy - [[200, 150], [220, 160]], [[2, 1], [2, 1]], atol=0.5)
