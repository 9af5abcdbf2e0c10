"""An animal that shrinks as it walks away and enters and leaves the view: its gait is found."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from gaitcore.analysis.analyze import AnalysisSettings, analyze_silhouettes
from gaitcore.analysis.framing import frame_silhouettes, partial_frames
from gaitcore.silhouettes.tracking import EDGE_LEFT, EDGE_RIGHT, crop_rois, frame_edges
from tests.gaitcore.walker import walker_frame

STRIDE = 24.0


def receding_walker(n: int = 110, *, shrink: float = 0.45, enter: int = 10,
                    leave: int = 12) -> np.ndarray:
    """The walker crossing a 300-pixel-wide view from the right, shrinking by ``shrink`` of
    its size over the clip, cut by the frame's right side for ``enter`` frames and by its
    left side for the last ``leave``."""
    frames = []
    for t in range(n):
        scale = 1.0 - shrink * t / (n - 1)
        walker = walker_frame(float(t), STRIDE, size=(120, 200))
        small = cv2.resize(walker, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        small = (small > 127).astype(np.uint8) * 255
        h, w = small.shape
        # x of the walker's left edge: half out on the right at t=0, half out on the left at
        # the end, crossing at a steady pace between
        start, stop = 300 - 0.55 * w, -0.45 * w
        inside = n - enter - leave
        x = int(round(start + (stop - start) * np.clip(t - enter / 2, 0, inside + enter / 2)
                      / (inside + enter / 2)))
        canvas = np.zeros((160, 300), np.uint8)
        y = 150 - h
        x0, x1 = max(0, x), min(300, x + w)
        if x1 > x0:
            canvas[y : y + h, x0:x1] = small[:, x0 - x : x1 - x]
        frames.append(canvas)
    return np.stack(frames)


def test_edges_are_the_sides_that_cut_the_silhouette_not_a_hoof_that_touches():
    body = np.ones((40, 80), bool)
    assert frame_edges(body, (0, 10, 80, 40), (100, 200)) == EDGE_LEFT
    assert frame_edges(body, (120, 10, 80, 40), (100, 200)) == EDGE_RIGHT
    hoof = np.zeros((40, 80), bool)
    hoof[:, 30:50] = True
    hoof[-1, :] = False
    hoof[-1, 40] = True  # one pixel on the bottom row
    assert frame_edges(hoof, (60, 60, 80, 40), (100, 200)) == 0


def test_frames_partly_in_view_are_named_and_the_size_evened_out():
    roi = crop_rois(receding_walker())
    edge, small, sides = partial_frames(roi)
    assert set(sides) == {"left", "right"}
    assert edge[:3].all() and edge[-3:].all() and not edge[30:80].any()
    framed, framing = frame_silhouettes(roi)
    assert framing.height_change > 1.3  # over the frames kept
    kept = ~framing.left_out
    heights = [np.ptp(np.flatnonzero(c.any(axis=1))) for c in framed.crops[kept]]
    assert max(heights) / min(heights) < 1.15  # steady, where the walker shrank by 45 %
    assert (framed.lost == framing.left_out).all()


def test_the_travel_is_counted_in_the_animal_s_own_heights_as_it_shrinks():
    clip = receding_walker()
    framed, framing = frame_silhouettes(crop_rois(clip))
    kept = np.flatnonzero(~framing.left_out)
    steps = np.diff(framing.travel[kept[0]:kept[-1] + 1])
    assert np.all(steps < 0)  # to the left
    # the walker crosses at a steady pace in pixels while it shrinks: in its own heights,
    # its pace grows as its height falls
    size = 1.0 - 0.45 * np.arange(len(clip)) / (len(clip) - 1)
    first, last = kept[:6], kept[-6:]
    grown = size[first].mean() / size[last].mean()
    assert steps[-5:].mean() / steps[:5].mean() == pytest.approx(grown, rel=0.1)
    analysis = analyze_silhouettes(crop_rois(clip), AnalysisSettings(key_time_limit_s=5.0))
    assert analysis.travel is not None and np.all(np.diff(analysis.travel) > 0)
    staying = np.stack([walker_frame(float(t), STRIDE, size=(120, 200)) for t in range(60)])
    assert analyze_silhouettes(crop_rois(staying),
                               AnalysisSettings(key_time_limit_s=5.0)).travel is None


def test_the_receding_walk_is_usable_with_its_stride():
    clip = receding_walker()
    analysis = analyze_silhouettes(crop_rois(clip), AnalysisSettings(key_time_limit_s=5.0))
    assert analysis.diagnosis.verdict.value == "usable", analysis.diagnosis.reason
    period = analysis.diagnosis.period_frames
    assert min(abs(period - STRIDE), abs(period - STRIDE / 2)) <= 0.1 * period
    start, stop = analysis.frame_range
    assert start >= 3 and stop <= len(clip) - 3  # the frames partly in view are left out
    assert set(analysis.partial_frames) >= {0, 1, len(clip) - 1}
    notes = " ".join(analysis.advice.notes)
    assert "partly in view" in notes and "steady size" in notes
    assert not set(analysis.key_frames) & set(analysis.partial_frames)
    paper = analyze_silhouettes(crop_rois(clip), AnalysisSettings(stabilize_roi=False,
                                                                  key_time_limit_s=5.0))
    assert paper.framing.height_change == 1.0  # the fixed window: the size is not evened


def test_a_frame_brought_back_is_analysed():
    clip = receding_walker()
    left = analyze_silhouettes(crop_rois(clip), AnalysisSettings(key_time_limit_s=5.0))
    last = left.partial_frames[-1]
    run = tuple(f for f in left.partial_frames if f >= left.frame_range[1])
    back = analyze_silhouettes(crop_rois(clip), AnalysisSettings(key_time_limit_s=5.0,
                                                                 bring_back=run))
    assert last not in back.partial_frames and back.frame_range[1] > last


@pytest.mark.parametrize("keys", [4, 6])
def test_keys_and_alternates_avoid_the_frames_left_out(keys):
    clip = receding_walker()
    analysis = analyze_silhouettes(crop_rois(clip), AnalysisSettings(
        keys=keys, switching=True, key_time_limit_s=5.0))
    posed = set(analysis.posed_frames)
    assert not posed & set(analysis.lost_frames) and not posed & set(analysis.partial_frames)
