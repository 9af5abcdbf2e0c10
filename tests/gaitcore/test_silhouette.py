"""Tests of subject tracking and fixed-size ROI crops (paper Section 2.2)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.progress import Cancelled
from gaitcore.silhouettes.tracking import (
    RoiAccumulator,
    SubjectTracker,
    crop_rois,
    fill_holes,
    keep_overlapping,
    track_subject,
)


def moving_disc(n: int = 8, *, rows: int = 60, cols: int = 90, radius: int = 8,
                gone: tuple[int, ...] = ()) -> np.ndarray:
    masks = np.zeros((n, rows, cols), np.uint8)
    for t in range(n):
        if t not in gone:
            cv2.circle(masks[t], (15 + 6 * t, 30), radius, 1, -1)
    return masks


def test_windows_have_one_size_and_follow_the_subject():
    masks = moving_disc()
    roi = crop_rois(masks)
    n, h, w = roi.crops.shape
    assert n == 8 and roi.size_rc == (h, w) and roi.scale == 1.0
    assert h >= 17 and w >= 17
    np.testing.assert_allclose(roi.centers_xy[:, 0], 15 + 6 * np.arange(8), atol=1e-9)
    # The subject moves but its crop does not.
    assert all(np.array_equal(roi.crops[0], c) for c in roi.crops[1:])
    assert roi.crops[0].sum() == masks[0].sum()


def test_lost_frames_are_flagged_not_filled():
    roi = crop_rois(moving_disc(gone=(3, 4)))
    assert roi.lost.tolist() == [False, False, False, True, True, False, False, False]
    assert not roi.crops[3].any() and np.isnan(roi.centers_xy[4]).all()
    assert roi.crops[5].any()


def test_nothing_found_anywhere_raises():
    with pytest.raises(GaitInputError, match="no subject"):
        crop_rois(np.zeros((3, 10, 10), bool))
    with pytest.raises(GaitInputError, match="frames, rows, cols"):
        crop_rois(np.zeros((10, 10), bool))


def test_streamed_masks_give_the_same_result_as_an_array():
    masks = moving_disc(gone=(2,))
    a = crop_rois(masks)
    b = crop_rois(m for m in masks)
    assert np.array_equal(a.crops, b.crops) and np.array_equal(a.lost, b.lost)
    np.testing.assert_array_equal(a.centers_xy, b.centers_xy)


def test_max_side_shrinks_the_windows():
    masks = moving_disc(radius=20, rows=80, cols=140)
    full = crop_rois(masks)
    small = crop_rois(masks, max_side=16)
    assert max(small.size_rc) == 16 and small.scale == pytest.approx(16 / max(full.size_rc))
    # The shrunk silhouette covers the same fraction of its window.
    assert small.crops[0].mean() == pytest.approx(full.crops[0].mean(), abs=0.05)


def test_tracking_prefers_the_component_near_the_previous_one():
    masks = np.zeros((3, 40, 100), np.uint8)
    for t in range(3):
        cv2.circle(masks[t], (20 + 2 * t, 20), 6, 1, -1)  # the subject
    cv2.circle(masks[1], (85, 20), 9, 1, -1)  # a larger distractor far away
    subject, centers, boxes = track_subject(masks)
    assert centers[1, 0] == pytest.approx(22, abs=0.5)
    assert not subject[1, :, 70:].any()
    assert boxes[2, 2] == 13


def test_tracker_hint_and_origin():
    mask = np.zeros((30, 60), np.uint8)
    mask[5:25, 5:25] = 1  # large
    mask[10:15, 40:50] = 1  # small, under the hint
    hint = np.zeros_like(mask, bool)
    hint[12, 45] = True
    crop, box, centre = SubjectTracker(hint=hint).update(mask)
    assert box.tolist() == [40, 10, 10, 5] and crop.all()
    found = SubjectTracker().update(mask[10:15, 40:50], origin_xy=(40, 10))
    assert found[1].tolist() == [40, 10, 10, 5]
    np.testing.assert_allclose(found[2], [44.5, 12.0])


def test_progress_can_cancel():
    with pytest.raises(Cancelled):
        crop_rois(moving_disc(), progress=lambda done, total: done < 3)


def test_accumulator_memory_is_bit_packed():
    acc = RoiAccumulator()
    crop = np.ones((200, 160), bool)
    acc.add(crop, np.array([0, 0, 160, 200]), np.array([80.0, 100.0]))
    bits, shape, _ = acc._items[0]
    assert bits.nbytes == 200 * 160 // 8 and shape == (200, 160)


def test_fill_holes_and_keep_overlapping():
    ring = np.zeros((20, 20), np.uint8)
    cv2.circle(ring, (10, 10), 7, 1, 2)
    filled = fill_holes(ring)
    assert filled[10, 10] == 1 and filled[0, 0] == 0 and filled.sum() > ring.sum()
    two = np.zeros((10, 30), np.uint8)
    two[2:8, 2:8] = 1
    two[2:5, 20:23] = 1
    ref = np.zeros_like(two)
    ref[3, 21] = 1
    assert keep_overlapping(two, ref).sum() == 9
    assert keep_overlapping(two, np.zeros_like(two)).sum() == 36


def test_stabilize_rois_follows_the_travel_not_the_stride():
    # A blob travelling right at 2 px/frame whose centre of mass also wobbles +-4 px with a
    # 12-frame stride.
    n, period = 48, 12
    masks = np.zeros((n, 60, 200), dtype=bool)
    for t in range(n):
        x = 20 + 2 * t + int(round(4 * np.sin(2 * np.pi * t / period)))
        masks[t, 20:40, x : x + 30] = True
    from gaitcore.silhouettes.tracking import stabilize_rois

    roi = crop_rois(masks)
    stable = stabilize_rois(roi, period)
    # Every silhouette is kept whole, however far the window moved.
    np.testing.assert_array_equal(stable.crops.sum(axis=(1, 2)), roi.crops.sum(axis=(1, 2)))
    # The window moves at the travel speed without the wobble, up to the clip's ends.
    steps = np.diff(stable.centers_xy[:, 0])
    np.testing.assert_allclose(steps, 2.0, atol=1e-6)
    # So the blob now wobbles inside the window, as it does in the world.
    left = stable.crops[:, stable.crops.shape[1] // 2, :].argmax(axis=1)
    assert np.ptp(left[period:-period]) >= 6
