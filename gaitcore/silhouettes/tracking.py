"""Silhouette clean-up, subject tracking and region-of-interest crops (paper Section 2.2).

After segmentation (or sketching) every frame is a binary image. The subject is the connected
component nearest to where it was in the previous frame (centre of mass tracking); a window of
one fixed size per clip is cut around it, so that PCA sees the animal's shape and not its
position in the frame.

Long clips never hold full-frame masks: :class:`SubjectTracker` picks the component frame by
frame and :class:`RoiAccumulator` keeps only its tight bounding-box crop, bit-packed, until
the window size of the whole clip is known.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report

WORK_SIDE_PX = 160
"""Longer side, in pixels, of the ROI crops the analysis works on (the PCA working size): small
enough that a long clip's silhouettes fit in memory, large enough to keep the legs."""

EDGE_LEFT, EDGE_TOP, EDGE_RIGHT, EDGE_BOTTOM = 1, 2, 4, 8
"""Bits of :attr:`RoiClip.edges`: the sides of the frame a silhouette is cut by."""
EDGE_NAMES = {EDGE_LEFT: "left", EDGE_TOP: "top", EDGE_RIGHT: "right", EDGE_BOTTOM: "bottom"}

EDGE_CONTACT = 0.1
"""A silhouette is cut by a side of the frame when it lies along it over at least this share
of its own extent that way (a hoof that touches the bottom is not cut; a body half out of
the view is)."""


def frame_edges(crop: np.ndarray, box: np.ndarray | tuple, frame_shape: tuple[int, int]) -> int:
    """The sides of a ``frame_shape`` (rows, cols) frame that cut a silhouette, as
    :data:`EDGE_LEFT` | ... bits (0: none).

    Parameters
    ----------
    crop : ndarray of shape (h, w), bool
        The silhouette inside its bounding box.
    box : (x, y, w, h)
        The bounding box in the frame.
    frame_shape : (rows, cols)
    """
    x, y, w, h = (int(v) for v in box)
    rows, cols = frame_shape
    c = np.asarray(crop, dtype=bool)
    sides = ((EDGE_LEFT, x <= 0, c[:, 0], h), (EDGE_TOP, y <= 0, c[0, :], w),
             (EDGE_RIGHT, x + w >= cols, c[:, -1], h), (EDGE_BOTTOM, y + h >= rows, c[-1, :], w))
    return sum(bit for bit, touches, line, extent in sides
               if touches and np.count_nonzero(line) >= EDGE_CONTACT * extent)


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
    scale : float
        Crop pixels per source pixel (1.0 unless the window was shrunk to a working size).
    edges : ndarray of shape (n,), uint8, or None
        The sides of the frame that cut each frame's silhouette (:func:`frame_edges` bits; 0
        where lost); None when the frame's size was not known.
    """

    crops: np.ndarray
    centers_xy: np.ndarray
    lost: np.ndarray
    scale: float = 1.0
    edges: np.ndarray | None = None

    @property
    def size_rc(self) -> tuple[int, int]:
        return int(self.crops.shape[1]), int(self.crops.shape[2])


class SubjectTracker:
    """Choose, frame after frame, the connected component that continues the subject's track.

    Parameters
    ----------
    min_area : int
        Components smaller than this many pixels are ignored as noise.
    hint : ndarray of shape (rows, cols), bool, optional
        Pixels known to be on the subject in the first frame (e.g. the subject rectangles):
        the first frame keeps the component that overlaps it most.

    Notes
    -----
    Paper Section 2.2. On the first frame the largest component (or the one under ``hint``) is
    the subject. After that, the component whose centre is nearest to the previous centre is
    kept, with area as the tie-breaker: candidates are scored by distance divided by the
    square root of their area.
    """

    def __init__(self, *, min_area: int = 1, hint: np.ndarray | None = None) -> None:
        self.min_area = max(1, int(min_area))
        self.hint = hint
        self.prev_xy: np.ndarray | None = None

    def update(
        self, mask: np.ndarray, *, origin_xy: tuple[int, int] = (0, 0)
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Find the subject in one binary frame.

        Parameters
        ----------
        mask : ndarray of shape (rows, cols)
            Any non-zero value is foreground.
        origin_xy : (int, int)
            Frame position of ``mask[0, 0]`` when ``mask`` is only a part of the frame that
            holds all its foreground (``hint`` must then be None).

        Returns
        -------
        (crop, box, center_xy) or None
            ``crop`` (h, w) bool: the component inside its bounding box; ``box`` (4,) int:
            x, y, w, h; ``center_xy`` (2,) float: centre of mass. None when no component is
            large enough (the subject is lost in this frame; the track keeps its last centre).
        """
        m = mask if mask.dtype == np.uint8 else (mask != 0).astype(np.uint8)
        count, labels, stats, cents = cv2.connectedComponentsWithStats(m, connectivity=8)
        stats[:, :2] += np.asarray(origin_xy, dtype=stats.dtype)
        cents = cents + np.asarray(origin_xy, dtype=float)
        areas = stats[1:, cv2.CC_STAT_AREA]
        ok = np.nonzero(areas >= self.min_area)[0]
        if not ok.size:
            return None
        if self.prev_xy is None:
            best = ok[np.argmax(areas[ok])]
            if self.hint is not None:
                overlap = np.bincount(labels[self.hint].ravel(), minlength=count)[1:]
                if overlap[ok].max() > 0:
                    best = ok[np.argmax(overlap[ok])]
        else:
            dist = np.linalg.norm(cents[1:][ok] - self.prev_xy, axis=1)
            best = ok[np.argmin(dist / np.sqrt(areas[ok]))]
        label = best + 1
        x, y, w, h = (int(v) for v in stats[label, :4])
        ox, oy = origin_xy
        crop = labels[y - oy : y - oy + h, x - ox : x - ox + w] == label
        self.prev_xy = cents[label].copy()
        return crop, np.array([x, y, w, h]), cents[label].copy()


class RoiAccumulator:
    """Collect per-frame tight crops of the subject, then cut equal windows around it.

    Memory per frame is the subject's bounding box at one bit per pixel, so a 10,000-frame
    clip costs tens of megabytes, not the gigabytes of its full-frame masks.

    Notes
    -----
    Paper Section 2.2: one window size per clip, centred on the centre of mass.
    """

    def __init__(self, frame_shape: tuple[int, int] | None = None) -> None:
        self.frame_shape = frame_shape
        self._items: list[tuple[np.ndarray, tuple[int, int], np.ndarray] | None] = []
        self._centers: list[np.ndarray] = []
        self._edges: list[int] = []

    def __len__(self) -> int:
        return len(self._items)

    def add(self, crop: np.ndarray, box: np.ndarray, center_xy: np.ndarray, *,
            frame_shape: tuple[int, int] | None = None) -> None:
        """Append one frame: ``crop`` (h, w) bool at ``box`` (x, y, w, h), its centre (x, y);
        ``frame_shape`` (rows, cols) of the source frame, once known, says which of its sides
        the silhouettes touch (kept for the frames after)."""
        if frame_shape is not None:
            self.frame_shape = (int(frame_shape[0]), int(frame_shape[1]))
        self.add_lost()
        self.replace(len(self) - 1, (crop, box, center_xy))

    def add_lost(self) -> None:
        """Append a frame where the subject was not found."""
        self._items.append(None)
        self._centers.append(np.full(2, np.nan))
        self._edges.append(0)

    def copy(self) -> RoiAccumulator:
        """A copy that shares the frames' packed crops (they are never changed in place:
        :meth:`replace` puts new ones), so that keeping copies for undo costs little."""
        other = RoiAccumulator(self.frame_shape)
        other._items, other._centers = list(self._items), list(self._centers)
        other._edges = list(self._edges)
        return other

    def replace(self, t: int, found: tuple[np.ndarray, np.ndarray, np.ndarray] | None) -> None:
        """Put frame ``t`` again: ``found`` is ``(crop, box, center_xy)`` as for :meth:`add`,
        or None where the subject was lost (a correction re-cut the frame)."""
        if found is None:
            self._items[t], self._centers[t], self._edges[t] = None, np.full(2, np.nan), 0
            return
        crop, box, center_xy = found
        crop = np.asarray(crop, dtype=bool)
        self._items[t] = (np.packbits(crop, axis=None), crop.shape, np.asarray(box, int))
        self._centers[t] = np.asarray(center_xy, dtype=float)
        self._edges[t] = (0 if self.frame_shape is None
                          else frame_edges(crop, box, self.frame_shape))

    def finish(self, *, margin: float = 0.05, max_side: int | None = None) -> RoiClip:
        """Cut the fixed-size windows.

        Parameters
        ----------
        margin : float
            Extra border around the largest bounding box, as a fraction of its size.
        max_side : int, optional
            Shrink the windows (area-averaged, then thresholded at one half) so that their
            longer side is at most this many pixels; None keeps the source resolution.

        Returns
        -------
        RoiClip

        Raises
        ------
        GaitInputError
            When the subject was found in no frame at all.
        """
        n = len(self._items)
        centers = np.array(self._centers, dtype=float).reshape(n, 2)
        lost = np.isnan(centers[:, 0])
        if n == 0 or lost.all():
            raise GaitInputError(
                "no subject found in any frame: the masks are empty; draw the box (or the "
                "rectangles) closer around the animal, or paint subject strokes on it"
            )
        boxes = np.array([it[2] for it in self._items if it is not None])
        w = int(np.ceil(boxes[:, 2].max() * (1 + 2 * margin))) + 2
        h = int(np.ceil(boxes[:, 3].max() * (1 + 2 * margin))) + 2
        scale = 1.0 if max_side is None else min(1.0, max_side / max(w, h))
        out_wh = (max(1, round(w * scale)), max(1, round(h * scale)))
        crops = np.zeros((n, out_wh[1], out_wh[0]), dtype=bool)
        window = np.zeros((h, w), dtype=np.uint8)
        for t in np.nonzero(~lost)[0]:
            item = self._items[t]
            assert item is not None  # a frame with a centre has its crop
            bits, shape, (bx, by, bw, bh) = item
            tight = np.unpackbits(bits, count=shape[0] * shape[1]).reshape(shape)
            x0 = int(round(centers[t, 0] - w / 2))
            y0 = int(round(centers[t, 1] - h / 2))
            window[:] = 0
            _paste(window, tight, bx - x0, by - y0)
            if scale < 1.0:
                small = cv2.resize(window * np.uint8(255), out_wh, interpolation=cv2.INTER_AREA)
                crops[t] = small >= 128
            else:
                crops[t] = window != 0
        edges = None if self.frame_shape is None else np.array(self._edges, dtype=np.uint8)
        return RoiClip(crops=crops, centers_xy=centers, lost=lost, scale=float(scale),
                       edges=edges)


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
        Called after each frame; returning False cancels with ``Cancelled``.

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
    See :class:`SubjectTracker` for the rule (paper Section 2.2). This function holds the
    whole clip; :func:`crop_rois` does not.
    """
    n = masks.shape[0]
    rows, cols = masks.shape[1:]
    tracker = SubjectTracker(min_area=int(min_area_frac * rows * cols))
    subject = np.zeros(masks.shape, dtype=bool)
    centers = np.full((n, 2), np.nan)
    boxes = np.zeros((n, 4), dtype=int)
    for t in range(n):
        found = tracker.update(np.asarray(masks[t]))
        if found is not None:
            crop, box, center = found
            x, y, w, h = box
            subject[t, y : y + h, x : x + w] = crop
            centers[t], boxes[t] = center, box
        report(progress, t + 1, n, "subject tracking cancelled")
    return subject, centers, boxes


def crop_rois(
    masks: np.ndarray | Iterable[np.ndarray],
    *,
    margin: float = 0.05,
    max_side: int | None = None,
    min_area_frac: float = 1e-4,
    progress: Progress | None = None,
) -> RoiClip:
    """Track the subject and cut a fixed-size window around it in every frame.

    Parameters
    ----------
    masks : array_like of shape (n, rows, cols), or an iterable of (rows, cols) masks
        Binary masks of the whole frames (any non-zero value is foreground). An iterable is
        consumed one frame at a time, so a generator keeps memory flat on long clips.
    margin : float
        Extra border around the largest bounding box, as a fraction of its size.
    max_side : int, optional
        Shrink the windows so that their longer side is at most this many pixels (default
        None: keep the source resolution, as the paper does).
    min_area_frac : float
        Components smaller than this fraction of the frame are ignored as noise.
    progress : callable(done, total) -> bool, optional
        Returning False cancels with ``Cancelled`` (total is 0 for an iterable).

    Returns
    -------
    RoiClip

    Raises
    ------
    GaitInputError
        When the masks are not a stack of 2-D images, or the subject is found in no frame.

    Notes
    -----
    Paper Section 2.2 (connected components, centre-of-mass tracking, fixed window).
    """
    if isinstance(masks, np.ndarray) or not hasattr(masks, "__next__"):
        masks = np.asarray(masks)
        if masks.ndim != 3:
            raise GaitInputError(
                f"expected masks of shape (frames, rows, cols), got {masks.shape}"
            )
        total = masks.shape[0]
    else:
        total = 0
    tracker: SubjectTracker | None = None
    acc = RoiAccumulator()
    for t, mask in enumerate(masks):
        mask = np.asarray(mask)
        if mask.ndim != 2:
            raise GaitInputError(f"mask {t} has shape {mask.shape}: expected (rows, cols)")
        if tracker is None:
            tracker = SubjectTracker(min_area=int(min_area_frac * mask.size))
        found = tracker.update(mask)
        if found is None:
            acc.add_lost()
        else:
            acc.add(*found, frame_shape=mask.shape)
        report(progress, t + 1, total, "subject tracking cancelled")
    return acc.finish(margin=margin, max_side=max_side)


def stabilize_rois(roi: RoiClip, period_frames: float) -> RoiClip:
    """Re-centre every crop on the subject's track averaged over one gait period.

    Parameters
    ----------
    roi : RoiClip
        Crops centred on each frame's own centre of mass.
    period_frames : float
        Gait period (from a first diagnosis); the moving average spans this many frames.

    Returns
    -------
    RoiClip
        Crops, padded just enough, centred on the smoothed track (``centers_xy``).

    Notes
    -----
    The paper centres the window on each frame's centre of mass (Section 2.2), which
    follows the legs' swing as much as the animal's travel and throws away the body's
    vertical motion. A moving average over exactly one period cancels the per-stride wobble
    (its zeros fall on the gait frequency and its harmonics) while following the travel, so
    the window stops jittering with the stride and the body's bounce stays in the images.
    """
    n = roi.crops.shape[0]
    width = int(round(period_frames))
    found = np.nonzero(~roi.lost)[0]
    if width < 2 or found.size < 2:
        return roi
    t = np.arange(n)
    raw = np.column_stack([np.interp(t, found, roi.centers_xy[found, k]) for k in range(2)])
    smooth = np.column_stack([moving_average(raw[:, k], width) for k in range(2)])
    shift = np.round((raw - smooth) * roi.scale).astype(int)  # (dx, dy) in crop pixels
    shift[roi.lost] = 0
    pad_x, pad_y = np.abs(shift).max(axis=0)
    rows, cols = roi.crops.shape[1:]
    crops = np.zeros((n, rows + 2 * pad_y, cols + 2 * pad_x), dtype=roi.crops.dtype)
    for f in found:
        y0, x0 = pad_y + shift[f, 1], pad_x + shift[f, 0]
        crops[f, y0 : y0 + rows, x0 : x0 + cols] = roi.crops[f]
    centers = np.where(roi.lost[:, None], np.nan, smooth)
    return RoiClip(crops=crops, centers_xy=centers, lost=roi.lost, scale=roi.scale,
                   edges=roi.edges)


def moving_average(track: np.ndarray, width: int, *, fit_degree: int = 1) -> np.ndarray:
    """Moving average over ``width`` frames, continued linearly over the half-width at each
    end (padding with the end value would leave a stride's wobble there).

    Parameters
    ----------
    track : ndarray of shape (n,)
    width : int
        Frames averaged, >= 2.
    fit_degree : int
        A clip shorter than two widths gets, instead, the least-squares polynomial of this
        degree in time.

    Returns
    -------
    ndarray of shape (n,)
    """
    n = track.size
    if n < 2 * width:
        t = np.linspace(-1.0, 1.0, n)
        return np.polyval(np.polyfit(t, track, min(fit_degree, n - 1)), t)
    valid = np.convolve(track, np.ones(width) / width, mode="valid")
    at = np.arange(valid.size) + (width - 1) / 2.0
    t = np.arange(n, dtype=float)
    out = np.interp(t, at, valid)
    head, tail = t < at[0], t > at[-1]
    out[head] = valid[0] + (t[head] - at[0]) * (valid[width] - valid[0]) / width
    out[tail] = valid[-1] + (t[tail] - at[-1]) * (valid[-1] - valid[-1 - width]) / width
    return out


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """Fill the holes of a binary mask (flood fill of the outside from the border).

    Parameters
    ----------
    mask : ndarray of shape (rows, cols), uint8 (0/1)

    Returns
    -------
    ndarray of shape (rows, cols), uint8 (0/1)

    Notes
    -----
    Part of the paper's "standard morphological analysis" (Section 2.2).
    """
    h, w = mask.shape
    flood = np.zeros((h + 2, w + 2), np.uint8)
    flood[1:-1, 1:-1] = mask
    cv2.floodFill(flood, np.zeros((h + 4, w + 4), np.uint8), (0, 0), 1)
    return (mask | (1 - flood[1:-1, 1:-1])).astype(np.uint8)


def keep_overlapping(mask: np.ndarray, reference: np.ndarray, *,
                     least: float | None = None) -> np.ndarray:
    """The connected component of ``mask`` that overlaps ``reference`` most.

    Parameters
    ----------
    mask : ndarray of shape (rows, cols), uint8 (0/1)
    reference : ndarray of shape (rows, cols)
        E.g. the silhouette predicted from the previous frame (non-zero is inside).
    least : float, optional
        Keep every component whose overlap is at least this share of the best one's
        (a leg cut off by a shadow still touches the prediction), not only the best.

    Returns
    -------
    ndarray of shape (rows, cols), uint8 (0/1)
        That component (or those); the largest one when none overlaps.
    """
    mask = np.asarray(mask, dtype=np.uint8)
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 2:
        return mask
    overlap = np.bincount(labels[reference > 0], minlength=n)
    overlap[0] = 0
    if overlap.max() == 0:
        overlap = np.bincount(labels.ravel(), minlength=n)
        overlap[0] = 0
    elif least is not None:
        keep = overlap >= least * overlap.max()
        keep[0] = False
        return keep[labels].astype(np.uint8)
    return (labels == int(np.argmax(overlap))).astype(np.uint8)


def _paste(window: np.ndarray, tight: np.ndarray, x: int, y: int) -> None:
    """OR ``tight`` into ``window`` with its top-left corner at (x, y), clipped."""
    h, w = window.shape
    th, tw = tight.shape
    sx0, sy0 = max(0, -x), max(0, -y)
    dx0, dy0 = max(0, x), max(0, y)
    cw, ch = min(tw - sx0, w - dx0), min(th - sy0, h - dy0)
    if cw > 0 and ch > 0:
        window[dy0 : dy0 + ch, dx0 : dx0 + cw] |= tight[sy0 : sy0 + ch, sx0 : sx0 + cw]
