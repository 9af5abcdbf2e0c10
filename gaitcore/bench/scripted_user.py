"""A scripted artist for measuring segmentation with corrections, after the robot of the DAVIS
interactive benchmark (Caelles et al. 2018).

It starts from the subject's box on frame 0 (the reference mask's bounding box, padded 4%);
each round it takes the frame with the lowest intersection over union, draws one stroke along
the middle of the largest wrong region there (a subject stroke where the animal was missed, a
background stroke where something else was taken) and lets the segmentation re-propagate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from gaitcore.progress import Progress, report
from gaitcore.silhouettes.annotations import Rect, Scribble
from gaitcore.silhouettes.roto import RotoSegmentation


def padded_box(mask: np.ndarray, pad: float = 0.04) -> Rect:
    """Bounding box of a (rows, cols) bool mask grown by ``pad`` of its size on each side."""
    x, y, w, h = cv2.boundingRect(mask.astype(np.uint8))
    if w == 0:
        raise ValueError("the reference mask is empty")
    dx, dy = pad * w, pad * h
    return Rect(int(round(x - dx)), int(round(y - dy)), int(round(w + 2 * dx)),
                int(round(h + 2 * dy)))


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two bool masks (1 when both are empty)."""
    union = int((a | b).sum())
    return 1.0 if union == 0 else float((a & b).sum()) / union


def legs_iou(mask: np.ndarray, ref: np.ndarray) -> float:
    """IoU inside the lower third of the reference mask's bounding box (the legs)."""
    x, y, w, h = cv2.boundingRect(ref.astype(np.uint8))
    if w == 0:
        return iou(mask, ref)
    rows = slice(y + (2 * h) // 3, y + h)
    return iou(mask[rows, x : x + w], ref[rows, x : x + w])


def corrective_stroke(mask: np.ndarray, ref: np.ndarray, frame: int) -> Scribble | None:
    """One stroke along the middle of the largest wrong region of a frame.

    Parameters
    ----------
    mask, ref : ndarray of shape (rows, cols), bool
        The segmentation and the reference.
    frame : int

    Returns
    -------
    Scribble or None
        ``"subject"`` over the largest missed region or ``"background"`` over the largest
        wrongly taken one, through the ridge of its distance transform (points sorted along
        the region's main axis, the longest run without gaps); None when nothing is wrong.
    """
    best = None
    for label, wrong in (("subject", ref & ~mask), ("background", mask & ~ref)):
        n, comp, stats, _ = cv2.connectedComponentsWithStats(wrong.astype(np.uint8), 8)
        if n > 1:
            k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
            if best is None or stats[k, cv2.CC_STAT_AREA] > best[0]:
                best = (stats[k, cv2.CC_STAT_AREA], label, comp == k)
    if best is None:
        return None
    _, label, region = best
    region = region.astype(np.uint8)
    dist = cv2.distanceTransform(region, cv2.DIST_L2, 5)
    ridge = cv2.ximgproc.thinning(region * np.uint8(255)) > 0
    radius = float(dist[ridge].max()) if ridge.any() else float(dist.max())
    keep = ridge & (dist >= max(1.0, 0.5 * radius))
    if not keep.any():
        keep = dist >= dist.max()
    ys, xs = np.nonzero(keep)
    pts = np.column_stack([xs, ys]).astype(float)
    width = float(np.clip(radius, 2.0, 16.0))
    if len(pts) > 1:
        centre = pts.mean(0)
        axis = np.linalg.svd(pts - centre, full_matrices=False)[2][0]
        pts = pts[np.argsort((pts - centre) @ axis)]
        gaps = np.nonzero(np.linalg.norm(np.diff(pts, axis=0), axis=1) > 2 * width)[0]
        runs = np.split(pts, gaps + 1)
        pts = max(runs, key=len)
        pts = pts[:: max(1, len(pts) // 24)]
    return Scribble(pts, width, frame, label)


LOWERED_BY = 0.01
"""A stroke lowers its clip when the clip's mean IoU falls by more than this: above one run's
noise on a clip (a change under about 0.01 cannot be told from it)."""


@dataclass(frozen=True)
class ScriptedRun:
    """Scores of a scripted session.

    Attributes
    ----------
    ious : ndarray of shape (rounds + 1, n_frames)
        Per-frame IoU from the box alone (row 0) and after each round.
    legs : ndarray of shape (rounds + 1, n_frames)
        The same in the lower third of the reference box.
    seconds : ndarray of shape (rounds,)
        Time of each re-propagation.
    """

    ious: np.ndarray
    legs: np.ndarray
    seconds: np.ndarray

    def lowered(self, by: float = LOWERED_BY) -> int:
        """How many strokes lowered the clip's mean IoU by more than ``by``: corrections that
        left the artist further from the animal than before (counted over the DAVIS clips in
        ``docs/segmentation.md``)."""
        means = self.ious.mean(axis=1)
        return int(np.count_nonzero(np.diff(means) < -by))


def run_scripted_user(seg: RotoSegmentation, refs: Sequence[np.ndarray], rounds: int, *,
                      progress: Progress | None = None) -> ScriptedRun:
    """Score ``seg`` (already run) against ``refs``, then correct it ``rounds`` times.

    Parameters
    ----------
    seg : RotoSegmentation
    refs : sequence of ndarray (rows, cols), bool
        Reference mask of every frame.
    rounds : int
    progress : callable(done, total) -> bool, optional
        Called after each round.
    """
    import time

    ious, legs, seconds = [], [], []
    for r in range(rounds + 1):
        masks = [seg.mask(t) for t in range(seg.n)]
        ious.append([iou(m, ref) for m, ref in zip(masks, refs)])
        legs.append([legs_iou(m, ref) for m, ref in zip(masks, refs)])
        if r == rounds:
            break
        worst = int(np.argmin(ious[-1]))
        stroke = corrective_stroke(masks[worst], refs[worst], worst)
        if stroke is None:
            break
        t0 = time.perf_counter()
        seg.correct([stroke])
        seconds.append(time.perf_counter() - t0)
        report(progress, r + 1, rounds, "scripted user cancelled")
    return ScriptedRun(np.array(ious), np.array(legs), np.array(seconds))
