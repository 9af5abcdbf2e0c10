"""Tests of colour segmentation from rectangles on the first frame (paper Section 2.2)."""

from __future__ import annotations

import threading

import cv2
import numpy as np
import pytest

from gaitcore.errors import GaitInputError
from gaitcore.footage.image_folder import read_mask_folder
from gaitcore.footage.sources import open_frames
from gaitcore.progress import Cancelled
from gaitcore.silhouettes.annotations import Rect
from gaitcore.silhouettes.segmentation import ColourModel, segment_clip

ROWS, COLS = 96, 128
SUBJECT = [Rect(24, 46, 20, 8)]
BACKGROUND = [Rect(0, 0, COLS, 18), Rect(COLS - 30, 62, 30, 34)]


def scene(n: int = 14, *, gone: tuple[int, ...] = (), seed: int = 0):
    """A brown animal (body and two swinging legs) trotting right over textured grass.

    Returns frames (n, ROWS, COLS, 3) uint8 BGR and the true masks (n, ROWS, COLS) bool.
    """
    rng = np.random.default_rng(seed)
    texture = cv2.GaussianBlur(rng.normal(0, 25, (ROWS, COLS)).astype(np.float32), (0, 0), 2)
    grass = np.clip(np.array([50, 140, 70], np.float32) + texture[..., None] * [1, 1.5, 1], 0, 255)
    frames = np.empty((n, ROWS, COLS, 3), np.uint8)
    masks = np.zeros((n, ROWS, COLS), np.uint8)
    for t in range(n):
        if t not in gone:
            cx, cy = 34 + 3 * t, 50
            cv2.ellipse(masks[t], (cx, cy), (20, 10), 0, 0, 360, 1, -1)
            swing = int(6 * np.sin(t))
            for foot_x in (cx - 12, cx + 12):
                cv2.line(masks[t], (foot_x, cy + 5), (foot_x + swing, cy + 26), 1, 4)
        brown = np.array([40, 80, 160], np.float32)
        img = np.where(masks[t][..., None] > 0, brown, grass)
        img += rng.normal(0, 6, img.shape)
        frames[t] = np.clip(img, 0, 255).astype(np.uint8)
    return frames, masks.astype(bool)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def collect(store: dict):
    def sink(index: int, mask: np.ndarray) -> None:
        assert mask.dtype == np.uint8 and set(np.unique(mask)) <= {0, 255}
        store[index] = mask > 0
    return sink


@pytest.mark.parametrize(("method", "least"), [("gmm", 0.85), ("propagate", 0.9)])
def test_both_methods_find_the_animal(method, least):
    frames, truth = scene()
    masks: dict = {}
    roi = segment_clip(frames, SUBJECT, BACKGROUND, method=method, mask_sink=collect(masks))
    assert sorted(masks) == list(range(len(frames)))
    scores = [iou(masks[t], truth[t]) for t in range(len(frames))]
    assert min(scores) >= least, scores
    assert not roi.lost.any() and roi.crops.shape[0] == len(frames)
    np.testing.assert_allclose(roi.centers_xy[:, 0], 34 + 3 * np.arange(len(frames)), atol=2.5)


def test_video_source_is_streamed(tmp_path):
    frames, truth = scene(10)
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, (COLS, ROWS))
    for f in frames:
        writer.write(f)
    writer.release()
    masks: dict = {}
    calls = []
    with open_frames(path) as source:
        roi = segment_clip(source, SUBJECT, BACKGROUND, mask_sink=collect(masks),
                           progress=lambda done, total: calls.append((done, total)) or True)
    # The camera holds still: the clip is carried once to learn what lies behind the animal,
    # then again with it.
    assert calls[-1] == (19, 19) and len(roi.lost) == 10
    assert [d for d, _ in calls] == sorted(d for d, _ in calls) and {t for _, t in calls} == {19}
    assert np.mean([iou(masks[t], truth[t]) for t in range(10)]) >= 0.85
    # An error or a cancel stops the decoding thread too.
    with open_frames(path) as source:
        with pytest.raises(GaitInputError, match="outside"):
            segment_clip(source, [Rect(900, 900, 5, 5)], BACKGROUND)
        with pytest.raises(Cancelled):
            segment_clip(source, SUBJECT, BACKGROUND, progress=lambda done, total: done < 3)
    assert not [t for t in threading.enumerate() if t.name == "gaitcore-decode"]


def test_lost_subject_is_flagged_and_found_again():
    frames, truth = scene(16, gone=(6, 7, 8, 9))
    for method in ("gmm", "propagate"):
        roi = segment_clip(frames, SUBJECT, BACKGROUND, method=method)
        assert roi.lost.tolist() == [t in (6, 7, 8, 9) for t in range(16)], method
        assert not roi.crops[roi.lost].any() and roi.crops[~roi.lost].any(axis=(1, 2)).all()


def test_max_side_and_margin():
    frames, _ = scene(6)
    roi = segment_clip(frames, SUBJECT, BACKGROUND, max_side=24)
    assert max(roi.size_rc) == 24 and roi.scale < 1
    big = segment_clip(frames, SUBJECT, BACKGROUND, max_side=None, margin=0.2)
    assert big.scale == 1.0 and max(big.size_rc) > 24


@pytest.mark.parametrize(
    ("subject", "background", "match"),
    [
        ([Rect(500, 500, 10, 10)], BACKGROUND, "outside"),
        ([(20, 40, 0, 5)], BACKGROUND, "empty"),
        ([], BACKGROUND, "no (box and no )?subject rectangle"),
        (SUBJECT, [], "no background rectangle"),
        (SUBJECT, [Rect(0, 0, COLS, ROWS)], "overlap"),
    ],
)
def test_bad_rectangles(subject, background, match):
    frames, _ = scene(2)
    with pytest.raises(GaitInputError, match=match):
        segment_clip(frames, subject, background)


def test_bad_frames_and_settings():
    frames, _ = scene(3)
    with pytest.raises(GaitInputError, match="no frames"):
        segment_clip([], SUBJECT, BACKGROUND)
    with pytest.raises(GaitInputError, match="BGR"):
        segment_clip(frames[..., 0], SUBJECT, BACKGROUND)
    with pytest.raises(GaitInputError, match="same size"):
        segment_clip([frames[0], frames[1][:-2]], SUBJECT, BACKGROUND)
    with pytest.raises(GaitInputError, match="unknown segmentation method"):
        segment_clip(frames, SUBJECT, BACKGROUND, method="magic")


def test_cancel():
    frames, _ = scene(6)
    with pytest.raises(Cancelled):
        segment_clip(frames, SUBJECT, BACKGROUND, progress=lambda done, total: done < 2)


def test_colour_model_posterior_and_refit():
    frames, truth = scene(2)
    model = ColourModel.fit(frames[0], SUBJECT, BACKGROUND)
    post = model.posterior(frames[0])
    assert post.dtype == np.uint8 and post.shape == (ROWS, COLS)
    assert np.median(post[truth[0]]) > 200 and np.median(post[~truth[0]]) < 50
    refit = model.refit(frames[1], truth[1], ~truth[1], keep_first=0.5)
    assert refit is not model and refit.lut.shape == model.lut.shape
    assert model.refit(frames[1], np.zeros_like(truth[1]), ~truth[1]) is model


def test_flat_colours_fit_without_warnings():
    frame = np.zeros((40, 60, 3), np.uint8)
    frame[:, :] = (20, 200, 20)
    frame[10:30, 20:40] = (30, 30, 200)
    frame[10, 20] = (31, 30, 200)  # a second, nearly empty colour bin
    model = ColourModel.fit(frame, [Rect(20, 10, 20, 20)], [Rect(0, 0, 60, 8)])
    post = model.posterior(frame)
    assert post[20, 30] > 250 and post[2, 2] < 5
    roi = segment_clip([frame] * 3, [Rect(20, 10, 20, 20)], [Rect(0, 0, 60, 8)], max_side=None)
    assert roi.crops.sum(axis=(1, 2)).tolist() == [400, 400, 400]


@pytest.mark.slow
def test_davis_bear_from_first_frame_rectangles(shared_data):
    """Mean IoU >= 0.85 against the DAVIS reference masks, from first-frame rectangles only.

    The rectangles were chosen once, by eye on the first frame: the subject ones on the bear's
    back and on its hind leg, the background ones on the wall above, the ground and rocks to
    the right, the bottom-left rocks and the reddish wall at the left edge. The only use of a
    reference mask is checking, on frame 0, that they are honest (inside / away from the bear).
    """
    bear = shared_data / "davis-bear"
    subject = [Rect(180, 245, 200, 70), Rect(385, 335, 30, 50)]
    background = [Rect(0, 0, 854, 190), Rect(500, 180, 354, 300), Rect(0, 440, 120, 40),
                  Rect(0, 200, 90, 120)]
    first_ref = cv2.imread(str(bear / "Annotations" / "00000.png"), cv2.IMREAD_GRAYSCALE) > 127
    assert all(first_ref[r.slices()].mean() > 0.99 for r in subject)
    assert not any(first_ref[r.slices()].any() for r in background)
    masks: dict = {}
    with open_frames(bear / "JPEGImages") as source:
        roi = segment_clip(source, subject, background, mask_sink=collect(masks))
    refs = read_mask_folder(bear / "Annotations")  # read only now, to score
    scores = [iou(masks[t], refs[t]) for t in range(len(refs))]
    assert np.mean(scores) >= 0.85, np.mean(scores)
    assert not roi.lost.any()


def test_results_do_not_depend_on_what_opencv_did_before(monkeypatch):
    """GrabCut starts its colour models from k-means on OpenCV's generator: each clip must
    start that generator from the same state (on Muybridge's horse an unlucky state took r2
    from 0.94 to 0.30)."""
    frames, _ = scene(3)
    grab_cut, seen = cv2.grabCut, []

    def recording(*args):
        seen.append(cv2.randu(np.empty(1), 0.0, 1.0)[0])  # the generator's state, as a draw
        return grab_cut(*args)

    monkeypatch.setattr(cv2, "grabCut", recording)
    firsts = []
    for seed in (1, 2):
        cv2.setRNGSeed(seed)
        seen.clear()
        segment_clip(frames, SUBJECT, BACKGROUND)
        firsts.append(seen[0])
    assert firsts[0] == firsts[1]
