"""A clip's silhouettes from one box, corrected by strokes on any frame (the Roto Brush model).

The first frame is cut from the artist's box (or the paper's rectangles); every frame that
carries strokes is a *key frame*, cut again with its strokes as hard labels. Masks travel from
each key frame forward, and backward, by optical flow and a graph cut
(:mod:`gaitcore.silhouettes.propagate`), up to and onto the next key frame. Where both
directions reach a frame their masks are blended, each weighted by its expected error there:
its distance from its key times how far it drifted by the other key (one minus the IoU of its
mask there and the key's), so a pass that swelled or shrank on the way hands the frames over
to the other, and two passes that drifted alike are weighted by nearness. A correction, or
its erasing, changes only the frames between its neighbouring key frames.

Only working-size masks are kept, bit-packed around the subject
(:class:`~gaitcore.silhouettes.packed_masks.PackedMasks`), so a 10,000-frame clip costs tens
of megabytes; frames are decoded again when a backward pass needs them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Collection, Generator, Iterable, Iterator, Sequence
from contextlib import closing
from dataclasses import dataclass

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.threads import prefetched
from gaitcore.progress import Progress, report
from gaitcore.silhouettes.annotations import Rect, Scribble, check_scribbles, check_start
from gaitcore.silhouettes.colour_model import (
    ColourModel,
    ColourTable,
    check_frame,
    colour_gap,
    rect_mask,
)
from gaitcore.silhouettes.exposure import ExposureTrack, exposed
from gaitcore.silhouettes.ground import (
    STILL_FRAMES,
    STILL_LEAST,
    NearbyGround,
    StillBackground,
    camera_held_still,
    may_hold_still,
)
from gaitcore.silhouettes.keyframe import (
    cut_first,
    cut_salient,
    cut_with_prior,
    grown_box,
    misses_motion,
    motion_residuals,
)
from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import (
    TOUCHING,
    CorrectionTrack,
    Cut,
    WorkingSize,
    disk,
    find_again,
    fuse_cut,
    key_colours,
    make_flow,
    overlap,
    warp_mask,
    window,
)
from gaitcore.silhouettes.saliency import SaliencyTrack, saliency_model
from gaitcore.silhouettes.settings import PropagationSettings
from gaitcore.silhouettes.sketch import rasterize_strokes
from gaitcore.silhouettes.tracking import keep_overlapping

OnFinal = Callable[[int, np.ndarray], None]
"""Given a frame ``(t, image)`` whose mask is final (see :meth:`RotoSegmentation.run`)."""
Framed = tuple[int, np.ndarray, np.ndarray | None]
"""A frame of a pass: ``(t, small, image)``, the source ``image`` when the pass hands it on."""

_STILL_LOOK = 6
"""The frame compared with frame 0 for a first look at whether the camera held still (the
first cut's motion reads it too: the last of ``motion_offsets``)."""

_DRIFT_FLOOR = 0.02
"""Least drift a pass is taken to have at the other key: a pass that lands on it exactly still
differs from it by a pixel along the outline."""
_CHUNK = 64  # frames decoded at once for a backward pass
FILLED_BOX = 0.95
"""A first cut covering more of its box than this separated nothing (an animal's silhouette
leaves gaps in its box: between the legs, above the back)."""
EMPTY_BOX = 0.01
"""A first cut covering less of its box than this found nothing in it (real first cuts cover
far more; see docs/segmentation.md, Settings)."""
SURE_SALIENT = 0.9
"""The network's median under a key frame's background strokes above which the passes from
that key run without it (:meth:`RotoSegmentation._saliency_track`): it is sure of what the
artist called background. Under it, what the stroke lies on is a gap the network blurs (the
ground between a dog's hind legs), and the network keeps the body. Placed between the two
clips it was found on, a dog's gap and a second camel (the figures: ``docs/segmentation.md``,
Settings)."""
DOUBTFUL_BELOW = 0.8
"""Confidence under which a frame is worth a look: the frames under it are mostly the badly
cut ones (see docs/segmentation.md, Settings)."""


@dataclass(frozen=True)
class FrameState:
    """What the segmentation says of one frame.

    Attributes
    ----------
    lost : bool
        No subject, or a mask far smaller than on the key frames.
    corrected : bool
        The frame carries the artist's strokes.
    confidence : float
        In [0, 1]: how far the mask stands out from its surroundings under its key frame's
        colours, as a share of how far the key's own mask did (1 on key frames; 0 where a
        cut was refused as a flood or a collapse, and where a lost subject was searched for
        and found again; see :func:`fuse_cut`); where both passes reach a frame, theirs
        weighted as their masks are blended. The lower, the more the frame is worth a look.
    """

    lost: bool
    corrected: bool
    confidence: float

    @property
    def to_check(self) -> bool:
        """Worth the artist's look: lost, or under :data:`DOUBTFUL_BELOW`, and not corrected."""
        return not self.corrected and (self.lost or self.confidence < DOUBTFUL_BELOW)


SUDDEN_CHANGE = 1.3
"""A silhouette this many times larger or smaller than the frame's before is worth a look (a
walking animal's changes by a tenth or so from one frame to the next)."""


def frames_to_check(states: Sequence[FrameState],
                    areas: np.ndarray | None = None) -> tuple[int, ...]:
    """The positions of the :attr:`FrameState.to_check` states (frame numbers, for a whole
    clip's states in order), and with ``areas`` (each frame's silhouette, pixels) those not
    corrected whose silhouette grew or shrank by :data:`SUDDEN_CHANGE` since the frame
    before."""
    check = {t for t, st in enumerate(states) if st.to_check}
    if areas is not None and len(areas) == len(states) > 1:
        a = np.maximum(np.asarray(areas, float), 1.0)
        jumps = np.abs(np.diff(np.log(a))) > np.log(SUDDEN_CHANGE)
        check |= {int(t) + 1 for t in np.flatnonzero(jumps) if not states[t + 1].corrected}
    return tuple(sorted(check))


class RotoSegmentation:
    """Silhouettes of a whole clip, propagated from key frames both ways.

    Parameters
    ----------
    source : FrameSource or sequence of ndarray (rows, cols, 3) uint8
        The clip. A :class:`gaitcore.footage.sources.FrameSource` is streamed.
    box : Rect, optional
        Around the subject on frame 0 (the GrabCut convention).
    subject_rects, background_rects : sequence of Rect
        The paper's rectangles on frame 0 (sure subject, sure background); with no box they
        seed a colour model (paper Section 2.2) whose guess starts the first cut.
    scribbles : sequence of Scribble
        Strokes on any frames (see :meth:`correct`).
    settings : PropagationSettings, optional

    Attributes
    ----------
    still : StillBackground or None
        After :meth:`run`, when the camera held still (:func:`camera_held_still` of
        :data:`STILL_FRAMES` frames sampled across the clip): what lies behind the animal,
        learnt from the frames the first cut's own pass leaves free; the clip is then
        carried again with it as a cue (:meth:`StillBackground.ratios`). Corrections keep it.
    turned : dict of int to ndarray (rows, cols) bool
        For each key frame whose strokes turned pixels of its mask to the subject, those
        pixels (working size): the passes from it carry them as a cue
        (:class:`~gaitcore.silhouettes.propagate.CorrectionTrack`).

    Raises
    ------
    GaitInputError
        No box and no rectangles, a box or rectangle outside the frame, a scribble outside
        the clip, an empty clip.
    """

    def __init__(self, source, *, box: Rect | None = None, subject_rects: Sequence[Rect] = (),
                 background_rects: Sequence[Rect] = (), scribbles: Sequence[Scribble] = (),
                 settings: PropagationSettings | None = None) -> None:
        self.source = source
        self.n = len(source)
        if self.n == 0:
            raise GaitInputError("the clip has no frames: choose another file or frame range")
        self.s = settings or PropagationSettings()
        first = check_frame(source[0])
        rows, cols = first.shape[:2]
        check_start(box, subject_rects, background_rects, scribbles)
        self.box = None if box is None else box.clipped_to(cols, rows)
        self.subject_rects = [r.clipped_to(cols, rows) for r in subject_rects]
        self.background_rects = [r.clipped_to(cols, rows) for r in background_rects]
        check_scribbles(scribbles, self.n, (rows, cols))
        self.scribbles: tuple[Scribble, ...] = tuple(scribbles)
        self.work = WorkingSize.for_subject((rows, cols), self._subject_side(first), self.s)
        self.fwd = PackedMasks(self.work.wh[::-1])
        self.bwd = PackedMasks(self.work.wh[::-1])
        self.keys: dict[int, Cut] = {}
        self.turned: dict[int, np.ndarray] = {}
        self.still: StillBackground | None = None
        self.saliency = saliency_model() if self.s.saliency_weight > 0 else None

    # -- public -----------------------------------------------------------------------------
    @property
    def corrected_frames(self) -> tuple[int, ...]:
        return tuple(sorted({sc.frame for sc in self.scribbles}))

    def run(self, progress: Progress | None = None, final: OnFinal | None = None) -> None:
        """Segment the whole clip from frame 0 and the strokes given so far.

        ``final`` is given every frame ``(t, image)`` in order, with its source image, once
        its mask is final (:meth:`frame`): while the clip is carried when that pass is its
        only one (no strokes, a camera that did not hold still on a first look), so that a
        caller's work on the masks overlaps it instead of following the pass; after the run
        otherwise.

        Raises
        ------
        Cancelled
            When ``progress`` returned False.
        """
        self.keys.clear()
        self.turned.clear()
        key_frames = sorted({0} | set(self.corrected_frames))
        self.keys[0] = self._first_cut()
        self._check_first_cut(self.keys[0].mask)
        may_hold_still = self._may_hold_still()
        done = [1]
        total = self.n + sum(b - a for a, b in zip(key_frames, key_frames[1:]))
        total += self.n - 1 if may_hold_still else 0  # a pass to learn what lies behind
        report(progress, 1, total, "segmentation cancelled")
        self.still = None
        streamed = final is not None and not may_hold_still and key_frames == [0]
        if may_hold_still:
            # What lies behind the animal is learnt from the first cut's own pass (strokes on
            # later frames aside, so erasing one gives what a run without it gives), from
            # frames sampled across the clip as the pass decodes them.
            picks = self._still_picks()
            kept: dict[int, np.ndarray] = {}
            self.fwd, self.bwd = PackedMasks(self.fwd.shape), PackedMasks(self.bwd.shape)
            self._carry(self.keys[0].mask, 0, _keeping(self._frames(0, self.n), set(picks), kept),
                        self.fwd, progress, done, total)
            sampled = [kept[t] for t in picks]
            if camera_held_still(sampled):
                self.still = StillBackground.learn(sampled, [self._final(t).mask for t in picks])
            elif len(key_frames) == 1:
                report(progress, total, total, "segmentation cancelled")
                self.each_frame(final)
                return  # that pass was the whole run
        self._passes(key_frames, progress, done, total, final if streamed else None)
        if not streamed:
            self.each_frame(final)

    def each_frame(self, final: OnFinal | None) -> None:
        """Every frame ``(t, image)`` with its source image to ``final`` (when there is one),
        in order, decoded on a thread ahead (:meth:`images`)."""
        if final is not None:
            with closing(self.images()) as images:
                for t, image in images:
                    final(t, image)

    def _passes(self, key_frames: list[int], progress, done: list[int], total: int,
                final: OnFinal | None = None) -> None:
        """Carry the masks across the whole clip from its key frames, both ways (frame 0
        already cut; corrected frames cut again from the forward pass's mask); ``final`` is
        given each frame as the forward passes carry it (final only when frame 0 is the one
        key frame)."""
        self.fwd, self.bwd = PackedMasks(self.fwd.shape), PackedMasks(self.bwd.shape)
        for a, b in zip(key_frames, key_frames[1:] + [self.n]):
            self._forward(a, min(b + 1, self.n), progress, done, total, final)
            if b < self.n:
                self.keys[b] = self._key_cut(b, self._blend(b, a, b, key_frames_only=True).mask)
                self._backward(b, a, progress, done, total)

    def correct(self, scribbles: Sequence[Scribble], progress: Progress | None = None
                ) -> tuple[int, int]:
        """Add strokes (on one or more frames) and re-propagate only where they matter.

        Each stroked frame is cut again with all its strokes as hard labels, starting from its
        current mask; the change travels forward and backward up to the neighbouring key
        frames. Background strokes alone on a frame only take subject away from the frames
        they reach and add none (a blob of ground does not come in where the rider goes out).

        Returns
        -------
        (first, stop) : the range of frames that changed.
        """
        check_scribbles(scribbles, self.n, self.work.shape)
        self.scribbles = self.scribbles + tuple(scribbles)
        lo, hi = self.n, 0
        for k in sorted({sc.frame for sc in scribbles}):
            labels = {sc.label for sc in scribbles if sc.frame == k}
            reach = self._reach(k)
            before = ({t: self._final(t).mask for t in reach} if labels == {"background"}
                      else {})
            self.keys[k] = self._key_cut(k, self._final(k).mask.astype(np.float32))
            first, stop = self._repropagate(k, progress)
            if before:
                self._taken_only(before)
            lo, hi = min(lo, first), max(hi, stop)
        return lo, hi

    def _reach(self, k: int) -> range:
        """The frames a correction of frame ``k`` re-propagates to, before it is a key frame:
        between the key frames around it (the key frames themselves left out, ``k`` in)."""
        prev = max([f for f in self.keys if f < k], default=-1)
        nxt = min([f for f in self.keys if f > k], default=self.n)
        return range(prev + 1, nxt)

    def _taken_only(self, before: dict[int, np.ndarray]) -> None:
        """Each frame of ``before`` (its mask before a background correction) only loses
        subject: its key cut or both passes' cuts bounded by it."""
        for t, mask in before.items():
            if t in self.keys:
                self.keys[t] = _within(self.keys[t], mask)
            for store in (self.fwd, self.bwd):
                cut = store.get(t)
                if cut is not None:
                    store.put(t, _within(cut, mask))

    def erase(self, indices: Collection[int], progress: Progress | None = None
              ) -> tuple[int, int]:
        """Drop the strokes at positions ``indices`` of :attr:`scribbles` and re-propagate
        only where it matters: a frame that keeps strokes is cut again from the forward
        pass's mask, as :meth:`run` cuts it (frame 0 from its box or rectangles); one left
        without strokes stops being a key frame, and its neighbouring keys' passes run across
        it.

        Returns
        -------
        (first, stop) : the range of frames that changed.

        Raises
        ------
        GaitInputError
            Frame 0 left with nothing to be cut from (no box, rectangles or subject stroke),
            or cut again to fill its box.
        Cancelled
            When ``progress`` returned False.
        """
        gone = set(indices)
        kept = tuple(sc for i, sc in enumerate(self.scribbles) if i not in gone)
        check_start(self.box, self.subject_rects, self.background_rects, kept)
        frames, self.scribbles = sorted({self.scribbles[i].frame for i in gone}), kept
        lo, hi = self.n, 0
        for k in frames:
            self.turned.pop(k, None)
            if k == 0:
                self.keys[0] = self._first_cut()
                self._check_first_cut(self.keys[0].mask)
            elif k in self.corrected_frames:
                prev = self._neighbours(k - 1)[0]
                self.keys[k] = self._key_cut(k, self._blend(k, prev, k, key_frames_only=True).mask)
            else:
                del self.keys[k]
            first, stop = self._repropagate(k, progress)
            lo, hi = min(lo, first), max(hi, stop)
        return lo, hi

    def mask(self, t: int) -> np.ndarray:
        """Frame ``t``'s silhouette at the source size, (rows, cols) bool, its outline on the
        frame's edges (:meth:`~gaitcore.silhouettes.propagate.WorkingSize.enlarge`); all
        False where the subject is lost, as the command writes it."""
        return self.frame(t)[0]

    def state(self, t: int) -> FrameState:
        """Lost, corrected and confidence of frame ``t``."""
        return self._state(t, self._final(t))

    def frame(self, t: int, image: np.ndarray | None = None) -> tuple[np.ndarray, FrameState]:
        """:meth:`mask` and :meth:`state` of frame ``t``, its two passes blended once;
        ``image`` is the source frame when the caller holds it (else it is read). A lost
        frame's leftover is not outlined: its mask is empty."""
        cut = self._final(t)
        state = self._state(t, cut)
        if state.lost or not cut.mask.any():
            return np.zeros(self.work.shape, bool), state
        image = check_frame(self.source[t] if image is None else image)
        return self.work.enlarge(cut.mask, image), state

    def _state(self, t: int, cut: Cut) -> FrameState:
        keys = (t,) if t in self.keys else self._neighbours(t)
        area = min(self._key_area(k) for k in keys if k in self.keys)
        return FrameState(self._lost(cut.area, area), t in set(self.corrected_frames),
                          round(cut.confidence, 3))

    def _key_area(self, k: int) -> float:
        """Key frame ``k``'s area, or where its cut does not hold the subject (:meth:`_holds`)
        the nearest key's that does: the size the subject is searched for at from there."""
        held = self._holding(k)
        return 1.0 if held is None else float(self.keys[held].area)

    def _holding(self, k: int) -> int | None:
        """Key frame ``k`` when its cut holds the subject (:meth:`_holds`), else the nearest
        key that does (None: none)."""
        return k if self._holds(k) else self._nearest_held(k)

    def _holds(self, k: int) -> bool:
        """Whether key frame ``k``'s cut holds the subject: not empty (background strokes
        alone where it was lost), nor a speck under ``lost_frac`` squared of frame 0's area
        (a subject stroke painted where there is no subject)."""
        area = self.keys[k].area
        return area > 0 and area >= self.s.lost_frac ** 2 * self.keys[0].area

    def _nearest_held(self, t: int) -> int | None:
        """The key frame other than ``t`` nearest it whose cut holds the subject (None:
        none)."""
        held = [k for k in self.keys if k != t and self._holds(k)]
        return min(held, key=lambda k: abs(k - t), default=None)

    def _lost(self, pixels: int, area: float) -> bool:
        """Whether a mask of ``pixels`` pixels holds under ``lost_frac`` of ``area``: the area
        of the key frame a pass carried it from, or for a frame's state the smaller of its
        neighbouring keys' (its own, on a key frame). Measured against frame 0's area
        instead, a subject that was far smaller on a later frame (a rider riding away) was
        lost there even on a frame the artist had painted it on, and the frame stayed
        empty."""
        return pixels < self.s.lost_frac * area

    # -- key frames -------------------------------------------------------------------------
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

    def _stroke_masks(self, t: int, work: WorkingSize | None = None
                      ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Frame ``t``'s subject and background strokes at ``work``'s size (the engine's by
        default; None for none)."""
        work = work or self.work
        out = []
        for label in ("subject", "background"):
            mine = [sc for sc in self.scribbles if sc.frame == t and sc.label == label]
            out.append(work.shrink_mask(rasterize_strokes(mine, work.shape) > 0)
                       if mine else None)
        return out[0], out[1]

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

    def _key_cut(self, t: int, prior: np.ndarray) -> Cut:
        """Cut corrected frame ``t`` from ``prior`` (:meth:`_key_mask`), and keep what it
        turned to the subject (:attr:`turned`) for its passes to carry
        (:class:`~gaitcore.silhouettes.propagate.CorrectionTrack`): with what earlier strokes
        there turned, while it stays subject (``prior`` is then the frame's key mask)."""
        mask = self._key_mask(t, prior) > 0
        turned = mask & ((prior <= 0.5) | self.turned.pop(t, False))
        if turned.any():
            self.turned[t] = turned
        return Cut(mask.astype(np.uint8), 1.0)

    def _key_mask(self, t: int, prior: np.ndarray) -> np.ndarray:
        """Cut a corrected frame: its strokes are sure labels, and the prior around them takes
        their side (a stroke painted over a wrong region turns the region, not a line); the
        cut is kept within ``stroke_zone_frac`` of the subject's side around them, the prior
        elsewhere.

        On a frame where the subject was lost (an empty prior), a subject stroke says where
        it is: the frame is cut as a first frame is (:func:`cut_first`), from a box of the
        nearest key's size around the strokes (:meth:`_box_around`). Cut from the strokes'
        band alone, it took little more than the band."""
        small = self.work.shrink(check_frame(self.source[t]))
        subject, background = self._stroke_masks(t)
        prior = prior.astype(np.float32)
        before = (prior > 0.5).astype(np.uint8)
        if subject is not None and not before.any():
            return cut_first(small, self._box_around(t, subject), subject=subject,
                             background=background, settings=self.s)
        bands = self._stroke_bands(t)
        for label, band in bands.items():
            prior[band] = 1.0 if label == "subject" else 0.0
        cut = cut_with_prior(small, prior, subject=subject, background=background,
                             iters=self.s.first_iters, settings=self.s)
        if not bands or not before.any():
            return cut.mask
        strokes = {"subject": subject, "background": background}
        return self._own_way(small, before, cut.mask > 0, bands, strokes)

    def _stroke_bands(self, t: int) -> dict[str, np.ndarray]:
        """Around frame ``t``'s strokes of each label, the band ``stroke_reach`` times their
        width that takes their side in the corrected frame's prior (working size, bool)."""
        bands = {}
        for label in ("subject", "background"):
            wide = [Scribble(sc.points_xy, sc.width_px * self.s.stroke_reach, t, label)
                    for sc in self.scribbles if sc.frame == t and sc.label == label]
            if wide:
                bands[label] = self.work.shrink_mask(rasterize_strokes(wide, self.work.shape) > 0)
        return bands

    def _own_way(self, small: np.ndarray, before: np.ndarray, cut: np.ndarray,
                 bands: dict[str, np.ndarray], strokes: dict[str, np.ndarray | None]
                 ) -> np.ndarray:
        """A corrected frame's mask: ``before`` changed by the ``cut`` within
        ``stroke_zone_frac`` of the subject's side around each stroke's band (``bands``);
        beside the band, a pixel turns to the stroke's side only where the network sees what
        it sees under the stroke (``strokes``: salient, or not), and to the other side only
        where it does not. Without the network, the cut is taken within the zone. Of what the
        cut would change there, only the parts the band reaches change: a stroke turns the
        wrong region it is painted on, as far as that region goes within the zone, and
        nothing beside it.

        The graph cut of a corrected frame learns its colours from that whole frame, and
        near a stroke it may take what the stroke did not ask for: a background stroke on
        the ground between a cow's front legs turned that ground and, beside it, a front leg
        of the soil's shade."""
        _, _, w, h = cv2.boundingRect(before)
        reach = disk(round(self.s.stroke_zone_frac * max(w, h)))
        # Not run when no stroke lies in the network's window: it would judge nothing.
        salient = self._network_map(small, before,
                                    _union(strokes.get("subject"), strokes.get("background")))
        out = before > 0
        for label, band in bands.items():
            zone = cv2.dilate(band.astype(np.uint8), reach) > 0
            toward = against = zone
            seen = _median_under(salient, strokes[label])
            if salient is not None and seen is not None:
                alike = np.isnan(salient) | ((salient > 0.5) == (seen > 0.5))
                toward = zone & (band | alike)
                against = zone & ~band & ~alike
            if label == "subject":
                turned = (out | (toward & cut)) & ~(against & ~cut)
            else:
                turned = (out & ~(toward & ~cut)) | (against & cut)
            out = np.where(_touching(turned != out, band), turned, out)
        return out.astype(np.uint8)

    def _network_map(self, small: np.ndarray, mask: np.ndarray,
                     under: np.ndarray | None = None) -> np.ndarray | None:
        """The network's map of the window around ``mask`` on the working-size frame
        ``small``, NaN outside the window; None without the network or a mask, or when
        ``under`` (pixels the map is wanted at) has none in the window: not run for them."""
        if self.saliency is None or not mask.any():
            return None
        x0, y0, x1, y1 = window(mask, self.s)
        if under is not None and not under[y0:y1, x0:x1].any():
            return None
        out = np.full(mask.shape, np.nan, np.float32)
        out[y0:y1, x0:x1] = self.saliency(small[y0:y1, x0:x1])
        return out

    def _box_around(self, t: int, subject: np.ndarray) -> tuple[int, int, int, int]:
        """A box (working size) around the subject strokes ``subject`` of frame ``t``, as wide
        and tall as the mask of the key frame nearest ``t`` that holds one grown by a fifth
        (the strokes' extent at least), clipped to the frame."""
        nearest = self._nearest_held(t)
        x, y, w, h = cv2.boundingRect(subject.astype(np.uint8))
        cx, cy = x + w / 2, y + h / 2
        if nearest is not None:
            _, _, kw, kh = cv2.boundingRect(self.keys[nearest].mask)
            w, h = max(w, kw), max(h, kh)
        rows, cols = subject.shape
        x0, y0 = max(0, round(cx - 0.6 * w)), max(0, round(cy - 0.6 * h))
        x1, y1 = min(cols, round(cx + 0.6 * w)), min(rows, round(cy + 0.6 * h))
        return x0, y0, x1 - x0, y1 - y0

    # -- propagation ------------------------------------------------------------------------
    def _repropagate(self, k: int, progress) -> tuple[int, int]:
        """Carry the masks again across the key frames around frame ``k``, which is a key
        frame just cut or one that just stopped being one: forward from it (or the key before
        it) onto the next key, backward from it (or the next key) onto the key before it.
        Returns the frames changed, ``(first, stop)``."""
        keys = sorted(self.keys)
        prev = max([f for f in keys if f < k], default=None)
        nxt = min([f for f in keys if f > k], default=self.n)
        start, back = (k, k) if k in self.keys else (prev, nxt)
        stop = min(nxt + 1, self.n)  # onto the next key: how far the pass drifted
        backward = prev is not None and back < self.n
        done, total = [0], stop - 1 - start + (back - prev if backward else 0)
        self._forward(start, stop, progress, done, total)
        if backward:
            self._backward(back, prev, progress, done, total)
        return (k if prev is None else prev + 1), nxt

    def images(self, start: int = 0, stop: int | None = None
               ) -> Generator[tuple[int, np.ndarray], None, None]:
        """Source frames ``(t, image)``, ``start <= t < stop`` (to the end: None) in order,
        decoded on a thread of their own a few frames ahead: for :meth:`frame`."""
        return prefetched(self._decoded(start, self.n if stop is None else stop), 4)

    def _frames(self, start: int, stop: int, *, full: bool = False, last_first: bool = False
                ) -> Generator[Framed, None, None]:
        """Working-size frames ``(t, small, image)``, ``start <= t < stop`` in order (from
        ``stop - 1`` down when ``last_first``: each read on its own, which only image files
        and frames in memory do cheaply), decoded and shrunk on a thread of their own a few
        frames ahead (OpenCV lets go of the GIL in both); ``image`` is the source frame when
        ``full``, else None."""
        return prefetched(self._shrunk(self._decoded(start, stop, last_first), full), 4)

    def _decoded(self, start: int, stop: int, last_first: bool = False
                 ) -> Generator[tuple[int, np.ndarray], None, None]:
        if last_first:
            return ((t, self.source[t]) for t in range(stop - 1, start - 1, -1))
        if hasattr(self.source, "iter_frames"):
            return self.source.iter_frames(start, stop)
        return ((t, self.source[t]) for t in range(start, stop))

    def _shrunk(self, stream: Iterator[tuple[int, np.ndarray]], full: bool
                ) -> Iterator[Framed]:
        try:
            for t, img in stream:
                img = check_frame(img)
                if img.shape[:2] != self.work.shape:
                    raise GaitInputError(f"frame {t} is {img.shape[:2]} but frame 0 is "
                                         f"{self.work.shape}: all frames must have the same size")
                yield t, self.work.shrink(img), img if full else None
        finally:
            stream.close()

    def _forward(self, key: int, stop: int, progress, done, total,
                 final: OnFinal | None = None) -> None:
        self._carry(self.keys[key].mask, key, self._frames(key, stop, full=final is not None),
                    self.fwd, progress, done, total, final)

    def _backward(self, key: int, stop: int, progress, done, total) -> None:
        """From key frame ``key`` down to key frame ``stop`` (included: where the pass meets
        that key tells how far it drifted). A video is decoded forward in chunks, each
        carried last frame first (its decoder seeks only to the video's own key frames);
        image files and frames in memory are read last frame first, so that the pass starts
        after one frame's decoding instead of a chunk's (the 50 frames of 960x540 PNG a
        correction carries backward)."""
        def reversed_frames() -> Iterator[Framed]:
            hi = key + 1
            while hi > stop:
                lo = max(stop, hi - _CHUNK)
                chunk = list(self._frames(lo, hi))
                yield from reversed(chunk)
                hi = lo

        frames = (reversed_frames() if getattr(self.source, "is_video", False)
                  else self._frames(stop, key + 1, last_first=True))
        self._carry(self.keys[key].mask, key, frames, self.bwd, progress, done, total)

    def _carry(self, mask: np.ndarray, key: int, frames: Iterable[Framed], store: PackedMasks,
               progress, done, total, final: OnFinal | None = None) -> None:
        flow_of = make_flow(self.s)
        nearby = (NearbyGround(self.s, mask) if self.still is None and self.s.nearby_weight > 0
                  else None)
        prev = grey_prev = models = exposure = salient = None
        corrected = (CorrectionTrack(self.turned[key], self.s)
                     if key in self.turned and self.s.correction_weight > 0 else None)
        gap, found = 0.0, False
        area = self._key_area(key)
        for t, small, grey, image in _ahead(frames, nearby):
            if t == key:
                models = self._key_colours(key, small, mask)
                gap = 0.0 if models is None else models.gap
                exposure = ExposureTrack(grey, mask, window(mask, self.s), self.s, small)
                salient = self._saliency_track(key, small, mask)
            else:
                if models is not None and self._lost(cv2.countNonZero(mask), area):
                    cut = Cut(find_again(small, models, area, self.s), 0.0)
                    found = bool(cut.mask.any())
                else:
                    cut, shown = self._step(mask, (prev, small), (grey_prev, grey), flow_of,
                                            models, exposure, nearby, salient, corrected,
                                            gap=gap, anchor=found)
                    gap = min(gap, shown) if shown > 0 else gap
                    found = False
                store.put(t, cut)
                mask = cut.mask
                done[0] += 1
                report(progress, done[0], max(total, done[0]), "segmentation cancelled")
            if final is not None:
                final(t, image)
            if nearby is not None:
                nearby.settle(mask)
            prev, grey_prev = small, grey

    def _saliency_track(self, key: int, small: np.ndarray, mask: np.ndarray
                        ) -> SaliencyTrack | None:
        """The network's cue for a pass from key frame ``key`` (``small``, cut ``mask``);
        None without the network, or when the artist's background strokes there lie on what
        the network is sure is salient (``SURE_SALIENT``): it took the same wrong thing, and
        would carry it back into the frames the stroke was meant to mend. On a clip of two
        camels the mask drifts onto the second and the fence between them, which the network
        calls salient in the window around both; a background stroke on the fence then
        lowered the clip until the passes from such keys ran without the network (see
        docs/segmentation.md, ``SURE_SALIENT``)."""
        if self.saliency is None:
            return None
        background = self._stroke_masks(key)[1]
        if background is not None and background.any():
            seen = _median_under(self._network_map(small, mask, background), background)
            if seen is not None and seen > SURE_SALIENT:
                return None
        return SaliencyTrack(self.saliency, self.s.saliency_every)

    def _key_colours(self, key: int, small: np.ndarray, mask: np.ndarray
                     ) -> ColourTable | None:
        """The colours a pass from key frame ``key`` judges its frames by: its own, or where
        its cut does not hold the subject (:meth:`_holds`) the nearest key's that does, so
        that the pass searches for the subject (:func:`find_again`) instead of losing every
        frame up to the next key."""
        held = self._holding(key)
        if held is None:
            return None
        if held != key:
            small, mask = self.work.shrink(check_frame(self.source[held])), self.keys[held].mask
        return key_colours(small, mask, self.s, self._stroke_masks(held)[1])

    def _step(self, mask, colours, greys, flow_of, models, exposure: ExposureTrack | None,
              nearby: NearbyGround | None = None, salient: SaliencyTrack | None = None,
              corrected: CorrectionTrack | None = None, *, gap: float = 0.0,
              anchor: bool = False) -> tuple[Cut, float]:
        """One propagated frame (``colours`` and ``greys``: the previous frame and this one),
        brought back to its key frame's exposure and colour balance (``exposure`` follows
        them) before the key's colours judge it: a camera's auto-exposure and white balance,
        or Muybridge's plates, each printed lighter or darker. What lies behind the animal
        is the clip's still background when there is one, else the pass's ``nearby`` ground;
        what stands out in the window, the ``salient`` track's; what a correction on the
        key turned to the subject, the ``corrected`` track's.

        The mask is lost when it stands out from its surroundings less than ``lost_gap`` of
        ``gap`` (see :func:`fuse_cut`). On the frame after the subject was searched for and
        found again (``anchor``, by :meth:`_carry`) it is not tested, and the gap it shows is
        returned beside the cut (0 otherwise): the pass measures slides from it from then on.
        The key's own gap is no yardstick there: the search found the subject by those very
        colours, and a better first frame's taller gap had every other frame lost and found
        again (see docs/segmentation.md, ``lost_gap``)."""
        small = colours[1]
        if models is None or exposure is None:
            return Cut(mask, 0.0), 0.0
        warp = warp_mask(mask, greys[0], greys[1], flow_of, self.s, colours=colours)
        gains = exposure.step(warp)
        x0, y0, x1, y1 = warp.window
        behind: StillBackground | NearbyGround | None
        behind, weight = ((self.still, self.s.still_weight) if self.still is not None
                          else (nearby, self.s.nearby_weight))
        ground = None if behind is None else behind.ratios(small[y0:y1, x0:x1], warp.prob,
                                                           warp.window)
        here = exposed(small[y0:y1, x0:x1], gains)
        cue = (None if salient is None
               else salient.step(here, warp.window, mask.shape, warp.carried))
        cut = fuse_cut(here, warp.prob, warp.trust, models, self.s, warp.motion, ground, weight,
                       salient=cue, corrected=None if corrected is None else corrected.step(warp),
                       gap=0.0 if anchor else gap)
        out = np.zeros_like(mask)
        out[y0:y1, x0:x1] = cut.mask
        shown = colour_gap(models(here), cut.mask > 0) if anchor and cut.mask.any() else 0.0
        return Cut(out, cut.confidence), shown

    def _may_hold_still(self) -> bool:
        """Frame 0 and frame :data:`_STILL_LOOK` (decoded for the first cut's motion) agree
        off the first cut as a still camera's do (:func:`may_hold_still`)."""
        if self.s.still_weight <= 0 or self.n < STILL_LEAST:
            return False
        first, then = (self.work.shrink(check_frame(self.source[t])) for t in (0, _STILL_LOOK))
        mask = self.keys[0].mask
        _, _, w, h = cv2.boundingRect(mask)
        off = cv2.dilate(mask, disk(max(1, round(0.1 * max(w, h))))) == 0
        return may_hold_still(first, then, off)

    def _still_picks(self) -> list[int]:
        return [int(t) for t in
                np.unique(np.linspace(0, self.n - 1, min(self.n, STILL_FRAMES)).round())]

    # -- blending ---------------------------------------------------------------------------
    def _neighbours(self, t: int) -> tuple[int, int]:
        keys = sorted(self.keys)
        a = max([k for k in keys if k <= t], default=0)
        b = min([k for k in keys if k > t], default=self.n)
        return a, b

    def _final(self, t: int) -> Cut:
        if t in self.keys:
            return self.keys[t]
        a, b = self._neighbours(t)
        return self._blend(t, a, b)

    def _weight(self, t: int, a: int, b: int, f: np.ndarray, g: np.ndarray) -> float:
        """The forward pass's share of frame ``t`` (``a < t < b``), in (0, 1), its mask ``f``
        and the backward pass's ``g``.

        Each pass's error is taken to grow in proportion to its distance from its key, at the
        rate measured where it reaches the other key: one minus the IoU of its mask there and
        that key's (at least ``_DRIFT_FLOOR``); there, furthest from its key, it is at its
        greatest. The share is the other pass's error over the sum, nearness alone when both
        drifted alike.

        One minus the IoU is a distance, so the two masks differ by at most the sum of their
        errors. Where they differ by more than the two errors so estimated add to, both are
        scaled up to it; a pass whose error would then pass its greatest hands the excess to
        the other. A pass that fails at once, rather than drifting, is so found out: a pass
        back from a stroke on a clip's last frame lost the dog within three frames, yet it
        came nearer there than the pass from frame 0 had drifted, and took most of those
        frames until this rule.
        """
        ef_end, eg_end = self._drift(self.fwd, b), self._drift(self.bwd, a)
        ef, eg = ef_end * (t - a) / (b - a), eg_end * (b - t) / (b - a)
        apart = 1.0 - overlap(f > 0, g > 0)
        if apart > ef + eg:
            ef, eg = ef * apart / (ef + eg), eg * apart / (ef + eg)
            if ef > ef_end and eg < eg_end:
                ef, eg = ef_end, min(eg_end, eg + ef - ef_end)
            elif eg > eg_end and ef < ef_end:
                ef, eg = min(ef_end, ef + eg - eg_end), eg_end
        return eg / (eg + ef)

    def _drift(self, store: PackedMasks, key: int) -> float:
        """One minus the IoU of a pass's mask on key frame ``key`` and the key's own."""
        end, mine = store.get(key), self.keys[key].mask > 0
        if end is None:
            return 1.0
        return max(_DRIFT_FLOOR, 1.0 - overlap(mine, end.mask > 0))

    def _blend(self, t: int, a: int, b: int, *, key_frames_only: bool = False) -> Cut:
        """Forward cut from key ``a`` and backward cut from key ``b`` at frame ``t``, masks
        and confidences mixed by :meth:`_weight` (masks as a probability in [0, 1]
        thresholded at one half).

        Where one pass lost the subject and the other did not, the other is taken whole: a
        pass that lost it does not know where it is, and mixed in it erased the other's mask
        wherever its share passed one half: a subject stroke where the pass from frame 0 had
        lost a dancer emptied earlier frames that pass held, because the pass back from the
        stroke lost her there. A pass from a key frame whose
        cut does not hold the subject (:meth:`_holds`) counts as lost: it only searched for
        the subject, and measured against that key the other pass looked all drift.

        The share :meth:`_weight` gives each pass is then weighed by the pass's confidence
        there (how far its mask stands out from its surroundings under its key's colours), as
        two independent judges' odds multiply: where the drifts cannot tell the passes apart,
        the mask that stands out takes the frame. The drifts are measured against the key
        frames, and a key made by a stroke is the frame's mask before it with the stroke's
        region turned, wrong elsewhere as it was: a subject stroke on a frame where the mask
        had lost a bus took part of it, the pass from frame 0, right on the frames before,
        looked as drifted against that partial key as the pass back from it, and small blobs
        of the latter, of low confidence, took those frames.
        """
        f = self.fwd.get(t)
        g = None if key_frames_only or b >= self.n else self.bwd.get(t)
        if f is None or g is None:
            return f or g or Cut(np.zeros(self.fwd.shape, np.uint8), 0.0)
        f_lost = not self._holds(a) or self._lost(f.area, self.keys[a].area)
        g_lost = not self._holds(b) or self._lost(g.area, self.keys[b].area)
        if f_lost != g_lost:
            return g if f_lost else f
        w = self._weight(t, a, b, f.mask, g.mask)
        forward, backward = w * f.confidence, (1 - w) * g.confidence
        if forward + backward > 0:
            w = forward / (forward + backward)
        soft = (w * cv2.GaussianBlur(f.mask.astype(np.float32), (0, 0), 1.5)
                + (1 - w) * cv2.GaussianBlur(g.mask.astype(np.float32), (0, 0), 1.5))
        return Cut((soft > 0.5).astype(np.uint8), w * f.confidence + (1 - w) * g.confidence)


def _ahead(frames: Iterable[Framed], nearby: NearbyGround | None
           ) -> Iterator[tuple[int, np.ndarray, np.ndarray, np.ndarray | None]]:
    """A pass's frames ``(t, small, grey, image)`` with their grey, each given to ``nearby``
    (when there is one) ``nearby_reach`` frames before it is decided."""
    reach = 0 if nearby is None else nearby.reach
    queue: deque[tuple[int, np.ndarray, np.ndarray, np.ndarray | None]] = deque()
    for t, small, image in frames:
        grey = cv2.cvtColor(small, cv2.COLOR_BGR2GRAY)
        if nearby is not None:
            nearby.add(small, grey)
        queue.append((t, small, grey, image))
        if len(queue) > reach:
            yield queue.popleft()
    yield from queue


def _keeping(stream: Generator[Framed, None, None], picks: Collection[int],
             kept: dict[int, np.ndarray]) -> Iterator[Framed]:
    """``stream`` as it is, its working-size frames numbered in ``picks`` kept into ``kept``
    on the way (``stream`` closed when this is, its decoding thread stopped)."""
    try:
        for t, small, image in stream:
            if t in picks:
                kept[t] = small
            yield t, small, image
    finally:
        stream.close()


def _median_under(values: np.ndarray | None, under: np.ndarray | None) -> float | None:
    """The median of ``values`` (NaN where unknown) under the pixels ``under``; None where
    none of them is known."""
    if values is None or under is None:
        return None
    known = values[under]
    known = known[~np.isnan(known)]
    return float(np.median(known)) if known.size else None


def _touching(changed: np.ndarray, band: np.ndarray) -> np.ndarray:
    """The pixels of ``changed`` (bool) in the 8-connected parts of it that ``band`` (bool)
    reaches."""
    _, parts = cv2.connectedComponents(changed.view(np.uint8), connectivity=8)
    reached = np.unique(parts[band & changed])
    return np.isin(parts, reached[reached > 0])


def _within(cut: Cut, mask: np.ndarray) -> Cut:
    """``cut`` with what lies outside ``mask`` taken away (the cut itself when nothing is)."""
    bounded = cut.mask & mask
    return cut if np.array_equal(bounded, cut.mask) else Cut(bounded.astype(np.uint8),
                                                             cut.confidence)


def _union(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
    if a is None:
        return b
    return a if b is None else a | b
