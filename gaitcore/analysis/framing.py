"""Silhouettes compared at the animal's own scale, with the frames where it is only partly in
view left out.

The paper cuts one fixed-size window around the subject (Section 2.2). An animal that walks
away from the camera at a slight angle shrinks over the clip, and one that enters or leaves
the view is cut by the frame's border: either change is larger than the legs' and becomes
the first principal component. Here each crop is scaled so that the silhouette keeps a
steady height (its height's slow trend, :func:`gaitcore.analysis.rhythm.slow_trend`, so
that the legs' swing and the head's nod do not rescale it) and centred on the slow trend of
its track, and the frames whose silhouette is lost, touches a side of the frame that most
frames do not touch, or is much smaller than its neighbours' are named, for the analysis to
leave out.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from gaitcore.analysis.rhythm import longest_period, slow_trend
from gaitcore.runs import true_runs
from gaitcore.silhouettes.tracking import EDGE_NAMES, RoiClip

SMALL_AREA = 0.5
"""A silhouette under this share of the median area of its neighbours is partial."""

NEIGHBOURS = 8
"""Frames on each side whose median area a silhouette is compared with."""

FRAMING_SHARE = 0.5
"""A side of the frame touched by more than this share of the silhouettes is the clip's
framing (an animal taller than the view), not an entry or an exit."""

SCALE_CHANGE = 1.1
"""The crops are scaled only when the slow trend of the silhouette's height changes by at least
this factor over the clip (below it the paper's one window size serves as well)."""

MIN_TRAVEL = 0.5
"""The animal crosses the view when its track moves by at least this many of its heights
over the frames analysed (less: it stays in place, or the camera follows it)."""

MAX_UPSCALE = 2.0
"""The most a crop is enlarged to bring it to the steady height (a silhouette that shrank more
than this is far away, and its pixels are too few to enlarge further)."""


@dataclass(frozen=True, eq=False)
class Framing:
    """Which frames are left out, and the scale each crop is compared at.

    Attributes
    ----------
    lost : ndarray of shape (n,), bool
        No silhouette.
    edge : ndarray of shape (n,), bool
        The silhouette touches a side of the frame that most frames do not (the animal is
        only partly in view).
    small : ndarray of shape (n,), bool
        Much smaller than its neighbours' (a part of the animal lost).
    sides : tuple of str
        The sides of the frame that ``edge`` frames touch ("left", "right", ...).
    scales : ndarray of shape (n,)
        The factor each crop was enlarged by (1: unchanged; below 1: shrunk) to keep the
        silhouette's height steady (all 1 under :data:`SCALE_CHANGE`).
    height_change : float
        The largest over the smallest of the slow trend of the silhouette's height, over the
        frames kept (1 when the framing was not asked to scale).
    travel : ndarray of shape (n,)
        The animal's progress across the view from frame 0, in its own heights: the slow
        trend of its track divided, frame by frame, by the slow trend of its height (so that
        an animal walking away, which shrinks, keeps its pace). Positive to the right; all 0
        with fewer than three frames kept.
    """

    lost: np.ndarray
    edge: np.ndarray
    small: np.ndarray
    sides: tuple[str, ...]
    scales: np.ndarray
    height_change: float
    travel: np.ndarray

    @property
    def left_out(self) -> np.ndarray:
        return self.lost | self.edge | self.small

    @property
    def partial(self) -> np.ndarray:
        """Frames left out although a silhouette was found."""
        return (self.edge | self.small) & ~self.lost


def partial_frames(roi: RoiClip) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Frames where the animal is only partly in view, or partly lost.

    Returns
    -------
    edge : ndarray of shape (n,), bool
        Touching a side of the frame touched by at most :data:`FRAMING_SHARE` of the frames
        (all False when ``roi.edges`` is None).
    small : ndarray of shape (n,), bool
        Area under :data:`SMALL_AREA` of the median of the :data:`NEIGHBOURS` found frames on
        each side.
    sides : tuple of str
        The sides the ``edge`` frames touch.
    """
    n = roi.crops.shape[0]
    found = ~np.asarray(roi.lost, dtype=bool)
    edge = np.zeros(n, dtype=bool)
    sides: list[str] = []
    if roi.edges is not None and found.any():
        bits = np.asarray(roi.edges, dtype=np.uint8)
        for bit, name in EDGE_NAMES.items():
            touching = (bits & bit) != 0
            if 0 < touching[found].mean() <= FRAMING_SHARE:
                edge |= touching & found
                sides.append(name)
    area = roi.crops.reshape(n, -1).sum(axis=1).astype(float)
    small = np.zeros(n, dtype=bool)
    where = np.flatnonzero(found)
    for k, t in enumerate(where):
        near = where[max(0, k - NEIGHBOURS) : k + NEIGHBOURS + 1]
        near = near[near != t]
        if near.size and area[t] < SMALL_AREA * np.median(area[near]):
            small[t] = True
    return edge, small, tuple(sides)


def frame_silhouettes(roi: RoiClip, *, scale: bool = True,
                      bring_back: tuple[int, ...] = ()) -> tuple[RoiClip, Framing]:
    """Crops at the animal's steady height, centred on its smoothed track.

    Parameters
    ----------
    roi : RoiClip
        Crops of one size centred on each frame's centre of mass (rows of the clip).
    scale : bool
        Scale and re-centre the crops (False: only name the partial frames).
    bring_back : tuple of int
        Rows the artist wants analysed although they look partial.

    Returns
    -------
    RoiClip
        The crops (uint8 grey levels when scaled, as area averaging leaves them), ``lost``
        set on every frame left out; ``centers_xy`` the smoothed track.
    Framing
    """
    lost = np.asarray(roi.lost, dtype=bool)
    edge, small, sides = partial_frames(roi)
    back = np.zeros(lost.size, dtype=bool)
    back[[t for t in bring_back if 0 <= t < lost.size]] = True
    edge &= ~back
    small &= ~back
    left_out = lost | edge | small
    kept = np.flatnonzero(~left_out)
    n = lost.size
    ones = np.ones(n)
    if kept.size < 3:
        return (replace(roi, lost=left_out),
                Framing(lost, edge, small, sides, ones, 1.0, np.zeros(n)))
    t = np.arange(n)
    window = longest_period(kept.size)
    trend = _log_height_trend(roi.crops, kept, window)
    centre = np.column_stack([np.interp(t, kept, roi.centers_xy[kept, k]) for k in range(2)])
    smooth = slow_trend(centre, window)
    travel = _travel(smooth[:, 0] * roi.scale, np.exp(trend))
    if not scale:
        return (replace(roi, lost=left_out),
                Framing(lost, edge, small, sides, ones, 1.0, travel))
    heights = np.exp(trend[kept])
    change = float(heights.max() / heights.min())
    steady = float(np.median(trend[kept]))
    factors = np.minimum(np.exp(steady - trend), MAX_UPSCALE) if change >= SCALE_CHANGE else ones
    shift = (smooth - centre) * roi.scale  # where the track's trend lies in each crop, px
    crops = _rescaled(roi.crops, factors, shift, left_out)
    centers = np.where(left_out[:, None], np.nan, smooth)
    return (replace(roi, crops=crops, centers_xy=centers, lost=left_out),
            Framing(lost, edge, small, sides, factors, change, travel))


def footage_travel(framing: Framing, start: int, stop: int) -> np.ndarray | None:
    """The animal's progress over frames ``start`` to ``stop`` (indices of ``framing``'s
    arrays) from the first of them, in its heights, always positive (the rig faces the way it
    walks): None when it moves by less than :data:`MIN_TRAVEL` heights."""
    travel = framing.travel[start:stop] - framing.travel[start]
    net = float(travel[-1]) if travel.size else 0.0
    return travel * np.sign(net) if abs(net) >= MIN_TRAVEL else None


def _travel(x: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """Progress of track ``x`` from its first frame, in the heights of the frames it was made
    in: each step divided by the mean of its two frames' heights (both in crop pixels)."""
    steps = np.diff(x) / (0.5 * (heights[1:] + heights[:-1]))
    return np.r_[0.0, np.cumsum(steps)]


def height_trend(roi: RoiClip) -> np.ndarray | None:
    """The slow trend of each frame's silhouette height in source pixels, over the frames
    where one was found and not much smaller than its neighbours' (None: fewer than three):
    how big the animal is on each frame, its legs' swing and its head's nod left out."""
    kept = _whole(roi)
    if kept.size < 3:
        return None
    trend = _log_height_trend(roi.crops, kept, longest_period(kept.size))
    return np.exp(trend) / roi.scale


def view_travel(roi: RoiClip) -> float:
    """The animal's net progress across the view over the frames :func:`frame_silhouettes`
    keeps, in its own heights (:attr:`Framing.travel`; positive to the right, 0 with fewer
    than three kept)."""
    framed, framing = frame_silhouettes(roi, scale=False)
    kept = np.flatnonzero(~framed.lost)
    return float(framing.travel[kept[-1]] - framing.travel[kept[0]]) if kept.size >= 3 else 0.0


def _whole(roi: RoiClip) -> np.ndarray:
    """Frames with a silhouette not much smaller than its neighbours'."""
    _, small, _ = partial_frames(roi)
    return np.flatnonzero(~(np.asarray(roi.lost, dtype=bool) | small))


def _log_height_trend(crops: np.ndarray, kept: np.ndarray, window: int) -> np.ndarray:
    """:func:`~gaitcore.analysis.rhythm.slow_trend` of the log of the rows each crop's
    silhouette spans, interpolated over the frames not ``kept`` (crop pixels)."""
    rows_spanned = _heights(crops)
    t = np.arange(crops.shape[0])
    log_h = np.interp(t, kept, np.log(np.maximum(rows_spanned[kept], 1.0)))
    return slow_trend(log_h, window)


def _heights(crops: np.ndarray) -> np.ndarray:
    """Rows spanned by each crop's silhouette (0 where empty)."""
    rows = np.asarray(crops).reshape(crops.shape[0], crops.shape[1], -1).any(axis=2)
    first = np.argmax(rows, axis=1)
    last = rows.shape[1] - 1 - np.argmax(rows[:, ::-1], axis=1)
    return np.where(rows.any(axis=1), last - first + 1, 0).astype(float)


def _rescaled(crops: np.ndarray, factors: np.ndarray, shift: np.ndarray,
              left_out: np.ndarray) -> np.ndarray:
    """Each crop enlarged by its factor about the point ``shift`` from its centre (the
    track's trend), that point put at the centre of a window large enough for them all
    (grown by the largest shift, so that no silhouette is cut)."""
    n, rows, cols = crops.shape
    top = float(factors[~left_out].max())
    reach_x, reach_y = np.abs(shift[~left_out]).max(axis=0)
    out_rows = int(np.ceil((rows + 2 * reach_y) * top))
    out_cols = int(np.ceil((cols + 2 * reach_x) * top))
    out = np.zeros((n, out_rows, out_cols), dtype=np.uint8)
    for t in np.flatnonzero(~left_out):
        f = float(factors[t])
        # source point (cols/2 + dx, rows/2 + dy) -> window centre; scale f about it
        cx, cy = cols / 2.0 + shift[t, 0], rows / 2.0 + shift[t, 1]
        warp = np.array([[f, 0.0, out_cols / 2.0 - f * cx], [0.0, f, out_rows / 2.0 - f * cy]])
        interpolation = cv2.INTER_AREA if f < 1.0 else cv2.INTER_LINEAR
        out[t] = cv2.warpAffine(crops[t].astype(np.uint8) * np.uint8(255), warp,
                                (out_cols, out_rows), flags=interpolation)
    return out


HEIGHT_NOTE = 1.15
"""A change of the silhouette's height (largest over smallest of its trend) from which the
advice says that the crops were scaled."""


def framing_notes(framing: Framing, first_frame: int = 0) -> tuple[str, ...]:
    """What the framing did, in sentences for an artist (frames numbered from
    ``first_frame``): the height change it evened out, the frames it left out."""
    notes = []
    if framing.height_change >= HEIGHT_NOTE:
        notes.append(f"The animal's height changes {framing.height_change:.1f}-fold over the "
                     "clip (it walks away from or towards the camera at an angle): its "
                     "silhouettes are compared at a steady size.")
    for frames, why in ((framing.edge, "the animal is only partly in view (it touches the "
                         + " and ".join(f"{side} side" for side in framing.sides)
                         + " of the frame)"),
                        (framing.small & ~framing.edge, "the silhouette is much smaller than "
                         "in the frames around (part of the animal is lost)")):
        runs = [(lo + first_frame, hi - 1 + first_frame) for lo, hi in true_runs(frames)]
        if runs:
            notes.append(f"{_frames_text(runs)}: {why}; left out.")
    return tuple(notes)


def _frames_text(runs: list[tuple[int, int]]) -> str:
    """"Frames 0-7 and 58-70", "Frame 12"."""
    parts = [f"{a}" if a == b else f"{a}-{b}" for a, b in runs]
    head = "Frame" if len(runs) == 1 and runs[0][0] == runs[0][1] else "Frames"
    body = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    return f"{head} {body}"
