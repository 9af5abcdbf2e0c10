"""Corrections: a key frame's strokes cut it again, and the passes around it run again.

A part of :class:`~gaitcore.silhouettes.roto.RotoSegmentation` (a mixin of its methods).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

import cv2
import numpy as np

from gaitcore.progress import Progress
from gaitcore.silhouettes.annotations import Scribble, check_scribbles, check_start
from gaitcore.silhouettes.colour_model import (
    check_frame,
)
from gaitcore.silhouettes.keyframe import (
    cut_first,
    cut_with_prior,
)
from gaitcore.silhouettes.propagate import (
    Cut,
    WorkingSize,
    disk,
    window,
)
from gaitcore.silhouettes.roto.common import _median_under, _union
from gaitcore.silhouettes.sketch import rasterize_strokes


class _Corrections:
    """Corrections: a key frame's strokes cut it again, and the passes around it run again."""

    scribbles: tuple[Scribble, ...]

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


