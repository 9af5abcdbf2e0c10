"""The first frame's cut, from the box, the rectangles or the strokes on it.

A part of :class:`~gaitcore.silhouettes.roto.RotoSegmentation` (a mixin of its methods).
"""

from __future__ import annotations

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.silhouettes.colour_model import (
    ColourModel,
    check_frame,
    rect_mask,
)
from gaitcore.silhouettes.keyframe import (
    cut_first,
    cut_salient,
    grown_box,
    misses_motion,
    motion_residuals,
)
from gaitcore.silhouettes.propagate import (
    TOUCHING,
    Cut,
    WorkingSize,
)
from gaitcore.silhouettes.roto.common import (
    _union,
)
from gaitcore.silhouettes.tracking import keep_overlapping

FILLED_BOX = 0.95
"""A first cut covering more of its box than this separated nothing (an animal's silhouette
leaves gaps in its box: between the legs, above the back)."""

EMPTY_BOX = 0.01
"""A first cut covering less of its box than this found nothing in it (real first cuts cover
far more; see docs/segmentation.md, Settings)."""


class _FirstCut:
    """The first frame's cut, from the box, the rectangles or the strokes on it."""

    work: WorkingSize

    def _subject_side(self, first: np.ndarray) -> float:
        """The subject's longer side in source pixels, as far as frame 0's input tells.

        Rectangles and strokes cover part of the animal: it is taken as twice their extent.
        With subject and background marks (the paper's rectangles, or else brush strokes), it
        is then the box the subject-coloured region they start spans (:meth:`_box_from_marks`)
        at that size, never less than their extent: a rectangle on a horse's neck, taken for
        twice its length, made the engine work at three times the resolution of a box around
        the whole horse, and several times slower; a stroke along it, likewise."""
        if self.box is not None:
            return float(max(self.box.w, self.box.h))
        pts = [sc.points_xy for sc in self.scribbles if sc.frame == 0 and sc.label == "subject"]
        if self.subject_rects:
            x0 = min(r.x for r in self.subject_rects)
            x1 = max(r.x + r.w for r in self.subject_rects)
            y0 = min(r.y for r in self.subject_rects)
            y1 = max(r.y + r.h for r in self.subject_rects)
            pts.append(np.array([[x0, y0], [x1, y1]], float))
        allp = np.concatenate(pts)
        extent = float(max(np.ptp(allp[:, 0]), np.ptp(allp[:, 1]), 8.0))
        work = WorkingSize.for_subject(first.shape[:2], 2.0 * extent, self.s)
        if self.subject_rects and self.background_rects:
            marks = self._rect_masks(work)
        else:
            marks = self._stroke_masks(0, work)
        found = self._box_from_marks(work.shrink(first), *marks)
        if found is None:
            return 2.0 * extent
        _, _, w, h = found[0]
        return max(extent, max(w, h) / work.scale)

    def _rect_masks(self, work: WorkingSize) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The subject and the background rectangles at ``work``'s size (None for none)."""
        fg, bg = ((work.shrink_mask(rect_mask(work.shape, rects, label)) if rects else None)
                  for rects, label in ((self.subject_rects, "subject"),
                                       (self.background_rects, "background")))
        return fg, bg

    def _first_cut(self) -> Cut:
        """Frame 0 from the box, rectangles or strokes: from the salient-object network's map
        of the box when it can (:meth:`_salient_first_cut`), else by GrabCut at
        ``first_scale`` times the working size (finer: nothing is known yet but the box)."""
        frame = check_frame(self.source[0])
        salient = self._salient_first_cut(frame)
        if salient is not None:
            return salient
        work = self.work
        self.work = WorkingSize.for_subject(work.shape, work.subject_side / self.s.first_scale,
                                            self.s)
        try:
            mask = self._first_cut_here(frame)
        finally:
            fine, self.work = self.work, work
        return Cut(work.shrink_mask(fine.enlarge(mask)).astype(np.uint8), 1.0)

    def _salient_first_cut(self, frame: np.ndarray) -> Cut | None:
        """Frame 0 cut from the network's map of the box (:func:`cut_salient`), the strokes
        on it then applied as a correction's are (:meth:`_key_cut`). None without the
        network or a box, with the paper's rectangles (their colours are the user's
        statement), when the map takes next to nothing or all of the box, or when it leaves
        out most of what moves in the box (:func:`misses_motion`); the GrabCut then decides,
        and :meth:`_check_first_cut` judges it."""
        if (self.saliency is None or self.box is None or self.subject_rects
                or self.background_rects):
            return None
        box = self.box.as_tuple()
        small = self.work.shrink_mask(cut_salient(self.saliency.in_box(frame, box)) > 0)
        x, y, w, h = self.work.box(box)
        inside = small[y : y + h, x : x + w]
        if not inside.size or not EMPTY_BOX <= float(inside.mean()) <= FILLED_BOX:
            return None
        if misses_motion(small, self._first_motion(frame, (x, y, w, h)), (x, y, w, h)):
            return None
        if any(sc.frame == 0 for sc in self.scribbles):
            return self._key_cut(0, small.astype(np.float32))
        return Cut(small.astype(np.uint8), 1.0)

    def _first_motion(self, frame: np.ndarray, box: tuple[int, int, int, int]
                      ) -> list[np.ndarray]:
        """:func:`motion_residuals` of frame 0 (``frame``) over the frames
        ``motion_offsets`` after it, at the current working size (``box`` at that size)."""
        later = [self.work.shrink(check_frame(self.source[k]))
                 for k in self.s.motion_offsets if k < self.n]
        return motion_residuals(self.work.shrink(frame), later, box)

    def _check_first_cut(self, mask: np.ndarray) -> None:
        """Refuse a first cut that fills its box (nothing in or around the box looked like
        background: a box over the whole frame, or one the animal's colours fill), or that
        is all but empty (the colours around the box explain everything in it)."""
        if self.box is None:
            return
        x, y, w, h = self.work.box(self.box.as_tuple())
        inside = mask[y : y + h, x : x + w]
        if not inside.size:
            return
        share = float(inside.mean())
        if share > FILLED_BOX:
            raise GaitInputError(
                "the cut-out on the first frame fills the whole box, so nothing told the "
                "animal from the background: draw the box closer around the animal, or paint "
                "background strokes on the first frame")
        if share < EMPTY_BOX:
            raise GaitInputError(
                "the cut-out on the first frame is empty: nothing in the box stood out from "
                "what lies around it: draw the box closer around the animal, or paint subject "
                "strokes over the animal on the first frame")

    def _first_cut_here(self, frame: np.ndarray) -> np.ndarray:
        small = self.work.shrink(frame)
        subject, background = self._stroke_masks(0)
        rects_fg, rects_bg = self._rect_masks(self.work)
        box = None if self.box is None else self.work.box(self.box.as_tuple())
        residuals: list[np.ndarray] = []
        seed = None
        if box is not None and self.s.motion_offsets:
            residuals = self._first_motion(frame, box)
        elif box is None and self.subject_rects and self.background_rects:
            found = self._box_from_marks(small, rects_fg, rects_bg)
            if found is None:
                raise GaitInputError(
                    "the subject or the background rectangles hold fewer than 16 pixels of "
                    "their own (do subject and background rectangles overlap?): draw larger, "
                    "separate rectangles")
            box, seed = found
        fg = _union(subject, rects_fg)
        bg = _union(background, rects_bg)
        if fg is not None and bg is not None:
            bg &= ~fg
        return cut_first(small, box, residuals=residuals, seed=seed, subject=fg, background=bg,
                         settings=self.s)

    @staticmethod
    def _box_from_marks(small: np.ndarray, fg: np.ndarray | None, bg: np.ndarray | None
                        ) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
        """Subject and background marks (the paper's rectangles, or brush strokes) as a box and
        a seed: the subject-coloured components (paper 2.2's mixture model, fitted to the
        marks) under the subject marks ``fg``, never under the background marks ``bg``, and
        their bounding box grown by a tenth. None when either kind of mark is missing or
        too small to fit a colour model to."""
        model = None if fg is None or bg is None else ColourModel.fit_masks(small, fg, bg)
        if model is None:
            return None
        guess = ((model.posterior(small) > 127) & ~bg) | fg
        guess = keep_overlapping(cv2.morphologyEx(guess.astype(np.uint8), cv2.MORPH_OPEN,
                                                  np.ones((3, 3), np.uint8)) | fg, fg,
                                 least=TOUCHING)
        return grown_box(guess, (0, 0, small.shape[1], small.shape[0])), guess > 0
