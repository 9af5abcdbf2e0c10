"""Cuts of key frames: the first frame from a box (or the paper's rectangles), and any frame
an artist corrects with strokes (beyond the paper's Section 2.2).

Both are ``cv2.grabCut`` (Rother et al. 2004) at the working size of
:mod:`gaitcore.silhouettes.propagate`. On the first frame, when the camera's own motion can be
explained (one or two homographies fitted to the optical flow outside the box), pixels in the
box that move differently seed the subject's colour model: this is what separates a pale dog
from pale grass. GrabCut only finds a local optimum, and which one depends on its seeds: the
first frame is cut from several (the motion over a few frames, over each of them) and the cut
whose own colour mixtures best tell its two sides apart is kept. The whole box, with no seed,
is cut only when no motion seeds a cut that spans it (separate photographs, a still camera
and subject, a box around more than the body), and then competes with them.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np

from gaitcore.silhouettes.colour_model import colour_separation
from gaitcore.silhouettes.motion import camera_departure
from gaitcore.silhouettes.propagate import TOUCHING, Box, Cut, disk, overlap
from gaitcore.silhouettes.settings import PropagationSettings
from gaitcore.silhouettes.tracking import keep_overlapping

_SAME_SEEDS = 0.95
"""Motion seeds overlapping earlier ones this much (IoU) would cut the same: not tried again."""
_PART_OF_LARGEST = 0.1
"""A salient part at least this share of the largest one's area is kept beside it."""
_LEAST_SHARE = 0.05
"""Moving pixels, or a cut, covering less of the box than this are taken to have found
nothing in it."""


def _grabcut(image: np.ndarray, labels: np.ndarray, iters: int) -> np.ndarray:
    """``cv2.grabCut`` from a label image, seeded so results never depend on OpenCV's RNG
    state; returns the 0/1 subject mask (labels are updated in place)."""
    fg = (labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)
    if min(int(fg.sum()), int(fg.size - fg.sum())) < 16:
        return fg.astype(np.uint8)
    cv2.setRNGSeed(0)
    cv2.grabCut(np.ascontiguousarray(image), labels, None, np.zeros((1, 65)),
                np.zeros((1, 65)), iters, cv2.GC_INIT_WITH_MASK)
    return ((labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)).astype(np.uint8)


def motion_residuals(first: np.ndarray, later: list[np.ndarray], box: Box) -> list[np.ndarray]:
    """How differently each pixel of ``first`` moves from the camera, in working pixels, over
    each of a few following frames.

    Parameters
    ----------
    first : ndarray of shape (rows, cols, 3), uint8
        The first frame at the working size.
    later : list of ndarray of shape (rows, cols, 3), uint8
        A few following frames.
    box : (x, y, w, h)
        The subject's box at the working size: the camera's motion is fitted outside it.

    Returns
    -------
    list of ndarray of shape (rows, cols), float32
        For each frame of ``later`` whose camera motion could be fitted, the distance between
        the optical flow and the flow of the best of (up to) two homographies fitted by RANSAC
        outside the box (a far and a near plane of the scene).
    """
    grey = cv2.cvtColor(first, cv2.COLOR_BGR2GRAY)
    x, y, w, h = box
    outside = np.ones(grey.shape, bool)
    outside[y : y + h, x : x + w] = False
    if np.count_nonzero(outside[::4, ::4]) < 64:
        return []
    flow_of = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    residuals = []
    for frame in later:
        flow = flow_of.calc(grey, cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY), None)
        residual = camera_departure(flow, outside, step=4, planes=2)
        if residual is not None:
            residuals.append(residual)
    return residuals


def cut_first(small: np.ndarray, box: Box | None, *, residuals: Sequence[np.ndarray] = (),
              seed: np.ndarray | None = None, subject: np.ndarray | None = None,
              background: np.ndarray | None = None,
              settings: PropagationSettings) -> np.ndarray:
    """Cut a key frame with no previous mask: from a box, strokes or rectangles.

    Parameters
    ----------
    small : ndarray of shape (rows, cols, 3), uint8
        The frame at the working size.
    box : (x, y, w, h) or None
        The subject's box (working size): everything outside is background.
    residuals : sequence of ndarray of shape (rows, cols)
        From :func:`motion_residuals`. Their median, and each of them, seeds one cut: inside
        the box, pixels that move unlike the camera start as "probably subject", the others
        as "probably background", and where the box lies on the frame's edge the cut keeps
        to their box grown by a tenth.
    seed : ndarray of shape (rows, cols), bool, optional
        Instead of ``residuals``: the pixels of the box that start as "probably subject"
        (e.g. the paper's colour model's guess), under the same check.
    subject, background : ndarray of shape (rows, cols), bool, optional
        Sure subject and sure background (rectangles, strokes).
    settings : PropagationSettings

    Returns
    -------
    ndarray of shape (rows, cols), uint8
        0/1 mask: the components touching the sure subject (or the largest one). With a box,
        the cuts seeded by the motion compete: of those that span their box
        (:func:`_spans`), the one whose own colours best separate its two sides
        (:func:`_separation`) is kept. The cut with the whole box "probably subject" is kept
        when nothing moved; with ``seed``, it competes with the seeded one. (Beside motion
        seeds it almost never won, and it costs one more GrabCut.) When no cut spans its
        box, the whole box is cut too and competes with the others, spanning or not, by the
        same separation; those under ``_LEAST_SHARE`` of the box (the colours around the box
        explained all those in it, as a crowd around a dancer's dress and skin does) are
        left out. A box drawn around more than the body, a kite's lines or a paraglider's
        wing, is spanned by no cut of the body, and the whole box's cut took the sea or the
        sky. This competition made some first cuts better and none worse, on tight and on
        loose boxes (see docs/segmentation.md, ``motion_offsets``). A part of the subject is
        a start the artist can correct; an empty first frame, or the background, loses the
        whole clip.
    """
    if box is None:
        return _cut_labels(small, None, None, subject, background, settings)
    x, y, w, h = box
    inside = np.zeros(small.shape[:2], bool)
    inside[y : y + h, x : x + w] = True
    seeds: list[np.ndarray] = []
    if seed is not None and seed.any():
        seeds = [seed]
    elif residuals:
        median = [np.median(residuals, axis=0)] if len(residuals) > 1 else []
        seeds = [m for m in (_moving(r, inside) for r in [*median, *residuals]) if m is not None]
    whole: tuple[Box, np.ndarray | None] = (box, None)
    with_whole = seed is not None or not seeds
    starts: list[tuple[Box, np.ndarray | None]] = [whole] if with_whole else []
    kept: list[np.ndarray] = []
    for moving in seeds:
        if not any(overlap(moving, other) > _SAME_SEEDS for other in kept):
            kept.append(moving)
            starts.append((_in_from_edges(box, moving) if seed is None else box, moving))

    def cut(start: tuple[Box, np.ndarray | None]) -> np.ndarray:
        return _cut_labels(small, *start, subject, background, settings)

    with ThreadPoolExecutor(max_workers=min(len(starts), os.cpu_count() or 1)) as pool:
        masks = list(pool.map(cut, starts))  # OpenCV lets go of the GIL in its calls
    cuts = [mask for mask, (around, _) in zip(masks, starts) if _spans(mask, around)]
    if cuts:
        return max(cuts, key=lambda mask: _separation(small, mask, box))
    whole_cut = masks[0] if with_whole else cut(whole)
    least = _LEAST_SHARE * w * h
    found = [mask for mask in (masks if with_whole else [*masks, whole_cut])
             if mask.sum() >= least]
    return max(found, key=lambda mask: _separation(small, mask, box)) if found else whole_cut


def cut_salient(prob: np.ndarray) -> np.ndarray:
    """A first frame's cut from the salient-object network's map of its box
    (:meth:`~gaitcore.silhouettes.saliency.Saliency.in_box`): the pixels above one half, in
    the largest component and those at least a tenth its size (a leg the map parts from the
    body at a thin joint). It cuts the first frame of animal clips better than this
    module's GrabCut, which missed a sunlit back, though it may leave out a pale tail (see
    docs/segmentation.md, ``saliency_weight``)."""
    mask = (prob > 0.5).astype(np.uint8)
    n, comp, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 2:
        return mask
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = 1 + np.flatnonzero(areas >= _PART_OF_LARGEST * areas.max())
    return np.isin(comp, keep).astype(np.uint8)


def _learning_window(box: Box) -> tuple[slice, slice]:
    """Where a first cut learns its colours: the box grown by half its longer side (and 8
    pixels). A small box in a big frame would otherwise compare the subject with the whole
    landscape."""
    x, y, w, h = box
    grow = max(w, h) // 2 + 8
    return slice(max(0, y - grow), y + h + grow), slice(max(0, x - grow), x + w + grow)


def _separation(small: np.ndarray, mask: np.ndarray, box: Box) -> float:
    """How well a cut's own colours tell its two sides apart (:func:`colour_separation`),
    over the :func:`_learning_window` of ``box``, the same pixels for every candidate. A cut
    that took ground of the subject's colours, or left a leg outside, has the same colours
    on both sides."""
    win = _learning_window(box)
    return colour_separation(small[win], mask[win])


def _cut_labels(small: np.ndarray, box: Box | None, moving: np.ndarray | None,
                subject: np.ndarray | None, background: np.ndarray | None,
                settings: PropagationSettings) -> np.ndarray:
    """GrabCut of a first frame from its labels; the components touching the sure subject
    (or the largest one)."""
    rows, cols = small.shape[:2]
    labels = np.full((rows, cols), cv2.GC_PR_BGD, np.uint8)
    if box is not None:
        x, y, w, h = box
        labels[:] = cv2.GC_BGD
        labels[y : y + h, x : x + w] = cv2.GC_PR_BGD if moving is not None else cv2.GC_PR_FGD
    if moving is not None:
        labels[moving] = cv2.GC_PR_FGD
    if background is not None:
        labels[background] = cv2.GC_BGD
    if subject is not None:
        labels[subject] = cv2.GC_FGD
    mask = np.zeros((rows, cols), np.uint8)
    win = (slice(None), slice(None)) if box is None else _learning_window(box)
    mask[win] = _grabcut(small[win], np.ascontiguousarray(labels[win]), settings.first_iters)
    anchor = subject if subject is not None and subject.any() else None
    if anchor is None:
        n, comp, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if n <= 1:
            return mask
        anchor = comp == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return keep_overlapping(mask, anchor, least=TOUCHING)


def grown_box(mask: np.ndarray, within: Box) -> Box:
    """The bounding box of a subject's first guess grown by a tenth (and 2 pixels) each way,
    clipped to ``within``."""
    x, y, w, h = cv2.boundingRect(mask.astype(np.uint8))
    pad_x, pad_y = round(0.1 * w) + 2, round(0.1 * h) + 2
    x0, y0 = max(within[0], x - pad_x), max(within[1], y - pad_y)
    x1 = min(within[0] + within[2], x + w + pad_x)
    y1 = min(within[1] + within[3], y + h + pad_y)
    return x0, y0, x1 - x0, y1 - y0


def _in_from_edges(box: Box, moving: np.ndarray) -> Box:
    """The box's sides that lie on the frame's edge, moved in to the moving pixels' box grown
    by a tenth: beyond such a side there is no background for the colour model to learn from
    (a box drawn past the frame), so the background left inside it would be taken."""
    rows, cols = moving.shape
    x, y, w, h = box
    gx, gy, gw, gh = grown_box(moving, box)
    x0 = gx if x == 0 else x
    y0 = gy if y == 0 else y
    x1 = gx + gw if x + w >= cols else x + w
    y1 = gy + gh if y + h >= rows else y + h
    return x0, y0, x1 - x0, y1 - y0


def _spans(mask: np.ndarray, box: Box, least: float = 0.6) -> bool:
    """Whether the mask spans at least ``least`` of the box both ways: a box is drawn around
    the whole subject, so a cut that fills only a corner of it (e.g. the sky between a
    horse's legs, where separate photographs made everything move) took the wrong thing."""
    _, _, w, h = cv2.boundingRect(mask)
    return w >= least * box[2] and h >= least * box[3]


MOVING_COVERED = 0.5
"""A first cut from the salient-object network is refused when it leaves out more than this
share of what moves unlike the camera in the box (the network took the dark rider and not the
pale horse under it)."""


def misses_motion(mask: np.ndarray, residuals: Sequence[np.ndarray], box: Box) -> bool:
    """Whether ``mask`` leaves out most of what moves in ``box``: the pixels that
    :func:`motion_residuals` (their median) calls moving, at least :data:`MOVING_COVERED` of
    them outside the mask. False when nothing clearly moves."""
    if not residuals:
        return False
    x, y, w, h = box
    inside = np.zeros(mask.shape, bool)
    inside[y : y + h, x : x + w] = True
    median = np.median(residuals, axis=0) if len(residuals) > 1 else residuals[0]
    moving = _moving(median, inside)
    if moving is None:
        return False
    return int(np.count_nonzero(moving & (mask > 0))) < MOVING_COVERED * moving.sum()


def _moving(residual: np.ndarray, inside: np.ndarray) -> np.ndarray | None:
    """Pixels in the box that move unlike the camera (Otsu's threshold of the residual in the
    box, at least half a pixel); None when that is under ``_LEAST_SHARE`` or over 90% of the
    box."""
    values = residual[inside]
    top = float(values.max())
    if top <= 0.5:
        return None
    scaled = np.clip(values / top * 255, 0, 255).astype(np.uint8)
    otsu, _ = cv2.threshold(scaled, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    moving = (residual > max(0.5, otsu / 255 * top)) & inside
    share = moving.sum() / max(inside.sum(), 1)
    return moving if _LEAST_SHARE <= share <= 0.9 else None


def cut_with_prior(small: np.ndarray, prior: np.ndarray, *, subject: np.ndarray | None = None,
                   background: np.ndarray | None = None, iters: int,
                   settings: PropagationSettings) -> Cut:
    """Graph cut of one window around a prior mask (warped, or the current result when an
    artist corrects a frame).

    Parameters
    ----------
    small : ndarray of shape (h, w, 3), uint8
        The window of the frame at the working size.
    prior : ndarray of shape (h, w), float32 or uint8
        Prior probability of the subject in [0, 1].
    subject, background : ndarray of shape (h, w), bool, optional
        Hard labels (the artist's strokes): with them the cut is never refused.
    iters : int
        Graph-cut iterations.
    settings : PropagationSettings

    Returns
    -------
    Cut
        In the window's coordinates.
    """
    inside = (prior > 0.5).astype(np.uint8)
    hard = subject is not None and subject.any()
    if hard:
        inside |= subject.astype(np.uint8)
    if background is not None:
        inside[background] = 0
    if not inside.any():
        return Cut(inside, 0.0)
    x, y, w, h = cv2.boundingRect(inside)
    side = max(w, h)
    labels = np.full(inside.shape, cv2.GC_BGD, np.uint8)
    labels[cv2.dilate(inside, disk(max(2, round(settings.band_frac * side)))) > 0] = \
        cv2.GC_PR_BGD
    labels[inside > 0] = cv2.GC_PR_FGD
    labels[cv2.erode(inside, disk(max(1, round(settings.core_frac * side)))) > 0] = cv2.GC_FGD
    if background is not None:
        labels[background] = cv2.GC_BGD
    if hard:
        labels[subject] = cv2.GC_FGD
    mask = keep_overlapping(_grabcut(small, labels, iters), subject if hard else inside,
                            least=TOUCHING)
    area, prior_area = float(mask.sum()), float(inside.sum())
    touched = hard or (background is not None and background.any())
    if not touched and not (settings.max_shrink * prior_area <= area
                            <= settings.max_growth * prior_area):
        return Cut(inside, 0.0)  # a flood or a collapse: keep the warped prior
    return Cut(mask, overlap(mask, inside))
