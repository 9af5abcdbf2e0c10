"""Silhouette clean-up, subject tracking and region-of-interest crops (paper Section 2.2).

After segmentation (or sketching) every frame is a binary image. The subject is the connected
component nearest to where it was in the previous frame (centre of mass tracking); a window of
one fixed size per clip is cut around it, so that PCA sees the animal's shape and not its
position in the frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import cv2
import numpy as np

from gaitcore.errors import GaitInputError

Progress = Callable[[int, int], bool]


@dataclass(frozen=True, eq=False)
class RoiClip:
    """Equal-sized binary crops around the tracked subject.

    Attributes
    ----------
    crops : ndarray of shape (n, rows, cols), bool
        The subject's silhouette in a fixed window centred on its centre of mass.
    centers_xy : ndarray of shape (n, 2), float
        Centre of mass of the tracked component in each source frame (x, y in pixels);
        NaN where the subject was lost.
    lost : ndarray of shape (n,), bool
        Frames where no component was found; their crop is empty.
    """

    crops: np.ndarray
    centers_xy: np.ndarray
    lost: np.ndarray

    @property
    def size_rc(self) -> tuple[int, int]:
        return int(self.crops.shape[1]), int(self.crops.shape[2])


def track_subject(
    masks: np.ndarray, *, min_area_frac: float = 1e-4, progress: Progress | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keep, in each frame, the component that continues the subject's track.

    Parameters
    ----------
    masks : ndarray of shape (n, rows, cols)
        Binary masks (any non-zero value is foreground).
    min_area_frac : float
        Components smaller than this fraction of the frame are ignored as noise.
    progress : callable(done, total) -> bool, optional
        Called after each frame; returning False cancels with ``InterruptedError``.

    Returns
    -------
    subject : ndarray of shape (n, rows, cols), bool
        Only the tracked component in each frame.
    centers_xy : ndarray of shape (n, 2)
        Its centre of mass (NaN where lost).
    boxes : ndarray of shape (n, 4), int
        Its bounding box x, y, w, h (zeros where lost).

    Notes
    -----
    On the first frame the largest component is the subject. After that, the component
    whose centre is nearest to the previous centre is kept, with area as the tie-breaker:
    candidates are scored by distance divided by the square root of their area.
    """
    n = masks.shape[0]
    rows, cols = masks.shape[1:]
    min_area = max(1, int(min_area_frac * rows * cols))
    subject = np.zeros(masks.shape, dtype=bool)
    centers = np.full((n, 2), np.nan)
    boxes = np.zeros((n, 4), dtype=int)
    prev: np.ndarray | None = None
    for t in range(n):
        m = (np.asarray(masks[t]) != 0).astype(np.uint8)
        count, labels, stats, cents = cv2.connectedComponentsWithStats(m, connectivity=8)
        areas = stats[1:, cv2.CC_STAT_AREA]
        ok = np.nonzero(areas >= min_area)[0]
        if ok.size:
            if prev is None:
                best = ok[np.argmax(areas[ok])]
            else:
                dist = np.linalg.norm(cents[1:][ok] - prev, axis=1)
                best = ok[np.argmin(dist / np.sqrt(areas[ok]))]
            label = best + 1
            subject[t] = labels == label
            centers[t] = cents[label]
            boxes[t] = stats[label, :4]
            prev = cents[label]
        if progress is not None and progress(t + 1, n) is False:
            raise InterruptedError("subject tracking cancelled")
    return subject, centers, boxes


def crop_rois(
    masks: np.ndarray,
    *,
    margin: float = 0.05,
    progress: Progress | None = None,
) -> RoiClip:
    """Track the subject and cut a fixed-size window around it in every frame.

    Parameters
    ----------
    masks : array_like of shape (n, rows, cols)
        Binary masks of the whole frames.
    margin : float
        Extra border around the largest bounding box, as a fraction of its size.
    progress : callable(done, total) -> bool, optional

    Returns
    -------
    RoiClip

    Raises
    ------
    GaitInputError
        When the subject is found in no frame at all.
    """
    arr = np.asarray(masks)
    if arr.ndim != 3:
        raise GaitInputError(f"expected masks of shape (frames, rows, cols), got {arr.shape}")
    subject, centers, boxes = track_subject(arr, progress=progress)
    lost = np.isnan(centers[:, 0])
    if lost.all():
        raise GaitInputError(
            "no subject found in any frame: the masks are empty; check the segmentation "
            "rectangles or sketch the animal"
        )
    w = int(np.ceil(boxes[~lost, 2].max() * (1 + 2 * margin))) + 2
    h = int(np.ceil(boxes[~lost, 3].max() * (1 + 2 * margin))) + 2
    crops = np.zeros((arr.shape[0], h, w), dtype=bool)
    for t in np.nonzero(~lost)[0]:
        x0 = int(round(centers[t, 0] - w / 2))
        y0 = int(round(centers[t, 1] - h / 2))
        crops[t] = _crop_padded(subject[t], x0, y0, w, h)
    return RoiClip(crops=crops, centers_xy=centers, lost=lost)


def _crop_padded(image: np.ndarray, x0: int, y0: int, w: int, h: int) -> np.ndarray:
    """Crop image[y0:y0+h, x0:x0+w], padding with zeros outside the frame."""
    out = np.zeros((h, w), dtype=image.dtype)
    rows, cols = image.shape
    sx0, sy0 = max(x0, 0), max(y0, 0)
    sx1, sy1 = min(x0 + w, cols), min(y0 + h, rows)
    if sx1 > sx0 and sy1 > sy0:
        out[sy0 - y0 : sy1 - y0, sx0 - x0 : sx1 - x0] = image[sy0:sy1, sx0:sx1]
    return out
