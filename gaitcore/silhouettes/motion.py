"""The motion cue: how unlike the camera's motion a pixel moves (beyond the paper).

The camera's motion, with the ground's, is a homography fitted to the optical flow off the
subject (:func:`camera_departure`); what departs from it is more likely the animal. The first
cut seeds its candidates with it (:func:`gaitcore.silhouettes.keyframe.motion_residuals`), and
a propagated frame weighs it beside colour (:func:`motion_ratios`, in
:func:`~gaitcore.silhouettes.propagate.fuse_cut`). The ground cues of
:mod:`gaitcore.silhouettes.ground` are learnt the same way (:func:`learnt_ratios`).
"""

from __future__ import annotations

import cv2
import numpy as np

_MOTION_BINS = 17
"""Bins of :func:`motion_ratios`: half octaves of the departure from the background's motion,
from 0.044 pixel (and less) to 16 pixels (and more)."""


def camera_departure(flow: np.ndarray, off: np.ndarray, *, step: int, planes: int = 1,
                     every: int = 1) -> np.ndarray | None:
    """How far the flow departs from the camera's motion at each pixel, in pixels.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2), float32
        An optical flow.
    off : ndarray of shape (h, w), bool
        The pixels the camera's motion is fitted to (off the subject).
    step : int
        They are sampled every ``step`` pixels each way.
    planes : int
        Up to this many homographies (a far and a near plane of the scene), each fitted by
        RANSAC to the samples the ones before left out; a pixel departs from the closest.
    every : int
        The departure is computed on every ``every`` pixels each way.

    Returns
    -------
    ndarray of shape (ceil(h / every), ceil(w / every)), float32, or None
        None when fewer than 32 pixels are sampled, or no homography explains 15% of them.
    """
    ys, xs = np.nonzero(off[::step, ::step])
    ys, xs = ys * step, xs * step
    src = np.stack([xs, ys], -1).astype(np.float32)
    dst = src + flow[ys, xs]
    sampled = len(src)
    gy = np.arange(0, flow.shape[0], every, dtype=np.float32)[:, None]
    gx = np.arange(0, flow.shape[1], every, dtype=np.float32)
    seen = flow[::every, ::every]
    best = None
    for _ in range(planes):
        if len(src) < 32:
            break
        homography, inliers = cv2.findHomography(src, dst, cv2.RANSAC, 1.0)
        if homography is None or inliers.sum() < 0.15 * sampled:
            break
        h = homography.astype(np.float32)
        z = h[2, 0] * gx + h[2, 1] * gy + h[2, 2]
        dx = seen[..., 0] - ((h[0, 0] * gx + h[0, 1] * gy + h[0, 2]) / z - gx)
        dy = seen[..., 1] - ((h[1, 0] * gx + h[1, 1] * gy + h[1, 2]) / z - gy)
        departure = np.sqrt(dx * dx + dy * dy)
        best = departure if best is None else np.minimum(best, departure)
        src, dst = src[inliers.ravel() == 0], dst[inliers.ravel() == 0]
    return best


def motion_ratios(flow: np.ndarray, prob: np.ndarray) -> np.ndarray | None:
    """How much more likely each pixel's motion is on the subject than on the background.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2), float32
        The flow from this frame to the previous one in the window.
    prob : ndarray of shape (h, w), float32
        The warped mask in [0, 1].

    Returns
    -------
    ndarray of shape (h, w), float32, or None
        Log-likelihood ratios within +-3; None when either side of the warped mask has too
        few pixels to learn from, or the background's motion cannot be fitted.

    Notes
    -----
    The background's motion (the camera's, with the ground) is a homography fitted to the
    flow off the warped mask (:func:`camera_departure`, every sixth pixel each way); each
    pixel's departure from it is binned in half octaves (:data:`_MOTION_BINS`), and the bins'
    ratio is learnt on this very frame from the warped mask's sure sides (above 0.9, below
    0.02). It is learnt again every frame because the cue comes and goes: strong while the
    animal moves across the ground (or the camera pans along it), nothing while it stands
    still, when the two histograms agree and the ratios are near 0.

    The cue is coarse (a flow is smooth across edges) and, weighed by ``motion_weight``, weak
    beside the warped mask: it tips the pixels near the mask's edge and where colour is
    unsure. A foot planted on the ground moves as the ground does, and is tipped towards the
    background as well.
    """
    if np.count_nonzero(prob > 0.9) < 16:
        return None
    # Every second pixel each way: the flow is smooth at that scale, and it is 4 times cheaper.
    departure = camera_departure(flow, prob < 0.02, step=6, every=2)
    if departure is None:
        return None
    bins = np.log2(departure + np.float32(0.05))
    bins = np.clip((bins + np.float32(4.5)) * 2, 0, _MOTION_BINS - 1).astype(np.intp)
    return cv2.resize(learnt_ratios(bins, prob[::2, ::2], _MOTION_BINS), prob.shape[::-1],
                      interpolation=cv2.INTER_LINEAR)


def learnt_ratios(bins: np.ndarray, prob: np.ndarray, n_bins: int) -> np.ndarray:
    """Each pixel's log-likelihood ratio, subject against background, of its bin of a cue,
    learnt from the warped mask's sure sides (``prob`` above 0.9, below 0.02; one more count
    in every bin), within +-3."""
    subject = np.bincount(bins[prob > 0.9], minlength=n_bins) + 1.0
    background = np.bincount(bins[prob < 0.02], minlength=n_bins) + 1.0
    ratios = np.log(subject / subject.sum()) - np.log(background / background.sum())
    return np.clip(ratios, -3, 3).astype(np.float32)[bins]
