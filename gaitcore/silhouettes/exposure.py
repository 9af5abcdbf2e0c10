"""A frame's exposure and colour balance against its key frame's (beyond the paper).

The key frame's colour models judge every frame of its passes. When the camera's exposure or
white balance drifts (a cloud, an automatic exposure following the animal into shade), the
same fur reads as other colours, and the models lose it. Each frame is therefore brought back
to its key frame's exposure and balance before they judge it (:func:`exposed`):

- from frame to frame, the ratio of grey levels (and of each of B, G and R) at the
  background's points the flow pairs (:func:`exposure_ratio`, :func:`balance_change`);
- along a pass, those ratios summed and pulled towards the background's own level and colour
  against the key frame's (:class:`ExposureTrack`), so they cannot drift.

The optical flow and the window a frame is decided in are
:mod:`gaitcore.silhouettes.propagate`'s (:func:`~gaitcore.silhouettes.propagate.warp_mask`
measures the ratios as it warps the mask).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import cv2
import numpy as np

from gaitcore.silhouettes.settings import PropagationSettings

if TYPE_CHECKING:
    from gaitcore.silhouettes.propagate import Warp


def measurable(image: np.ndarray) -> np.ndarray:
    """Pixels (grey, or BGR) neither near black nor clipped in any channel: their level
    scales with the exposure."""
    channels = 1 if image.ndim == 2 else image.shape[2]
    return cv2.inRange(image, (17,) * channels, (239,) * channels) > 0


def background_pixels(grey: np.ndarray, subject: np.ndarray) -> np.ndarray:
    """The pixels whose level measures the exposure: measurable, and off the subject
    (``subject``: a 0/1 mask, or a warped one in [0, 1])."""
    return measurable(grey) & (subject < 0.05)


with np.errstate(divide="ignore", invalid="ignore"):
    _LOG = np.log(np.arange(256, dtype=np.float32))
    _PAIR_RATIO = (_LOG[:, None] - _LOG[None, :]).ravel()
"""The log ratio of each pair of levels, ``after * 256 + before`` (float32, as it is taken of
the pixels): a pair's rank among them stands for its ratio, and ranks sort by counting."""
_BY_RATIO = np.argsort(_PAIR_RATIO, kind="stable")
_RATIO_RANK = np.empty(_PAIR_RATIO.size, np.uint16)
_RATIO_RANK[_BY_RATIO] = np.arange(_PAIR_RATIO.size)


def _median_ratio(ranks: np.ndarray) -> np.ndarray:
    """The median log ratio of each row of pairs (``ranks``: their :data:`_RATIO_RANK`), as
    ``np.median`` takes it of the ratios themselves (float32): 16-bit ranks sort by counting,
    nearly twice as fast as numpy selects among the ratios."""
    n = ranks.shape[1]
    middle = np.sort(ranks, axis=1, kind="stable")[:, [(n - 1) // 2, n // 2]]
    return _PAIR_RATIO[_BY_RATIO[middle]].mean(axis=1)


def _log_ratios(before: np.ndarray, after: np.ndarray, ok: np.ndarray,
                settings: PropagationSettings) -> np.ndarray | None:
    """How much brighter ``after`` is than ``before`` (grey or BGR, uint8, paired by the flow),
    per channel: the median log ratio at the pixels ``ok`` (the background's, measurable in
    both), among the pairs that match on every channel once the ratios are applied; None when
    under a quarter of them match (the flow paired different things: Muybridge's plates, a
    cut)."""
    n = int(ok.sum())
    if n < 64:
        return None
    b = before[ok].reshape(n, -1).T
    a = after[ok].reshape(n, -1).T
    ranks = _RATIO_RANK[(a.astype(np.uint16) << 8) | b]
    gains = np.exp(_median_ratio(ranks))
    same = (np.abs(a.astype(np.float32) - gains[:, None] * b.astype(np.float32))
            < settings.trust_grey).all(axis=0)
    if same.sum() < max(64, n // 4):
        return None
    return _median_ratio(ranks[:, same])


def exposure_ratio(before: np.ndarray, after: np.ndarray, ok: np.ndarray,
                   settings: PropagationSettings) -> float:
    """This frame's brightness over the previous one's (grey, :func:`_log_ratios`); 1 when
    it cannot be told."""
    log_ratio = _log_ratios(before, after, ok, settings)
    return 1.0 if log_ratio is None else float(np.exp(log_ratio[0]))


def balance_change(before: np.ndarray, after: np.ndarray, background: np.ndarray,
                   settings: PropagationSettings) -> np.ndarray:
    """The change of colour balance from ``before`` to ``after`` (BGR): the log ratios of
    :func:`_log_ratios` at the ``background`` pixels measurable in both, less their mean;
    zeros when they cannot be told."""
    ok = background & measurable(before) & measurable(after)
    log_ratios = _log_ratios(before, after, ok, settings)
    return np.zeros(3) if log_ratios is None else log_ratios - log_ratios.mean()


def _levels(image: np.ndarray, ok: np.ndarray) -> np.ndarray | None:
    """The median level of each channel (grey: one; uint8) at the pixels ``ok``, as
    ``np.median`` takes it, by counting; None when too few."""
    n = int(ok.sum())
    if n < 64:
        return None
    counted = [np.bincount(channel, minlength=256).cumsum()
               for channel in image[ok].reshape(n, -1).T]
    return np.array([np.searchsorted(c, [(n - 1) // 2, n // 2], "right").mean()
                     for c in counted])


def background_level(grey: np.ndarray, background: np.ndarray) -> float | None:
    """Median grey level of the ``background`` pixels (measurable ones); None when too few."""
    level = _levels(grey, background)
    return None if level is None else float(level[0])


def balance_level(bgr: np.ndarray, background: np.ndarray) -> np.ndarray | None:
    """The log of the median B, G and R of the ``background`` pixels measurable in all three,
    less their mean; None when too few."""
    levels = _levels(bgr, background & measurable(bgr))
    if levels is None:
        return None
    log_levels = np.log(levels)
    return log_levels - log_levels.mean()


class ExposureTrack:
    """A frame's exposure and colour balance over its key frame's, followed along one pass of
    the propagation.

    Two estimates of each, as a complementary filter: the sum of the frame-to-frame log
    ratios (:attr:`~gaitcore.silhouettes.propagate.Warp.exposure`,
    :attr:`~gaitcore.silhouettes.propagate.Warp.balance`; exact from frame to frame, but they
    drift over hundreds of frames) pulled by ``exposure_pull`` towards the background's
    median level (grey), and its colour (:func:`balance_level`), against the key frame's
    (they cannot drift, but the background's content changes them).

    Parameters
    ----------
    grey : ndarray of shape (rows, cols), uint8
        The key frame, grey, at the working size.
    mask : ndarray of shape (rows, cols), uint8
        Its 0/1 mask.
    around : (x0, y0, x1, y1)
        Where the background's level is measured: the window the key frame's successors are
        decided in (:func:`~gaitcore.silhouettes.propagate.window`).
    settings : PropagationSettings
    colour : ndarray of shape (rows, cols, 3), uint8, optional
        The key frame in colour (BGR): without it the balance is followed from frame to frame
        only.
    """

    def __init__(self, grey: np.ndarray, mask: np.ndarray, around: tuple[int, int, int, int],
                 settings: PropagationSettings, colour: np.ndarray | None = None) -> None:
        self.settings = settings
        self.level = self.balance_level = None
        if mask.any():
            x0, y0, x1, y1 = around
            background = background_pixels(grey[y0:y1, x0:x1], mask[y0:y1, x0:x1])
            self.level = background_level(grey[y0:y1, x0:x1], background)
            if colour is not None:
                self.balance_level = balance_level(colour[y0:y1, x0:x1], background)
        self.log_gain = 0.0
        self.log_balance = np.zeros(3)

    def step(self, warp: Warp) -> np.ndarray:
        """Follow the exposure and the balance to the frame ``warp`` carried the mask to;
        returns the B, G and R gains that bring it back to the key frame's."""
        s = self.settings
        if not s.match_exposure:
            return np.ones(3)
        self.log_gain += float(np.log(warp.exposure))
        if self.level is not None and warp.level is not None:
            self.log_gain += s.exposure_pull * (float(np.log(warp.level / self.level))
                                                - self.log_gain)
        self.log_balance = self.log_balance + warp.balance
        if self.balance_level is not None and warp.balance_level is not None:
            self.log_balance += s.exposure_pull * (warp.balance_level - self.balance_level
                                                   - self.log_balance)
        matched = _beyond(self.log_gain, s.exposure_slack) + _beyond(self.log_balance,
                                                                      s.balance_slack)
        return np.exp(-matched)


def _beyond(log_gain: float | np.ndarray, slack: float) -> np.ndarray:
    """What of a log gain (or each of several) exceeds ``slack``, with its sign."""
    return np.sign(log_gain) * np.maximum(0.0, np.abs(log_gain) - slack)


def exposed(small: np.ndarray, gains: float | Sequence[float] | np.ndarray) -> np.ndarray:
    """A frame's colours times ``gains`` (one for all channels, or one each for B, G and R;
    rounded, saturated): a frame brought back to its key frame's exposure and balance before
    the key's colours judge it."""
    gains = np.broadcast_to(np.asarray(gains, np.float64), (3,))
    return small if (gains == 1.0).all() else cv2.transform(small, np.diag(gains))
