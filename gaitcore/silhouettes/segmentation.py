"""Segmentation of the subject in a clip (paper Section 2.2, and beyond it).

Two methods:

``"propagate"`` (default)
    One box around the subject on the first frame is enough (the paper's subject and
    background rectangles also work); the mask travels from frame to frame by dense optical
    flow and is decided by colour models learnt on the key frames, and corrective strokes on
    any frame re-propagate both ways (:mod:`gaitcore.silhouettes.roto`).
``"gmm"``
    The paper's: a Gaussian mixture colour model of the first frame's rectangles, posterior
    above one half, morphological opening and closing, the connected component continuing the
    subject's track (centre of mass), holes filled.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import closing
from dataclasses import replace

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.threads import InOrder
from gaitcore.progress import Progress, report
from gaitcore.silhouettes.annotations import Rect, Scribble
from gaitcore.silhouettes.colour_model import ColourModel, check_frame, rect_mask
from gaitcore.silhouettes.propagate import disk
from gaitcore.silhouettes.roto import FrameState, RotoSegmentation
from gaitcore.silhouettes.settings import SegmentationSettings
from gaitcore.silhouettes.tracking import (
    WORK_SIDE_PX,
    RoiAccumulator,
    RoiClip,
    SubjectTracker,
    fill_holes,
)

MaskSink = Callable[[int, np.ndarray], None]


def _gmm_masks(frames: Iterable[np.ndarray], subject_rects: Sequence[Rect],
               background_rects: Sequence[Rect], s: SegmentationSettings
               ) -> Iterable[tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray] | None]]:
    """The paper's method, frame by frame: (frame, found) with found as
    :meth:`SubjectTracker.update` gives it (None where lost)."""
    model = tracker = shape = None
    for t, frame in enumerate(frames):
        frame = check_frame(frame)
        if model is None:
            model = ColourModel.fit(frame, subject_rects, background_rects,
                                    n_components=s.n_components, lut_bits=s.lut_bits)
            shape = frame.shape[:2]
            hint = rect_mask(frame.shape, subject_rects, "subject")
            tracker = SubjectTracker(min_area=max(1, int(s.min_area_frac * frame[..., 0].size)),
                                     hint=hint)
        elif frame.shape[:2] != shape:
            raise GaitInputError(f"frame {t} is {frame.shape[:2]} but frame 0 is {shape}: "
                                 "all frames must have the same size")
        m = (model.posterior(frame) > 127).astype(np.uint8)
        r = max(1, round(min(shape) / 240))
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, disk(r))
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, disk(3 * r))
        found = tracker.update(m)
        if found is not None:
            crop, box, centre = found
            found = fill_holes(crop.astype(np.uint8)) > 0, box, centre
        yield frame, found


def segment_clip(
    source: Iterable[np.ndarray],
    subject_rects: Sequence[Rect | tuple] = (),
    background_rects: Sequence[Rect | tuple] = (),
    *,
    box: Rect | tuple | None = None,
    scribbles: Sequence[Scribble] = (),
    method: str | None = None,
    settings: SegmentationSettings | None = None,
    margin: float = 0.05,
    max_side: int | None = WORK_SIDE_PX,
    progress: Progress | None = None,
    mask_sink: MaskSink | None = None,
    state_sink: Callable[[int, FrameState], None] | None = None,
) -> RoiClip:
    """Segment every frame of a clip and cut the subject's fixed-size window (paper 2.2).

    Parameters
    ----------
    source : FrameSource or sequence of ndarray (rows, cols, 3) uint8
        The clip; a :class:`gaitcore.footage.sources.FrameSource` is streamed, so memory
        does not grow with its length.
    subject_rects, background_rects : sequence of Rect or (x, y, w, h)
        Drawn on the first frame over the subject and over the background (``"gmm"`` needs
        at least one of each; ``"propagate"`` needs them or ``box``).
    box : Rect or (x, y, w, h), optional
        Around the whole subject on the first frame (``"propagate"`` only).
    scribbles : sequence of Scribble
        Corrective strokes on any frames (``"propagate"`` only).
    method : {"propagate", "gmm"}, optional
        Overrides ``settings.method`` when given.
    settings : SegmentationSettings, optional
    margin : float
        Border around the largest bounding box of the silhouette, fraction of its size.
    max_side : int or None
        Longer side of the ROI windows in pixels (default
        :data:`~gaitcore.silhouettes.tracking.WORK_SIDE_PX`, the PCA working size of
        :mod:`gaitcore.analysis.analyze`); None keeps the source resolution.
    progress : callable(done, total) -> bool, optional
        Returning False cancels with ``Cancelled``.
    mask_sink : callable(frame_index, mask), optional
        Receives each full-frame silhouette, (rows, cols) uint8 0/255 (zeros where lost).
    state_sink : callable(frame_index, FrameState), optional
        Receives lost / corrected / confidence of each frame (``"propagate"`` only).

    Returns
    -------
    RoiClip
        Lost frames are flagged in ``lost`` with empty crops.

    Raises
    ------
    GaitInputError
        Empty clip, bad rectangles, box or scribbles, unreadable frames, or no subject in any
        frame.
    Cancelled
        When ``progress`` returned False.
    """
    s = settings or SegmentationSettings()
    if method is not None:
        s = replace(s, method=method)
    subject_rects = [r if isinstance(r, Rect) else Rect(*r) for r in subject_rects]
    background_rects = [r if isinstance(r, Rect) else Rect(*r) for r in background_rects]
    if s.method == "gmm":
        if box is not None or scribbles:
            raise GaitInputError("the paper's 'gmm' method takes subject and background "
                                 "rectangles only: drop --box and --scribbles, or use "
                                 "'propagate'")
        acc = _segment_gmm(source, subject_rects, background_rects, s, progress, mask_sink)
    else:
        seg = RotoSegmentation(source, box=None if box is None else
                               (box if isinstance(box, Rect) else Rect(*box)),
                               subject_rects=subject_rects, background_rects=background_rects,
                               scribbles=scribbles, settings=s.propagation)
        with RotoCollector(seg, mask_sink, state_sink) as collect:
            seg.run(progress, final=collect)
        acc = collect.acc
    return acc.finish(margin=margin, max_side=max_side)


def _segment_gmm(source, subject_rects, background_rects, s: SegmentationSettings,
                 progress: Progress | None, mask_sink: MaskSink | None) -> RoiAccumulator:
    """The paper's method over the clip, one frame at a time."""
    acc = RoiAccumulator()
    total = len(source) if hasattr(source, "__len__") else 0
    for t, (frame, found) in enumerate(_gmm_masks(_stream(source), subject_rects,
                                                  background_rects, s)):
        _collect(acc, found, frame.shape[:2], t, mask_sink)
        report(progress, t + 1, max(total, t + 1), "segmentation cancelled")
    if not len(acc):
        raise GaitInputError("the clip has no frames: choose another file or frame range")
    return acc


class RotoCollector:
    """Every frame's mask of a propagation, all its components (legs may come apart), into
    the ROI accumulator :attr:`acc` and the sinks, in order, each outlined on its source frame
    (:func:`roto_frame`) on a thread of its own. As :meth:`RotoSegmentation.run`'s ``final``
    it works beside the propagation. Use it as a context manager: :attr:`acc` is whole once
    the block is left without an error."""

    def __init__(self, seg: RotoSegmentation, mask_sink: MaskSink | None,
                 state_sink: Callable[[int, FrameState], None] | None) -> None:
        self.seg, self.acc = seg, RoiAccumulator()
        self._sinks = mask_sink, state_sink
        self._behind = InOrder("mask-outline")

    def __call__(self, t: int, image: np.ndarray) -> None:
        """Take frame ``t`` (``image``: its source frame), its mask final."""
        self._behind.submit(self._take, t, image)

    def _take(self, t: int, image: np.ndarray) -> None:
        found, state = roto_frame(self.seg, t, image)
        mask_sink, state_sink = self._sinks
        _collect(self.acc, found, self.seg.work.shape, t, mask_sink)
        if state_sink is not None:
            state_sink(t, state)

    def __enter__(self) -> RotoCollector:
        return self

    def __exit__(self, *exc) -> None:
        self._behind.__exit__(*exc)


def collect_roto(seg: RotoSegmentation, mask_sink: MaskSink | None,
                 state_sink: Callable[[int, FrameState], None] | None) -> RoiAccumulator:
    """:class:`RotoCollector` of a finished propagation."""
    with RotoCollector(seg, mask_sink, state_sink) as collect:
        seg.each_frame(collect)
    return collect.acc


def roto_frames(seg: RotoSegmentation, start: int = 0, stop: int | None = None
                ) -> Iterator[tuple[int, tuple[np.ndarray, np.ndarray, np.ndarray] | None,
                                    FrameState]]:
    """:func:`roto_frame` of frames ``start <= t < stop`` (to the end: None) in order, as
    ``(t, found, state)``, their source frames decoded on a thread ahead
    (:meth:`RotoSegmentation.images`)."""
    with closing(seg.images(start, stop)) as images:
        for t, image in images:
            yield (t, *roto_frame(seg, t, image))


def roto_frame(seg: RotoSegmentation, t: int, image: np.ndarray | None = None
               ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray] | None, FrameState]:
    """Frame ``t`` of a finished propagation as the ROI accumulator takes it: ``(crop, box,
    center_xy)`` of the whole mask (all its components: legs may come apart), None where the
    subject is lost; and what the segmentation says of the frame (``image``: its source frame,
    when the caller holds it)."""
    mask, state = seg.frame(t, image)
    if not mask.any():  # lost frames come empty
        return None, state
    x, y, w, h = cv2.boundingRect(mask.astype(np.uint8))
    crop = mask[y : y + h, x : x + w]
    m = cv2.moments(crop.astype(np.uint8), binaryImage=True)
    return (crop, np.array([x, y, w, h]),
            np.array([x + m["m10"] / m["m00"], y + m["m01"] / m["m00"]])), state


def _stream(source) -> Iterable[np.ndarray]:
    if hasattr(source, "iter_frames"):
        stream = source.iter_frames(prefetch=4)
        try:
            for _, img in stream:
                yield img
        finally:
            stream.close()
    else:
        yield from source


def _collect(acc: RoiAccumulator, found, shape: tuple[int, int], t: int,
             mask_sink: MaskSink | None) -> None:
    """Add one frame to the ROI accumulator and hand its full-frame mask to the sink."""
    if found is None:
        acc.add_lost()
    else:
        acc.add(*found, frame_shape=shape)
    if mask_sink is not None:
        mask_sink(t, full_frame_mask(found, shape))


def full_frame_mask(found: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
                    shape: tuple[int, int]) -> np.ndarray:
    """A frame's mask as the masks folder holds it, (rows, cols) uint8 0/255, from its
    ``(crop, box, center_xy)`` (None: lost, all zeros)."""
    out = np.zeros(shape, np.uint8)
    if found is not None:
        crop, (x, y, w, h), _ = found
        out[y : y + h, x : x + w] = crop * np.uint8(255)
    return out
