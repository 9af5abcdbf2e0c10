"""What lies behind the animal, as cues for deciding a propagated frame (beyond the paper's
Section 2.2; see :func:`gaitcore.silhouettes.propagate.fuse_cut`).

Colour and motion take for the animal whatever shares its colours and moves with it: a shadow,
the ground it uncovers. What the ground looks like where the animal stands tells them apart:

- When the camera held still (a tripod shot, :func:`camera_held_still`), the clip's own
  background (:class:`StillBackground`, learnt from frames sampled across it, off the
  animal's masks): a planted foot, or a leg of the ground's own colours, looks unlike it.
- When it did not (a camera panning after the animal), the frames either side brought to this
  one by the camera's motion (:class:`NearbyGround`, :func:`camera_motion`): the ground a
  running animal uncovers behind it.

Both give per-pixel log-likelihood ratios learnt on the frame itself from the warped mask's sure
sides (:func:`~gaitcore.silhouettes.motion.learnt_ratios`), as the motion cue's are.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from gaitcore.silhouettes.motion import learnt_ratios
from gaitcore.silhouettes.propagate import disk
from gaitcore.silhouettes.settings import PropagationSettings

STILL_FRAMES = 15
"""Frames sampled evenly across a clip to tell whether its camera held still, and to learn the
background behind the animal."""

STILL_LEAST = 8
"""Fewest frames a clip's still background is looked for in."""

_STILL_LEVELS = 12
_STILL_SHARE = 0.8
"""A camera held still when, on most sampled frames, at least this share of the pixels are
within ``_STILL_LEVELS`` (each of B, G and R) of the samples' median. Panning footage shares
far less, and so does a loop that keeps a running horse in place (see docs/segmentation.md,
Settings)."""

_STILL_BINS = 17
"""Bins of :meth:`StillBackground.ratios`: half octaves of the difference from the still
background, from 0 to 255 levels."""


def camera_held_still(frames: Sequence[np.ndarray]) -> bool:
    """Whether frames sampled across a clip (:data:`STILL_FRAMES`, at least
    :data:`STILL_LEAST`) show a camera that held still (see :data:`_STILL_SHARE`)."""
    if len(frames) < STILL_LEAST:
        return False
    stack = np.stack(frames)
    shares = _agreeing(stack, np.median(stack, axis=0).astype(np.uint8))
    return bool(np.median(shares) >= _STILL_SHARE)


def may_hold_still(first: np.ndarray, later: np.ndarray, off: np.ndarray) -> bool:
    """A first look, from two frames a few apart that are decoded anyway: whether they agree
    off the subject (``off``, bool) as a still camera's frames do (:data:`_STILL_SHARE`).
    Only then are frames sampled across the clip (:func:`camera_held_still`), as a pass
    decodes them: seeking them first cost a noticeable share of a long clip's time."""
    # Two frames' noise, where the median has little: the levels grow by the square root of 2.
    return bool(_agreeing(later[None], first, off, levels=_STILL_LEVELS * np.sqrt(2))[0]
                >= _STILL_SHARE)


def _agreeing(frames: np.ndarray, reference: np.ndarray, where: np.ndarray | None = None, *,
              levels: float = _STILL_LEVELS) -> np.ndarray:
    """For each of ``frames`` (n, rows, cols, 3), the share of its pixels (of ``where``, when
    given) within ``levels`` of ``reference`` on each of B, G and R."""
    near = (np.abs(frames.astype(np.int16) - reference) <= levels).all(axis=3)
    if where is None:
        return near.mean(axis=(1, 2))
    return near[:, where].mean(axis=1) if where.any() else np.zeros(len(frames))


@dataclass(frozen=True)
class StillBackground:
    """What lies behind the animal in a clip whose camera held still.

    Attributes
    ----------
    image : ndarray of shape (rows, cols, 3), uint8
        At the working size: per pixel, the median of the sampled frames on which the
        animal's mask (grown by 3 pixels) leaves it free.
    known : ndarray of shape (rows, cols), bool
        Where at least one sampled frame left it free.
    """

    image: np.ndarray
    known: np.ndarray

    @classmethod
    def learn(cls, frames: Sequence[np.ndarray], masks: Sequence[np.ndarray]
              ) -> StillBackground:
        """From frames sampled across the clip and the animal's masks on them (0/1, working
        size). A plain median would hold an animal that lingers on a spot, and call the ground
        it uncovers the subject."""
        stack = np.stack(frames).astype(np.float32)
        taken = np.stack([cv2.dilate(m.astype(np.uint8), disk(3)) > 0 for m in masks])
        stack[taken] = np.nan
        known = ~taken.all(axis=0)
        image = np.zeros(stack.shape[1:], np.uint8)
        image[known] = np.nanmedian(stack[:, known], axis=0).round().astype(np.uint8)
        return cls(image, known)

    def ratios(self, image: np.ndarray, prob: np.ndarray, window: tuple[int, int, int, int]
               ) -> np.ndarray | None:
        """How much more likely each pixel of a propagated frame's ``window`` (``image``,
        BGR uint8; ``prob``, its warped mask in [0, 1]) is the subject, by how unlike this
        background it looks.

        Returns
        -------
        ndarray of shape (h, w), float32, or None
            Log-likelihood ratios within +-3 (0 where the background is not known), learnt on
            this frame from the warped mask's sure sides as
            :func:`~gaitcore.silhouettes.motion.motion_ratios`' are; None when the mask has
            too few sure pixels.

        Notes
        -----
        The difference is the largest of the three channels', binned in half octaves
        (:data:`_STILL_BINS`). Unlike motion, it tells a planted foot from the ground it
        stands on, and a leg of the ground's own colours from the ground the background shows
        there.
        """
        x0, y0, x1, y1 = window
        diff = _largest_difference(image, self.image[y0:y1, x0:x1])[0]
        return _ground_ratios(diff, self.known[y0:y1, x0:x1], prob)


_DIFF_BINS = np.clip(2 * np.log2(np.arange(256, dtype=np.float32) + 1), 0, _STILL_BINS - 1
                     ).astype(np.intp)


def _largest_difference(image: np.ndarray, other: np.ndarray) -> list[np.ndarray]:
    """Per pixel, the largest of B, G and R's absolute differences between two uint8 images,
    then the difference of each further channel (an alpha), as planes."""
    blue, green, red, *rest = cv2.split(cv2.absdiff(image, other))
    return [cv2.max(cv2.max(blue, green), red), *rest]


def _sorted(planes: list[np.ndarray]) -> list[np.ndarray]:
    """The planes (same shape, uint8) sorted pixel by pixel, smallest first (odd-even
    transposition: a few microseconds a pair on a working-size window)."""
    planes = list(planes)
    for r in range(len(planes)):
        for k in range(r % 2, len(planes) - 1, 2):
            low, high = planes[k], planes[k + 1]
            planes[k], planes[k + 1] = cv2.min(low, high), cv2.max(low, high)
    return planes


def _picked(planes: list[np.ndarray], index: np.ndarray) -> np.ndarray:
    """Per pixel, the plane ``index`` names (``np.choose``, a copy per plane: twenty times
    cheaper on a working-size window)."""
    out = planes[0].copy()
    for k in range(1, len(planes)):
        cv2.copyTo(planes[k], (index == k).view(np.uint8), out)
    return out


def _ground_ratios(diff: np.ndarray, known: np.ndarray, prob: np.ndarray) -> np.ndarray | None:
    """:meth:`StillBackground.ratios` from each pixel's difference from the ground behind it
    (uint8; ``known``: where that ground was seen)."""
    if np.count_nonzero(prob > 0.9) < 16:
        return None
    bins = _DIFF_BINS[diff]
    sure = np.where(known, prob, np.float32(0.5))
    return np.where(known, learnt_ratios(bins, sure, _STILL_BINS), np.float32(0))


def camera_motion(grey: np.ndarray, later: np.ndarray, off: np.ndarray) -> np.ndarray | None:
    """The homography that carries ``grey``'s pixels to ``later``'s (two frames, grey, working
    size): corners off the subject (``off``, bool) tracked by pyramidal Lucas-Kanade, fitted
    by RANSAC. None when too few corners are tracked or fit."""
    corners = cv2.goodFeaturesToTrack(grey, 150, 0.01, 7, mask=off.astype(np.uint8))
    if corners is None or len(corners) < _LEAST_CORNERS:
        return None
    tracked, found, _ = cv2.calcOpticalFlowPyrLK(grey, later, corners, None, winSize=(11, 11),
                                                 maxLevel=2)
    found = found.ravel() == 1
    if found.sum() < _LEAST_CORNERS:
        return None
    homography, inliers = cv2.findHomography(corners[found], tracked[found], cv2.RANSAC, 2.0)
    if homography is None or inliers.sum() < _LEAST_CORNERS:
        return None
    return homography


_LEAST_CORNERS = 12


class NearbyGround:
    """What lies behind the animal on a frame of a pass, from the frames around it.

    The frames up to ``nearby_reach`` either side (every ``nearby_step``) are brought to this
    frame by the camera's motion (:func:`camera_motion`, chained frame to frame). Each shows
    the ground where the animal is not: the frames already decided, off their masks; the
    frames ahead, off this frame's mask moved on as the animal moves over the ground. A pixel
    is as unlike that ground as the median of its differences from them (the largest of B, G
    and R). Ahead, the ground the animal is uncovering behind it; before, the ground it is
    stepping onto: the two a panning camera's colour and motion cues take for the animal
    (DAVIS dog, the flow there is the dog's).

    A frame ahead shows a planted foot where this frame's mask, moved on, is not: there the
    foot reads as ground, and legs are cut worse. Clearing more around the moved mask gave
    them back but lost the dog's uncovered ground. The median of the differences, not the
    difference from the frames' median, is cheaper and read about the same. Comparing each
    pixel with the range its 3x3 neighbourhood spans in the aligned frame (a tolerance for
    parallax) lost legs: a thin leg matches the ground beside it. The figures:
    docs/segmentation.md (Settings, ``nearby_weight``; Tried).

    A pass adds each frame before it is decided (:meth:`add`, ``nearby_reach`` frames ahead),
    and settles its mask once it is (:meth:`settle`), in the pass's order.
    """

    def __init__(self, settings: PropagationSettings, mask: np.ndarray) -> None:
        """For a pass from a key frame whose mask (0/1, working size) is ``mask``."""
        self.reach, self.step = settings.nearby_reach, settings.nearby_step
        self.frames: dict[int, np.ndarray] = {}
        self.onward: dict[int, np.ndarray | None] = {}
        self.backward: dict[int, np.ndarray] = {}  # the inverses of ``onward``'s
        self.centres: dict[int, np.ndarray] = {}
        self.latest = mask
        self.added = self.deciding = 0
        self._grey: np.ndarray | None = None

    def add(self, small: np.ndarray, grey: np.ndarray) -> None:
        """The pass's next frame (BGR and grey, working size), ahead of the one being decided;
        the pass's latest mask keeps the camera's corners off the animal."""
        i, self.added = self.added, self.added + 1
        self.frames[i] = cv2.cvtColor(small, cv2.COLOR_BGR2BGRA)
        if self._grey is not None:
            x, y, w, h = cv2.boundingRect(self.latest)
            grow = round(0.25 * max(w, h))
            off = np.ones(grey.shape, bool)
            off[max(0, y - grow):y + h + grow, max(0, x - grow):x + w + grow] = False
            self.onward[i - 1] = onward = camera_motion(self._grey, grey, off)
            if onward is not None:
                self.backward[i - 1] = np.linalg.inv(onward)
        self._grey = grey

    def settle(self, mask: np.ndarray) -> None:
        """The mask of the frame being decided (the key frame's first): where it shows the
        ground to the frames after it. The next frame is decided then."""
        i, self.deciding, self.latest = self.deciding, self.deciding + 1, mask
        self.frames[i][..., 3] = 255 - 255 * cv2.dilate(mask, disk(3))
        moments = cv2.moments(mask, True)
        if moments["m00"] > 0:
            self.centres[i] = np.array([moments["m10"], moments["m01"]]) / moments["m00"]
        for gone in [j for j in self.frames if j < i - self.reach]:
            for kept in (self.frames, self.onward, self.backward, self.centres):
                kept.pop(gone, None)

    def ratios(self, image: np.ndarray, prob: np.ndarray, window: tuple[int, int, int, int]
               ) -> np.ndarray | None:
        """:meth:`StillBackground.ratios` of the ``window`` (``image``) of the frame being
        decided, against the ground the frames around it show there, with ``prob`` its warped
        mask; None where too few frames around it are known."""
        i = self.deciding
        x0, y0, x1, y1 = window
        size = (x1 - x0, y1 - y0)
        shift = np.array([[1, 0, -x0], [0, 1, -y0], [0, 0, 1]], np.float64)
        here = cv2.cvtColor(image, cv2.COLOR_BGR2BGRA)
        inside = (prob > 0.5).view(np.uint8)
        pace = self._pace(i, inside, window)
        planes = []
        for j in [*range(-self.reach, 0, self.step), *range(self.step, self.reach + 1, self.step)]:
            to_here = self._to(i + j, i)
            if to_here is None or (j > 0 and pace is None):
                continue
            # The fourth channel is 255 where that frame shows the ground (0 off the frame).
            seen = cv2.warpPerspective(self.frames[i + j], shift @ to_here, size,
                                       flags=cv2.INTER_LINEAR)
            diff, hidden = _largest_difference(here, seen)
            diff = cv2.max(diff, cv2.threshold(hidden, 0, 255, cv2.THRESH_BINARY)[1])
            if j > 0:  # the animal there: this frame's, moved on over the ground
                ahead = cv2.warpAffine(inside, np.float32([[1, 0, j * pace[0]],
                                                           [0, 1, j * pace[1]]]), size,
                                       flags=cv2.INTER_NEAREST)
                diff = cv2.max(diff, cv2.dilate(ahead, disk(3)) * np.uint8(255))
            planes.append(diff)
        if len(planes) < 2:
            return None
        count = sum((p < 255).view(np.uint8) for p in planes)
        middle = _picked(_sorted(planes), (np.maximum(count, 1) - 1) // 2)
        return _ground_ratios(middle, count > 0, prob)

    def _to(self, j: int, i: int) -> np.ndarray | None:
        """The camera's motion from frame ``j`` of the pass to frame ``i``, or None."""
        if j not in self.frames:
            return None
        step = 1 if j < i else -1
        motions = self.onward if step == 1 else self.backward
        motion = np.eye(3)
        for k in range(j, i, step):
            moved = motions.get(min(k, k + step))
            if moved is None:
                return None
            motion = moved @ motion
        return motion

    def _pace(self, i: int, inside: np.ndarray, window: tuple[int, int, int, int]
              ) -> np.ndarray | None:
        """How far the animal moves over the ground from frame to frame, in this frame's
        window: from the last decided frame's centre, carried here by the camera, to the
        warped mask's."""
        before = self.centres.get(i - 1)
        motion = self.onward.get(i - 1)
        moments = cv2.moments(inside.view(np.uint8), True)
        if before is None or motion is None or moments["m00"] == 0:
            return None
        carried = cv2.perspectiveTransform(before[None, None], motion)[0, 0]
        here = np.array([moments["m10"], moments["m01"]]) / moments["m00"]
        return here + window[:2] - carried
