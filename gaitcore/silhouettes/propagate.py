"""Carrying a silhouette from frame to frame by optical flow (beyond the paper's Section 2.2).

Everything works at a reduced *working size* (:class:`WorkingSize`): the subject's longer side
is brought to about ``subject_side_px`` pixels, enough to keep thin legs while staying fast.

- A frame receives the previous frame's mask warped by dense optical flow (OpenCV's DIS,
  Kroeger et al. 2016), not shifted: each pixel looks up where it was in the previous frame.
- It is then decided (:func:`fuse_cut`) from the colour models learnt on the key frame the mask
  came from (kept, so they cannot drift) and the warped mask as a soft prior, smoothed along
  the image's edges: the mask follows legs and snaps to edges. Where the flow is trusted (the
  previous frame, warped by it, matches this one) the prior is sharp and strong, so a thin leg
  the flow carried well is not given away to an ambiguous colour; elsewhere it is blurred and
  weak, and colour decides. Colour is helped by motion: what moves unlike the ground (the
  camera's and the ground's motion, a homography fitted to the flow off the mask) is more
  likely the subject (:mod:`gaitcore.silhouettes.motion`), and by what lies behind the animal
  (:mod:`gaitcore.silhouettes.ground`): when the camera held still (a tripod shot), what looks
  unlike the clip's background (a planted foot, or a leg of the ground's own colours); when it
  did not (a camera panning after the animal), what looks unlike the ground the frames either
  side show there, brought to this one by the camera's motion (the ground a running animal
  uncovers behind it, which colour and motion take for the animal).
  Parts of the mask that drift away from the body (background the flow carried along) are
  dropped.
- A result whose area jumps away from the warped mask's (a flood into the ground, or a
  collapse) is refused: the warped mask is kept and the frame marked as not confident. When
  the warped pixels stop looking like the subject, or the mask stops standing out from its
  surroundings (it slid onto the background), it is lost, and searched for again in the
  whole frame (:func:`find_again`).

Key frames (the first one, corrected ones) are cut by :mod:`gaitcore.silhouettes.keyframe`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache

import cv2
import numpy as np

from gaitcore.silhouettes.colour_model import ColourTable, colour_gap, learn_colours
from gaitcore.silhouettes.exposure import (
    background_level,
    background_pixels,
    balance_change,
    balance_level,
    exposure_ratio,
    measurable,
)
from gaitcore.silhouettes.motion import motion_ratios
from gaitcore.silhouettes.settings import PropagationSettings
from gaitcore.silhouettes.tracking import keep_overlapping

_PRESETS = {"ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
            "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
            "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM}
Box = tuple[int, int, int, int]  # x, y, w, h


_MANY_PIXELS = 40_000
"""A window at least this large measures its exposure and background level on a quarter of
its pixels (the medians were a noticeable share of a run's time, and a quarter tells them as
well); a smaller one on all of them (on a small window a quarter changed frames' exposure, and
the cut lost part of the subject; see docs/segmentation.md, Settings)."""

TOUCHING = 0.02
"""A component is kept when its overlap with the prediction is at least this share of the best
one's: a leg cut off from the body by a shadow still touches it."""


@dataclass(frozen=True)
class WorkingSize:
    """How frames are shrunk for the cut.

    Attributes
    ----------
    scale : float
        Working pixels per source pixel (at most 1).
    wh : (int, int)
        Working frame size (width, height).
    shape : (int, int)
        Source frame shape (rows, cols).
    """

    scale: float
    wh: tuple[int, int]
    shape: tuple[int, int]
    subject_side: float = 0.0

    @classmethod
    def for_subject(cls, shape: tuple[int, int], subject_side: float,
                    settings: PropagationSettings) -> WorkingSize:
        """The working size that brings a subject ``subject_side`` source pixels long to
        ``settings.subject_side_px``."""
        rows, cols = int(shape[0]), int(shape[1])
        scale = min(1.0, settings.subject_side_px / max(float(subject_side), 1.0))
        return cls(scale, (max(16, round(cols * scale)), max(16, round(rows * scale))),
                   (rows, cols), float(subject_side))

    def shrink(self, frame: np.ndarray) -> np.ndarray:
        """Area-averaged downscale (halving with pyrDown first: cheaper on big frames)."""
        img = frame
        while img.shape[1] >= 2 * self.wh[0] and img.shape[0] >= 2 * self.wh[1]:
            img = cv2.pyrDown(img)
        if img.shape[1] == self.wh[0] and img.shape[0] == self.wh[1]:
            return np.ascontiguousarray(img)
        return cv2.resize(img, self.wh, interpolation=cv2.INTER_AREA)

    def shrink_mask(self, mask: np.ndarray) -> np.ndarray:
        """A full-frame bool mask at the working size (area-averaged, kept above one half)."""
        small = cv2.resize(mask.astype(np.uint8) * np.uint8(255), self.wh,
                           interpolation=cv2.INTER_AREA)
        return small >= 128

    def box(self, box: Box) -> Box:
        """A source box at the working size, clipped to the frame."""
        x, y, w, h = (float(v) * self.scale for v in box)
        x0, y0 = max(0, int(np.floor(x))), max(0, int(np.floor(y)))
        x1, y1 = min(self.wh[0], int(np.ceil(x + w))), min(self.wh[1], int(np.ceil(y + h)))
        return x0, y0, max(0, x1 - x0), max(0, y1 - y0)

    def enlarge(self, small: np.ndarray, image: np.ndarray | None = None) -> np.ndarray:
        """A working-size 0/1 mask as a full-frame bool mask, computed only around the mask.

        Bilinear (above one half) without ``image``. With the source frame (BGR or grey,
        uint8) the outline follows its edges below the working size: a guided filter
        (He et al. 2010) fitted at the working size, mask against grey level within
        :data:`EDGE_RADIUS` working pixels, is applied to the full-size grey (He and Sun's
        fast guided filter, 2015). It read closer than the bilinear mask on every run
        measured, at a small cost a frame (see docs/segmentation.md, Settings).
        """
        rows, cols = self.shape
        out = np.zeros((rows, cols), bool)
        x, y, w, h = cv2.boundingRect(small.astype(np.uint8))
        if w == 0:
            return out
        pad = 1 if image is None else 2 * EDGE_RADIUS + 2
        x0, y0 = max(0, x - pad), max(0, y - pad)
        x1, y1 = min(self.wh[0], x + w + pad), min(self.wh[1], y + h + pad)
        fx, fy = cols / self.wh[0], rows / self.wh[1]
        X0, Y0 = int(x0 * fx), int(y0 * fy)
        X1, Y1 = min(cols, int(np.ceil(x1 * fx))), min(rows, int(np.ceil(y1 * fy)))

        def up(plane: np.ndarray, left: int = 0, top: int = 0) -> np.ndarray:
            """``plane`` (working size from ``(left, top)``) at the full size: the sampling
            of cv2.resize on the whole mask, src = (dst + 1/2) / f - 1/2."""
            warp = np.array([[1 / fx, 0, (X0 + 0.5) / fx - 0.5 - left],
                             [0, 1 / fy, (Y0 + 0.5) / fy - 0.5 - top]])
            return cv2.warpAffine(plane, warp, (X1 - X0, Y1 - Y0),
                                  flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                  borderMode=cv2.BORDER_REPLICATE)

        if image is None:
            out[Y0:Y1, X0:X1] = up(small.astype(np.uint8) * np.uint8(255)) > 127
            return out
        grey = image[Y0:Y1, X0:X1]
        if grey.ndim == 3:
            grey = cv2.cvtColor(grey, cv2.COLOR_BGR2GRAY)
        level = grey.astype(np.float32) * np.float32(1 / 255)
        # The grey at the working size: each working pixel's source pixels averaged (a box
        # as wide, odd so that it stays centred), sampled at its centre.
        width, height = (2 * int(f / 2) + 1 for f in (fx, fy))
        shrink = np.array([[fx, 0, (x0 + 0.5) * fx - 0.5 - X0],
                           [0, fy, (y0 + 0.5) * fy - 0.5 - Y0]])
        guide = cv2.warpAffine(cv2.blur(level, (width, height)), shrink, (x1 - x0, y1 - y0),
                               flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                               borderMode=cv2.BORDER_REPLICATE)
        slope, offset = guided_coefficients(guide, small[y0:y1, x0:x1].astype(np.float32))
        out[Y0:Y1, X0:X1] = up(slope, x0, y0) * level + up(offset, x0, y0) > 0.5
        return out


EDGE_RADIUS = 2
"""Working pixels either side over which :meth:`WorkingSize.enlarge` fits the mask to the grey
level (1 to 3 read about the same; see docs/segmentation.md, Settings)."""

EDGE_EPS = 0.005
"""The guided filter's regularisation, in squared grey levels of [0, 1]: flatter windows than
about 0.07 of a level's spread keep the bilinear mask (the value matters little)."""


def guided_coefficients(guide: np.ndarray, mask: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """The guided filter's averaged linear coefficients of ``mask`` against ``guide`` (grey
    levels in [0, 1]; both float32, same shape): ``mask ~ slope * guide + offset`` locally."""
    size = (2 * EDGE_RADIUS + 1,) * 2

    def mean(a: np.ndarray) -> np.ndarray:
        return cv2.boxFilter(a, -1, size, borderType=cv2.BORDER_REFLECT)

    mean_guide, mean_mask = mean(guide), mean(mask)
    spread = mean(guide * guide) - mean_guide * mean_guide
    slope = (mean(guide * mask) - mean_guide * mean_mask) / (spread + np.float32(EDGE_EPS))
    return mean(slope), mean(mean_mask - slope * mean_guide)


@dataclass(frozen=True)
class Cut:
    """One frame's result at the working size.

    Attributes
    ----------
    mask : ndarray of shape (rows, cols), uint8
        0/1 silhouette at the working size.
    confidence : float
        How far the mask stands out from its surroundings under its key's colours, as a share
        of how far the key's own mask did (:func:`fuse_cut`), in [0, 1]; 1 on key frames, 0
        when the cut was refused and the warped prior kept.
    """

    mask: np.ndarray
    confidence: float

    @cached_property
    def area(self) -> int:
        """The mask's pixels, counted once."""
        return cv2.countNonZero(self.mask)


def make_flow(settings: PropagationSettings) -> cv2.DISOpticalFlow:
    """A DIS optical flow object with the settings' preset."""
    return cv2.DISOpticalFlow_create(_PRESETS[settings.flow_preset])


def overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two 0/1 (or bool) masks; 0 when both are empty."""
    return float((a & b).sum()) / max(float((a | b).sum()), 1.0)


def disk(r: int) -> np.ndarray:
    """Elliptic structuring element of radius ``r`` (at least 1), read-only."""
    return _disk(max(1, int(r)))


@lru_cache(maxsize=64)
def _disk(r: int) -> np.ndarray:
    """Made once a radius: a propagated frame asks for a dozen."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    kernel.flags.writeable = False
    return kernel


def window(mask: np.ndarray, settings: PropagationSettings) -> tuple[int, int, int, int]:
    """Where a frame is decided around a 0/1 mask (not empty): its box grown by
    ``margin_frac`` of its longer side and 8 pixels, clipped to the frame, as (x0, y0, x1, y1)."""
    rows, cols = mask.shape
    x, y, w, h = cv2.boundingRect(mask)
    grow = int(settings.margin_frac * max(w, h)) + 8
    return max(0, x - grow), max(0, y - grow), min(cols, x + w + grow), min(rows, y + h + grow)


def key_colours(small: np.ndarray, mask: np.ndarray, settings: PropagationSettings,
                background: np.ndarray | None = None) -> ColourTable | None:
    """The colour models of a key frame (working size), learnt in the :func:`window` its
    successors will be decided in, with the pixels under the artist's ``background`` strokes
    there (bool, or None) counted ``stroke_teaching`` times more; None for an empty mask."""
    if not mask.any():
        return None
    x0, y0, x1, y1 = window(mask, settings)
    taught = None
    if settings.stroke_teaching and background is not None and background.any():
        pixels = np.tile(small[background], (settings.stroke_teaching, 1))
        taught = pixels, np.zeros(len(pixels), np.uint8)
    return learn_colours(small[y0:y1, x0:x1], mask[y0:y1, x0:x1], taught)


@dataclass(frozen=True)
class Warp:
    """The previous frame's mask carried to this frame (:func:`warp_mask`).

    Attributes
    ----------
    prob : ndarray of shape (h, w), float32
        The warped mask in [0, 1] inside the window.
    trust : ndarray of shape (h, w), float32
        In (0, 1]: how well the previous frame warped by the same flow matches this one
        (see ``trust_grey``); low where the flow is wrong (a fast leg, an occlusion).
    window : (x0, y0, x1, y1)
        Where ``prob`` lies in the frame: the mask's box grown by ``margin_frac``.
    exposure : float
        This frame's brightness over the previous one's, at the same points of the scene
        (1 when the camera's exposure held).
    level : float or None
        This frame's background level in the window (:func:`background_level`).
    balance : ndarray of shape (3,)
        This frame's colour balance over the previous one's: the log ratios of its B, G and R
        levels at the same points, less their mean (zeros when the balance held or was not
        measured; see :func:`balance_change`).
    balance_level : ndarray of shape (3,) or None
        The background's colour in the window (:func:`balance_level`).
    motion : ndarray of shape (h, w), float32, or None
        The motion cue (:func:`motion_ratios`); None when it could not be learnt.
    maps : (ndarray, ndarray) of shape (h, w), float32, or None
        Where each pixel of the window came from in the previous frame (x, y, in the
        window's coordinates); None when the window was too small for the flow.
    """

    prob: np.ndarray
    trust: np.ndarray
    window: tuple[int, int, int, int]
    exposure: float = 1.0
    level: float | None = None
    balance: np.ndarray = field(default_factory=lambda: np.zeros(3))
    balance_level: np.ndarray | None = None
    motion: np.ndarray | None = None
    maps: tuple[np.ndarray, np.ndarray] | None = None

    def carried(self, values: np.ndarray) -> np.ndarray:
        """A whole previous-frame map (working size, float32) brought to this frame by the
        same flow, inside the window; held where the window was too small for the flow."""
        x0, y0, x1, y1 = self.window
        here = values[y0:y1, x0:x1]
        if self.maps is None:
            return here.copy()
        return cv2.remap(np.ascontiguousarray(here), *self.maps, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)


class CorrectionTrack:
    """What a correction turned to the subject on its key frame, carried along a pass from
    it by the flow (:meth:`Warp.carried`) and faded by ``correction_fade`` each frame: the
    cue :func:`fuse_cut` weighs by ``correction_weight``.

    A correction mends its own frame, but the cues that missed the subject there (the key's
    colours, the network) miss it again on the next one, and the pass loses it at once: a
    ball the artist painted on frame after frame stayed lost until the turned pixels were
    carried. Only the pixels turned to the subject are carried: those turned to the
    background, carried alike, lay where the legs stepped next. Faded by the flow's trust as
    well (:attr:`Warp.trust`), the carried pixels died with a fast ball's untrusted flow.
    The figures: docs/segmentation.md (Settings, ``correction_weight``; Tried).

    Parameters
    ----------
    turned : ndarray of shape (rows, cols), bool
        The key frame's pixels a correction turned to the subject (working size).
    settings : PropagationSettings
    """

    LEAST = 0.05
    """The largest carried value under which the track is dropped."""

    def __init__(self, turned: np.ndarray, settings: PropagationSettings) -> None:
        self.values: np.ndarray | None = turned.astype(np.float32)
        self.fade = np.float32(settings.correction_fade)

    def step(self, warp: Warp) -> np.ndarray | None:
        """The track carried to this frame, inside ``warp``'s window (None once faded)."""
        if self.values is None:
            return None
        here = warp.carried(self.values)  # a new array: the track's own is reused below
        here *= self.fade
        if not here.size or float(here.max()) < self.LEAST:
            self.values = None
            return None
        x0, y0, x1, y1 = warp.window
        self.values.fill(0.0)
        self.values[y0:y1, x0:x1] = here
        return here


def warp_mask(mask: np.ndarray, grey_prev: np.ndarray, grey: np.ndarray,
              flow_of: cv2.DISOpticalFlow, settings: PropagationSettings, *,
              colours: tuple[np.ndarray, np.ndarray] | None = None) -> Warp:
    """Carry the previous mask to this frame by dense optical flow.

    Parameters
    ----------
    mask : ndarray of shape (rows, cols), uint8
        0/1 mask of the previous frame (working size, not empty).
    grey_prev, grey : ndarray of shape (rows, cols), uint8
        The previous and this frame, grey, at the working size.
    flow_of : cv2.DISOpticalFlow
    settings : PropagationSettings
    colours : (ndarray, ndarray) of shape (rows, cols, 3), uint8, optional
        The previous and this frame in colour (BGR, working size): the warp then measures
        the change of colour balance too.

    Returns
    -------
    Warp

    Notes
    -----
    Backward warping: the flow from this frame to the previous one tells each pixel where it
    came from, so the warped mask has no holes, and thin parts (legs) keep their width.

    The exposure is the median ratio of this frame's grey levels to the previous frame's at
    the background's points the flow pairs (see :func:`exposure_ratio`). DIS matches
    mean-normalised patches, so its flow holds through a change of exposure; the trust
    compares the two frames once the ratio is applied. The change of colour balance is
    measured the same way, per channel, at the same points (:func:`balance_change`).
    """
    x0, y0, x1, y1 = window(mask, settings)
    a = np.ascontiguousarray(grey[y0:y1, x0:x1])
    b = np.ascontiguousarray(grey_prev[y0:y1, x0:x1])
    if min(a.shape) < 16:
        held = mask[y0:y1, x0:x1].astype(np.float32)
        return Warp(held, np.zeros_like(held), (x0, y0, x1, y1))
    flow = flow_of.calc(a, b, None)
    map_x = np.arange(x1 - x0, dtype=np.float32) + flow[..., 0]
    map_y = np.arange(y1 - y0, dtype=np.float32)[:, None] + flow[..., 1]
    prob = cv2.remap(mask[y0:y1, x0:x1].astype(np.float32), map_x, map_y, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    came = cv2.remap(b, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    background = background_pixels(a, prob)
    grid = (slice(0, None, 2), slice(0, None, 2))  # a quarter of the pixels tell the levels
    levels = grid if a.size >= _MANY_PIXELS else (slice(None), slice(None))
    exposure = exposure_ratio(came[levels], a[levels],
                              background[levels] & measurable(came[levels]), settings)
    residual = cv2.GaussianBlur(np.abs(a - np.float32(exposure) * came), (0, 0), 1.5)
    trust = np.exp(-np.square(residual / settings.trust_grey))
    prob = cv2.GaussianBlur(prob, (0, 0), 1.0)
    warp = Warp(prob, trust, (x0, y0, x1, y1), exposure,
                background_level(a[levels], background[levels]),
                motion=motion_ratios(flow, prob) if settings.motion_weight > 0 else None,
                maps=(map_x, map_y))
    if colours is None:
        return warp
    here = np.ascontiguousarray(colours[1][y0:y1, x0:x1][grid])
    came_bgr = cv2.remap(np.ascontiguousarray(colours[0][y0:y1, x0:x1]), map_x[grid],
                         map_y[grid], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return replace(warp, balance=balance_change(came_bgr, here, background[grid], settings),
                   balance_level=balance_level(here, background[grid]))


def fuse_cut(small: np.ndarray, prior: np.ndarray, trust: np.ndarray, colours: ColourTable,
             settings: PropagationSettings, motion: np.ndarray | None = None,
             ground: np.ndarray | None = None, ground_weight: float = 0.0, *,
             salient: np.ndarray | None = None, corrected: np.ndarray | None = None,
             gap: float | None = None) -> Cut:
    """Decide one window of a propagated frame from its colours and the warped mask.

    Parameters
    ----------
    small : ndarray of shape (h, w, 3), uint8
        The window of the frame at the working size.
    prior : ndarray of shape (h, w), float32
        The warped mask in [0, 1].
    trust : ndarray of shape (h, w), float32
        The flow's trust in [0, 1] (from :func:`warp_mask`).
    colours : ColourTable
        Learnt on the key frame the mask was carried from, and kept: what that frame (and the
        artist's strokes there) taught is not forgotten frame after frame, and cannot drift.
    settings : PropagationSettings
    motion : ndarray of shape (h, w), float32, optional
        The motion cue (:attr:`Warp.motion`), weighed by ``motion_weight``.
    ground : ndarray of shape (h, w), float32, optional
        The cue of the ground behind the animal (the ``ratios`` of
        :mod:`gaitcore.silhouettes.ground`'s still background or nearby ground), weighed by
        ``ground_weight``.
    salient : ndarray of shape (h, w), float32, optional
        The salient-object network's log-odds (:class:`~gaitcore.silhouettes.saliency.
        SaliencyTrack`), weighed by ``saliency_weight``.
    corrected : ndarray of shape (h, w), float32, optional
        Where a correction on the key frame turned the mask to the subject, carried here and
        faded (:attr:`~gaitcore.silhouettes.roto.RotoSegmentation.turned`), in [0, 1],
        weighed by ``correction_weight``.
    gap : float, optional
        How far a mask that has not slid stands out from its surroundings under ``colours``
        (:func:`~gaitcore.silhouettes.colour_model.colour_gap`): the key frame's,
        ``colours.gap``, by default; 0 does not test it.

    Returns
    -------
    Cut
        The cut, its confidence how far it stands out from its surroundings under
        ``colours``, over ``colours.gap`` (at most 1). It ranks a clip's frames by their
        IoU with the reference better than the cut's overlap with its prior, the
        confidence before, did (see docs/segmentation.md, ``DOUBTFUL_BELOW``).

        The kept warped mask (confidence 0) when the result's area jumped (flood,
        collapse); an empty mask when the warped mask's pixels mostly do not look like the
        subject (it has left, or is hidden), or when the mask no longer stands out from its
        surroundings under the key's colours ``lost_gap`` as well as ``gap`` says (it slid
        onto the background).

    Notes
    -----
    Per pixel, the evidence for "subject" is the colour log-likelihood ratio, plus
    ``motion_weight`` times the motion's, ``still_weight`` times the still background's and
    ``saliency_weight`` times the salient-object network's and ``correction_weight`` times
    the carried correction ``corrected`` (when given), plus the warped
    mask's log-odds:
    ``trusted_prior_weight`` times those of the mask as warped (kept within those of 0.1 and
    0.9, so a strong colour can still turn a pixel the flow carried wrong), where the flow is
    trusted, and ``prior_weight`` times those of the mask blurred by
    ``prior_blur_frac`` of the subject's side (how far the flow may be wrong) where it is
    not, mixed by the trust. A guided filter (He et al. 2013) guided by the frame smooths the
    evidence along the image's edges, and the sign decides. This replaces the graph cut on
    propagated frames: every cue enters as a soft term (GrabCut only takes hard labels), and
    it is several times faster.
    """
    inside = (prior > 0.5).astype(np.uint8)
    if not inside.any():
        return Cut(inside, 0.0)
    _, _, w, h = cv2.boundingRect(inside)
    side = max(w, h)
    loose = _log_odds(cv2.GaussianBlur(prior, (0, 0), max(1.0, settings.prior_blur_frac * side)),
                      0.02)
    sharp = _log_odds(prior, 0.1)
    ratios = colours(small)
    cues = ratios
    if motion is not None:
        cues = cues + np.float32(settings.motion_weight) * motion
    if ground is not None:
        cues = cues + np.float32(ground_weight) * ground
    if salient is not None:
        cues = cues + np.float32(settings.saliency_weight) * salient
    if corrected is not None:
        cues = cues + np.float32(settings.correction_weight) * corrected
    evidence = (cues + trust * (settings.trusted_prior_weight * sharp)
                + (1 - trust) * (settings.prior_weight * loose))
    evidence = cv2.ximgproc.guidedFilter(np.ascontiguousarray(small), evidence,
                                         max(1, round(settings.smooth_frac * side)), 4.0)
    mask = keep_overlapping((evidence > 0).astype(np.uint8), inside, least=TOUCHING)
    mask = _near_body(mask, max(1, round(settings.part_gap_frac * side)))
    area, prior_area = float(mask.sum()), float(inside.sum())
    # Gone: nothing there looks like the subject, or the mask kept no longer stands out from
    # its surroundings (it slid onto them).
    gone = area < settings.max_shrink * prior_area and np.median(evidence[inside > 0]) < 0
    if not gone:
        kept = settings.max_shrink * prior_area <= area <= settings.max_growth * prior_area
        held = mask if kept else inside
        shows = colour_gap(ratios, held > 0)
        reference = colours.gap if gap is None else gap
        gone = (reference > 0 and shows < settings.lost_gap * reference
                and not _salient(salient, held))
        confidence = (float(np.clip(shows / colours.gap, 0.0, 1.0)) if colours.gap > 0
                      else overlap(mask, inside))
        cut = Cut(held, confidence if kept else 0.0)
    return Cut(np.zeros_like(inside), 0.0) if gone else cut


def _salient(salient: np.ndarray | None, mask: np.ndarray) -> bool:
    """Whether the salient-object network calls most of ``mask`` salient: a mask that slid
    onto the background is not, and one that stands out less under the key's colours only
    because the light fell is. A darkened clip, its key's colour gap raised by the network's
    better first cut, was otherwise lost at the darkest frames (see docs/segmentation.md,
    ``lost_gap``)."""
    return salient is not None and bool(mask.any()) and float(np.median(salient[mask > 0])) > 0


def _log_odds(p: np.ndarray, floor: float) -> np.ndarray:
    """log(p / (1 - p)) with p kept in [floor, 1 - floor]."""
    p = np.clip(p, floor, 1 - floor)
    return np.log(p / (1 - p))


def _near_body(mask: np.ndarray, gap: int) -> np.ndarray:
    """The largest component of a 0/1 mask and the others within ``gap`` pixels of it."""
    n, comp, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 2:
        return mask
    body = (comp == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))).astype(np.uint8)
    near = np.zeros(n, bool)
    near[comp[cv2.dilate(body, disk(gap)) > 0]] = True
    near[0] = False
    return near[comp].astype(np.uint8)


def find_again(small: np.ndarray, colours: ColourTable, area: float,
               settings: PropagationSettings) -> np.ndarray:
    """Look for a lost subject in a whole frame by colour alone.

    Parameters
    ----------
    small : ndarray of shape (rows, cols, 3), uint8
        The frame at the working size.
    colours : ColourTable
    area : float
        The subject's area on its key frame (working pixels).
    settings : PropagationSettings

    Returns
    -------
    ndarray of shape (rows, cols), uint8
        The largest subject-coloured component whose area is within ``max_shrink`` ..
        ``max_growth`` times ``area``; all zeros when there is none (still lost).
    """
    evidence = cv2.ximgproc.guidedFilter(np.ascontiguousarray(small), colours(small), 2, 4.0)
    found = cv2.morphologyEx((evidence > 0).astype(np.uint8), cv2.MORPH_OPEN, disk(1))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(found, connectivity=8)
    sizes = stats[1:, cv2.CC_STAT_AREA].astype(float)
    ok = np.nonzero((sizes >= settings.max_shrink * area)
                    & (sizes <= settings.max_growth * area))[0]
    if not ok.size:
        return np.zeros(found.shape, np.uint8)
    return (labels == 1 + ok[np.argmax(sizes[ok])]).astype(np.uint8)
