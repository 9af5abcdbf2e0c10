"""Colour segmentation of the subject from rectangles on the first frame (paper Section 2.2).

The artist draws rectangles over the subject and over the background on the first frame. A
Gaussian mixture colour model of each (fitted in CIE Lab) gives every colour a posterior
probability of being the subject, tabulated once in a lookup table over quantized BGR so
that classifying a frame is one table lookup per pixel.

Two methods:

``"gmm"``
    The paper's: posterior above one half, morphological opening and closing, the connected
    component continuing the subject's track (centre of mass), holes filled.
``"grabcut"`` (default)
    Better than the paper: the previous frame's silhouette, shifted by the subject's motion,
    bounds a band where ``cv2.grabCut`` (graph cut on colour with a smoothness term) decides,
    started from the colour model's labels, at a reduced working resolution (chosen from the
    frame, or from the subject when it is small in the frame); the colour model
    is refitted from confident pixels every few frames (mixed with the first frame's so it
    cannot drift away); a subject that shrinks away is declared lost and searched for again
    in the whole frame with the colour model.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.silhouettes.annotations import Rect
from gaitcore.silhouettes.colour_model import ColourModel, check_frame, rect_mask
from gaitcore.silhouettes.tracking import (
    WORK_SIDE_PX,
    RoiAccumulator,
    RoiClip,
    SubjectTracker,
    fill_holes,
    keep_overlapping,
)

MaskSink = Callable[[int, np.ndarray], None]
METHODS = ("gmm", "grabcut")


@dataclass(frozen=True)
class SegmentationSettings:
    """Options of :func:`segment_clip` and :func:`segment_frame`.

    Attributes
    ----------
    method : {"grabcut", "gmm"}
        See the module docstring.
    n_components : int
        Gaussians per colour model.
    lut_bits : int
        Quantization of each BGR channel in the posterior table (5: 32 levels, 6: 64 levels).
    work_side_px : int
        ``"grabcut"`` works on frames shrunk so that their longer side is at most this...
    subject_side_px : int
        ... unless the silhouette found there in the first frame is less than 3/4 of this
        across (its longer side): then the working size grows (never beyond the source's)
        until the subject is this big, for the whole clip, and the first frame is segmented
        again, so a small animal in HD footage keeps its detail. 0 turns this off.
    band_frac : float
        Half-width of the band searched around the predicted silhouette, as a fraction of the
        silhouette's longer side.
    grabcut_iters : int
        Graph-cut iterations per frame.
    refit_every : int
        Refit the colour model every this many frames (0: never).
    keep_first : float
        Weight of the first frame's colour samples in each refit, in [0, 1].
    lost_area_ratio : float
        A silhouette smaller than this fraction of the subject's usual area counts as lost.
    min_area_frac : float
        Components smaller than this fraction of the frame are noise.
    """

    method: str = "grabcut"
    n_components: int = 5
    lut_bits: int = 5
    work_side_px: int = 192
    subject_side_px: int = 96
    band_frac: float = 0.06
    grabcut_iters: int = 1
    reach_frac: float = 0.2
    reach_prob: int = 230
    refit_every: int = 20
    keep_first: float = 0.5
    lost_area_ratio: float = 0.25
    min_area_frac: float = 1e-3

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise GaitInputError(
                f"unknown segmentation method {self.method!r}: use one of {METHODS}"
            )
        if not 4 <= self.lut_bits <= 7:
            raise GaitInputError(f"lut_bits must be 4..7, got {self.lut_bits}")
        if self.n_components < 1 or self.work_side_px < 32 or self.grabcut_iters < 1:
            raise GaitInputError(
                f"segmentation settings out of range (n_components={self.n_components}, "
                f"work_side_px={self.work_side_px}, grabcut_iters={self.grabcut_iters}): use "
                "n_components >= 1, work_side_px >= 32, grabcut_iters >= 1"
            )


# -- per-frame segmentation ---------------------------------------------------------------
def _disk(r: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


Found = tuple[np.ndarray, np.ndarray, np.ndarray]  # crop (h, w) bool, box x,y,w,h, centre xy


class _Segmenter:
    """Frame-to-frame state of one clip's segmentation (both methods)."""

    def __init__(self, model: ColourModel, settings: SegmentationSettings, shape: tuple[int, int],
                 hint: np.ndarray | None = None, background: np.ndarray | None = None) -> None:
        self.model, self.s, self.shape = model, settings, shape
        rows, cols = shape
        self.min_area = max(1, int(settings.min_area_frac * rows * cols))
        self._set_scale(min(1.0, settings.work_side_px / max(rows, cols)))
        self.hint, self.background = hint, background  # full-frame bool, first frame only
        self.prev: np.ndarray | None = None  # last silhouette at working size, uint8 0/1
        self.velocity = np.zeros(2)
        self.last_xy: np.ndarray | None = None  # working-size centre of the last silhouette
        self.ref_area = 0.0  # running mean of the silhouette's working-size area
        self.count = 0
        self.gc_models: tuple[np.ndarray, np.ndarray] | None = None
        self.tracker = SubjectTracker(min_area=self.min_area, hint=hint)

    def continue_from(self, previous: np.ndarray) -> None:
        """Take ``previous`` (full-frame bool) as the silhouette of the preceding frame."""
        if not previous.any():
            return
        self.tracker.hint = previous
        if self.s.method == "grabcut":
            self.prev = self._small(previous).astype(np.uint8)
            self.ref_area = float(self.prev.sum())

    def _set_scale(self, scale: float) -> None:
        rows, cols = self.shape
        self.scale = scale
        self.work_wh = (max(1, round(cols * scale)), max(1, round(rows * scale)))

    def _grow_scale(self) -> bool:
        """Work at a finer size when the subject is small there; True when it changed.

        The tracking state moves to the new size; the graph cut's colour models are learnt
        afresh.
        """
        target = self.s.subject_side_px
        if not target or self.prev is None or self.scale >= 1.0:
            return False
        _, _, w, h = cv2.boundingRect(self.prev)
        if max(w, h) >= 0.75 * target:
            return False
        old = self.scale
        self._set_scale(min(1.0, old * target / max(w, h, 1)))
        ratio = self.scale / old
        self.prev = cv2.resize(self.prev, self.work_wh, interpolation=cv2.INTER_NEAREST)
        self.last_xy = None if self.last_xy is None else self.last_xy * ratio
        self.velocity = np.zeros(2)
        self.ref_area *= ratio**2
        self.gc_models = None
        return True

    def step(self, frame: np.ndarray) -> Found | None:
        """The subject's component in ``frame`` (as ``SubjectTracker.update``), None if lost."""
        found = self._gmm(frame) if self.s.method == "gmm" else self._grabcut(frame)
        if found is not None and self.s.method == "grabcut" and self.count == 0 \
                and self._grow_scale():
            found = self._grabcut(frame)  # the first frame again, at the finer size
        self.count += 1
        self.hint = self.background = None
        return found

    def _gmm(self, frame: np.ndarray) -> Found | None:
        """The paper's method: posterior > 1/2, opening, closing, tracked component, filled."""
        m = (self.model.posterior(frame) > 127).astype(np.uint8)
        r = max(1, round(min(self.shape) / 240))
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, _disk(r))
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, _disk(3 * r))
        found = self.tracker.update(m)
        if found is None:
            return None
        crop, box, centre = found
        return fill_holes(crop.astype(np.uint8)) > 0, box, centre

    def _grabcut(self, frame: np.ndarray) -> Found | None:
        """Graph cut in a band around the predicted silhouette, at the working size."""
        small = _shrink(frame, self.work_wh)
        pred = self._predict() if self.prev is not None else self._detect(small)
        if pred is None:
            return None
        lab, (x0, y0), r = self._labels(small, pred)
        h, w = lab.shape
        is_fg = (lab == cv2.GC_FGD) | (lab == cv2.GC_PR_FGD)
        if min(np.count_nonzero(is_fg), is_fg.size - np.count_nonzero(is_fg)) >= 16:
            # Colour models of the graph cut: learnt afresh now and then, otherwise frozen
            # (faster, and steadier from frame to frame).
            fresh = self.gc_models is None or self.prev is None or (
                self.s.refit_every and self.count % self.s.refit_every == 0)
            if fresh:
                self.gc_models = np.zeros((1, 65)), np.zeros((1, 65))
            mode = cv2.GC_INIT_WITH_MASK if fresh else cv2.GC_EVAL_FREEZE_MODEL
            cv2.grabCut(small[y0 : y0 + h, x0 : x0 + w], lab, None, *self.gc_models,
                        self.s.grabcut_iters, mode)
            is_fg = (lab == cv2.GC_FGD) | (lab == cv2.GC_PR_FGD)
        res = np.zeros(pred.shape, np.uint8)
        res[y0 : y0 + h, x0 : x0 + w] = keep_overlapping(is_fg.astype(np.uint8),
                                                          pred[y0 : y0 + h, x0 : x0 + w])
        area = float(res.sum())
        if area < max(self.min_area * self.scale**2, self.s.lost_area_ratio * self.ref_area):
            self.prev = None  # lost: search the whole frame next time
            return None
        self.ref_area = area if self.ref_area == 0 else 0.9 * self.ref_area + 0.1 * area
        m = cv2.moments(res, binaryImage=True)
        xy = np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])
        tracking = self.prev is not None and self.last_xy is not None
        self.velocity = xy - self.last_xy if tracking else np.zeros(2)
        self.last_xy, self.prev = xy, res
        if self.s.refit_every and self.count and self.count % self.s.refit_every == 0:
            ring = (cv2.dilate(res, _disk(3 * r)) > 0) & (cv2.dilate(res, _disk(r)) == 0)
            conf = (cv2.erode(res, _disk(r)) > 0) & (self.model.posterior(small) > 127)
            self.model = self.model.refit(small, conf, ring, keep_first=self.s.keep_first)
        return self._upsample(res)

    def _labels(
        self, small: np.ndarray, pred: np.ndarray
    ) -> tuple[np.ndarray, tuple[int, int], int]:
        """GrabCut labels around ``pred``: (labels cropped to the undecided area, its x0 y0,
        band half-width). Band: colour model's guess; deep inside: sure subject where the
        colour agrees; beyond the band, only strongly subject-coloured pixels; else background.
        """
        ys, xs = np.nonzero(pred)
        side = max(np.ptp(xs), np.ptp(ys)) + 1
        r = max(2, round(self.s.band_frac * side))
        reach = max(r, round(self.s.reach_frac * side))
        y0, y1 = max(0, ys.min() - reach - 2), min(pred.shape[0], ys.max() + reach + 3)
        x0, x1 = max(0, xs.min() - reach - 2), min(pred.shape[1], xs.max() + reach + 3)
        psub = pred[y0:y1, x0:x1]
        outside = cv2.distanceTransform(1 - psub, cv2.DIST_L2, cv2.DIST_MASK_5)
        inside = cv2.distanceTransform(np.pad(psub, 1), cv2.DIST_L2, cv2.DIST_MASK_5)[1:-1, 1:-1]
        post = self.model.posterior(small[y0:y1, x0:x1])
        fg = post > 127
        lab = np.where(outside <= r, np.where(fg, cv2.GC_PR_FGD, cv2.GC_PR_BGD), cv2.GC_BGD)
        lab = lab.astype(np.uint8)
        lab[(inside > r) & fg] = cv2.GC_FGD
        lab[(outside > r) & (outside <= reach) & (post >= self.s.reach_prob)] = cv2.GC_PR_FGD
        if self.hint is not None:
            lab[self._small(self.hint)[y0:y1, x0:x1]] = cv2.GC_FGD
            lab[self._small(self.background)[y0:y1, x0:x1]] = cv2.GC_BGD
        # Graph-cut only around the undecided pixels (its cost grows with the area).
        bx, by, bw, bh = cv2.boundingRect((lab != cv2.GC_BGD).astype(np.uint8))
        cx0, cy0 = max(0, bx - 3), max(0, by - 3)
        cx1, cy1 = min(lab.shape[1], bx + bw + 3), min(lab.shape[0], by + bh + 3)
        return np.ascontiguousarray(lab[cy0:cy1, cx0:cx1]), (x0 + cx0, y0 + cy0), r

    def _upsample(self, res: np.ndarray) -> Found | None:
        """The working-size silhouette at frame size, computed only around it."""
        x, y, w, h = cv2.boundingRect(res)
        fx, fy = self.shape[1] / self.work_wh[0], self.shape[0] / self.work_wh[1]
        X0, Y0 = max(0, int((x - 1) * fx)), max(0, int((y - 1) * fy))
        X1 = min(self.shape[1], int(np.ceil((x + w + 1) * fx)))
        Y1 = min(self.shape[0], int(np.ceil((y + h + 1) * fy)))
        # Same sampling as cv2.resize of the whole mask: src = (dst + 1/2) / f - 1/2.
        warp = np.array([[1 / fx, 0, (X0 + 0.5) / fx - 0.5], [0, 1 / fy, (Y0 + 0.5) / fy - 0.5]])
        up = cv2.warpAffine(res * np.uint8(255), warp, (X1 - X0, Y1 - Y0),
                            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                            borderMode=cv2.BORDER_REPLICATE)
        return SubjectTracker(min_area=1).update(up > 127, origin_xy=(X0, Y0))

    def _small(self, full_mask: np.ndarray) -> np.ndarray:
        small = cv2.resize(full_mask.astype(np.uint8), self.work_wh,
                           interpolation=cv2.INTER_NEAREST)
        return small > 0

    def _predict(self) -> np.ndarray:
        """Last silhouette united with itself moved by the last displacement."""
        dx, dy = np.round(self.velocity).astype(int)
        if dx == 0 and dy == 0:
            return self.prev
        shift = np.float32([[1, 0, dx], [0, 1, dy]])
        return self.prev | cv2.warpAffine(self.prev, shift, self.work_wh, flags=cv2.INTER_NEAREST)

    def _detect(self, small: np.ndarray) -> np.ndarray | None:
        """Find the subject with the colour model alone (first frame, or after losing it)."""
        m = (self.model.posterior(small) > 127).astype(np.uint8)
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, _disk(1))
        hint = None if self.hint is None else self._small(self.hint)
        if hint is not None:
            m[hint] = 1
        n, labels, stats, cents = cv2.connectedComponentsWithStats(m, connectivity=8)
        areas = stats[1:, cv2.CC_STAT_AREA].astype(float)
        least = max(self.min_area * self.scale**2, self.s.lost_area_ratio * self.ref_area)
        ok = np.nonzero(areas >= least)[0]
        if not ok.size:
            return None
        if hint is not None:
            best = ok[np.argmax(np.bincount(labels[hint], minlength=n)[1:][ok])]
        elif self.last_xy is not None:
            dist = np.linalg.norm(cents[1:][ok] - self.last_xy, axis=1)
            best = ok[np.argmin(dist / np.sqrt(areas[ok]))]
        else:
            best = ok[np.argmax(areas[ok])]
        return fill_holes((labels == best + 1).astype(np.uint8))


# -- public API -------------------------------------------------------------------------
def segment_frame(
    frame_bgr: np.ndarray,
    model: ColourModel,
    *,
    previous: np.ndarray | None = None,
    subject_rects: Sequence[Rect | tuple] = (),
    background_rects: Sequence[Rect | tuple] = (),
    settings: SegmentationSettings | None = None,
) -> np.ndarray:
    """Segment one frame (e.g. the one the GUI shows) with a fitted colour model.

    Parameters
    ----------
    frame_bgr : ndarray of shape (rows, cols, 3), uint8
    model : ColourModel
        From :meth:`ColourModel.fit` on the first frame.
    previous : ndarray of shape (rows, cols), optional
        The subject's silhouette in the preceding frame; ``"grabcut"`` searches near it.
        Without it the subject is the colour component under ``subject_rects``, else the
        largest one.
    subject_rects, background_rects : sequence of Rect or (x, y, w, h)
        Sure subject and sure background in this frame (the first frame's rectangles).
    settings : SegmentationSettings, optional

    Returns
    -------
    ndarray of shape (rows, cols), bool
        The subject's silhouette; all False when it is not found.

    Raises
    ------
    GaitInputError
        Bad frame, rectangles outside the frame, ``previous`` of the wrong shape.

    Notes
    -----
    Paper Section 2.2; see the module docstring for what ``"grabcut"`` adds.
    """
    frame = check_frame(frame_bgr)
    s = settings or SegmentationSettings()
    _reset_rng()
    hint = rect_mask(frame.shape, subject_rects, "subject") if subject_rects else None
    bg = rect_mask(frame.shape, background_rects, "background") if background_rects else None
    seg = _Segmenter(model, s, frame.shape[:2], hint, bg if hint is not None else None)
    if previous is not None:
        prev = np.asarray(previous)
        if prev.shape != frame.shape[:2]:
            raise GaitInputError(
                f"previous mask is {prev.shape} but the frame is {frame.shape[:2]}: "
                "give the silhouette of the preceding frame of the same clip"
            )
        seg.continue_from(prev != 0)
    out = np.zeros(frame.shape[:2], bool)
    found = seg.step(frame)
    if found is not None:
        crop, (x, y, w, h), _ = found
        out[y : y + h, x : x + w] = crop
    return out


def segment_clip(
    source: Iterable[np.ndarray],
    subject_rects: Sequence[Rect | tuple],
    background_rects: Sequence[Rect | tuple],
    *,
    method: str | None = None,
    settings: SegmentationSettings | None = None,
    margin: float = 0.05,
    max_side: int | None = WORK_SIDE_PX,
    progress: Progress | None = None,
    mask_sink: MaskSink | None = None,
) -> RoiClip:
    """Segment every frame of a clip and cut the subject's fixed-size window (paper 2.2).

    Parameters
    ----------
    source : FrameSource or sequence of ndarray (rows, cols, 3) uint8
        The clip; a :class:`gaitcore.footage.sources.FrameSource` is streamed (decoded on a second
        thread while segmenting), so memory does not grow with its length.
    subject_rects, background_rects : sequence of Rect or (x, y, w, h)
        Drawn on the first frame over the subject and over the background (at least one each).
    method : {"grabcut", "gmm"}, optional
        ``"gmm"`` is the paper's plain mixture model; ``"grabcut"`` the improved default.
        Overrides ``settings.method`` when given.
    settings : SegmentationSettings, optional
    margin : float
        Border around the largest bounding box of the silhouette, fraction of its size.
    max_side : int or None
        Longer side of the ROI windows in pixels (default :data:`~gaitcore.silhouettes.tracking.WORK_SIDE_PX`, the PCA working size of
        ``gaitcore.analysis.analyze``; 10,000 frames then take at most 256 MB); None keeps the
        source resolution.
    progress : callable(done, total) -> bool, optional
        Called after each frame; returning False cancels with ``Cancelled``.
    mask_sink : callable(frame_index, mask), optional
        Receives each full-frame silhouette, (rows, cols) uint8 0/255 (zeros where lost).

    Returns
    -------
    RoiClip
        Lost frames are flagged in ``lost`` with empty crops.

    Raises
    ------
    GaitInputError
        Empty clip, bad rectangles, unreadable frames, or no subject in any frame.
    Cancelled
        When ``progress`` returned False.
    """
    s = settings or SegmentationSettings()
    if method is not None:
        s = replace(s, method=method)
    total = len(source) if hasattr(source, "__len__") else 0
    if hasattr(source, "iter_frames"):
        stream = source.iter_frames(prefetch=4)
        frames: Iterable[np.ndarray] = (img for _, img in stream)
    else:
        stream = frames = iter(source)
    seg: _Segmenter | None = None
    acc = RoiAccumulator()
    try:
        for t, frame in enumerate(frames):
            frame = check_frame(frame)
            if seg is None:
                _reset_rng()
                model = ColourModel.fit(frame, subject_rects, background_rects,
                                        n_components=s.n_components, lut_bits=s.lut_bits)
                hint = rect_mask(frame.shape, subject_rects, "subject")
                bg = rect_mask(frame.shape, background_rects, "background")
                seg = _Segmenter(model, s, frame.shape[:2], hint & ~bg, bg & ~hint)
            elif frame.shape[:2] != seg.shape:
                raise GaitInputError(f"frame {t} is {frame.shape[:2]} but frame 0 is {seg.shape}: "
                                     "all frames must have the same size")
            found = seg.step(frame)
            if found is None:
                acc.add_lost()
            else:
                acc.add(*found)
            if mask_sink is not None:
                out = np.zeros(seg.shape, np.uint8)
                if found is not None:
                    crop, (x, y, w, h), _ = found
                    out[y : y + h, x : x + w] = crop * np.uint8(255)
                mask_sink(t, out)
            report(progress, t + 1, max(total, t + 1), "segmentation cancelled")
    finally:
        if hasattr(stream, "close"):
            stream.close()
    if seg is None:
        raise GaitInputError("the clip has no frames: choose another file or frame range")
    return acc.finish(margin=margin, max_side=max_side)


def _reset_rng() -> None:
    """Seed OpenCV's random generator (this thread's) as a fresh process has it.

    The graph cut's colour models start from k-means, which draws from that generator: without
    this, a clip's silhouettes depended on what OpenCV had done before in the same thread (on
    Muybridge's race horse, r2 fell from 0.94 to 0.30 for one of six earlier states).
    """
    cv2.setRNGSeed(0)


def _shrink(image: np.ndarray, size_wh: tuple[int, int]) -> np.ndarray:
    """Area-averaged downscale, halving with ``cv2.pyrDown`` first while the image is more
    than twice the target: as smooth as INTER_AREA on the whole frame at a quarter of its
    cost, which is most of the time of a frame at 854x480."""
    while image.shape[1] >= 2 * size_wh[0] and image.shape[0] >= 2 * size_wh[1]:
        image = cv2.pyrDown(image)
    return cv2.resize(image, size_wh, interpolation=cv2.INTER_AREA)
