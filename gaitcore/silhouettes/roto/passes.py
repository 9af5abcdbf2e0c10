"""The passes that carry a key frame's mask forward and backward by the flow.

A part of :class:`~gaitcore.silhouettes.roto.RotoSegmentation` (a mixin of its methods).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator

import cv2
import numpy as np

from gaitcore.progress import report
from gaitcore.silhouettes.colour_model import (
    ColourTable,
    check_frame,
    colour_gap,
)
from gaitcore.silhouettes.exposure import ExposureTrack, exposed
from gaitcore.silhouettes.ground import (
    STILL_FRAMES,
    STILL_LEAST,
    NearbyGround,
    StillBackground,
    may_hold_still,
)
from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import (
    CorrectionTrack,
    Cut,
    disk,
    find_again,
    fuse_cut,
    key_colours,
    make_flow,
    warp_mask,
    window,
)
from gaitcore.silhouettes.roto.common import _STILL_LOOK, Framed, OnFinal, _median_under
from gaitcore.silhouettes.saliency import SaliencyTrack

_CHUNK = 64  # frames decoded at once for a backward pass

SURE_SALIENT = 0.9
"""The network's median under a key frame's background strokes above which the passes from
that key run without it (:meth:`RotoSegmentation._saliency_track`): it is sure of what the
artist called background. Under it, what the stroke lies on is a gap the network blurs (the
ground between a dog's hind legs), and the network keeps the body. Placed between the two
clips it was found on, a dog's gap and a second camel (the figures: ``docs/segmentation.md``,
Settings)."""


class _Passes:
    """The passes that carry a key frame's mask forward and backward by the flow."""

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


