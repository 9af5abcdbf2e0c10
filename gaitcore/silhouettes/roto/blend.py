"""Where two passes reach a frame, their masks blended by their expected errors.

A part of :class:`~gaitcore.silhouettes.roto.RotoSegmentation` (a mixin of its methods).
"""

from __future__ import annotations

import cv2
import numpy as np

from gaitcore.silhouettes.packed_masks import PackedMasks
from gaitcore.silhouettes.propagate import (
    Cut,
    overlap,
)

_DRIFT_FLOOR = 0.02
"""Least drift a pass is taken to have at the other key: a pass that lands on it exactly still
differs from it by a pixel along the outline."""


class _Blending:
    """Where two passes reach a frame, their masks blended by their expected errors."""

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
