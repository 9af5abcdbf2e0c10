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

from collections.abc import Generator, Iterator, Sequence
from contextlib import closing
from dataclasses import dataclass

import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.footage.threads import prefetched
from gaitcore.progress import Progress, report
from gaitcore.silhouettes.annotations import Rect, Scribble, check_scribbles, check_start
from gaitcore.silhouettes.colour_model import (
    check_frame,
)
from gaitcore.silhouettes.ground import (
    StillBackground,
    camera_held_still,
)
from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import (
    Cut,
    WorkingSize,
)
from gaitcore.silhouettes.roto.blend import _Blending
from gaitcore.silhouettes.roto.common import Framed, OnFinal, _keeping
from gaitcore.silhouettes.roto.corrections import _Corrections
from gaitcore.silhouettes.roto.first import _FirstCut
from gaitcore.silhouettes.roto.passes import _Passes
from gaitcore.silhouettes.saliency import saliency_model
from gaitcore.silhouettes.settings import PropagationSettings

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


class RotoSegmentation(_FirstCut, _Passes, _Blending, _Corrections):
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


    # -- propagation ------------------------------------------------------------------------

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


    # -- blending ---------------------------------------------------------------------------


