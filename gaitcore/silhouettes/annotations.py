"""Plain data of a Gait Studio project: rectangles drawn on frames, sketch strokes and brush
strokes, and their checks against a clip.

Values are frozen dataclasses of numbers and numpy arrays, never Qt types: an edit makes a
new value, so undo only swaps the before and after values.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gaitcore.errors import GaitInputError


def _is_whole(value: object) -> bool:
    """True for a whole number that fits a float (``3``, ``3.0``; not ``1e400`` or ``"3"``)."""
    try:
        return float(value).is_integer()
    except (TypeError, ValueError, OverflowError):
        return False


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in pixels: columns ``x .. x+w-1``, rows ``y .. y+h-1``.

    Attributes
    ----------
    x, y : int
        Top-left corner (column, row); may be negative before clipping.
    w, h : int
        Width and height, both positive.

    Raises
    ------
    GaitInputError
        When ``w`` or ``h`` is not positive.

    Notes
    -----
    The artist draws such rectangles over the subject and the background on the first frame
    to seed the colour models (paper Section 2.2).
    """

    x: int
    y: int
    w: int
    h: int

    def __post_init__(self) -> None:
        for name in ("x", "y", "w", "h"):
            value = getattr(self, name)
            if isinstance(value, bool) or not _is_whole(value):
                raise GaitInputError(f"rectangle {name}={value!r} is not a whole number of pixels")
            object.__setattr__(self, name, int(value))
        if self.w <= 0 or self.h <= 0:
            raise GaitInputError(
                f"rectangle {self.as_tuple()} is empty: width and height must be positive"
            )

    @classmethod
    def from_corners(cls, x0: float, y0: float, x1: float, y1: float) -> Rect:
        """Rectangle spanning two opposite corners given in any order (as dragged)."""
        ax, bx = sorted((int(round(x0)), int(round(x1))))
        ay, by = sorted((int(round(y0)), int(round(y1))))
        return cls(ax, ay, bx - ax, by - ay)

    @classmethod
    def parse(cls, text: str) -> Rect:
        """Parse ``"x,y,w,h"`` (the command line's format)."""
        parts = text.replace(" ", "").split(",")
        try:
            values = [int(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != 4:
            raise GaitInputError(f"rectangle {text!r} is not four integers x,y,w,h")
        return cls(*values)

    def as_tuple(self) -> tuple[int, int, int, int]:
        return self.x, self.y, self.w, self.h

    @property
    def area(self) -> int:
        return self.w * self.h

    def clipped_to(self, width: int, height: int) -> Rect:
        """The part of this rectangle inside a ``width`` x ``height`` frame.

        Raises
        ------
        GaitInputError
            When the rectangle lies entirely outside the frame.
        """
        x0, y0 = max(self.x, 0), max(self.y, 0)
        x1, y1 = min(self.x + self.w, int(width)), min(self.y + self.h, int(height))
        if x1 <= x0 or y1 <= y0:
            raise GaitInputError(
                f"rectangle {self.as_tuple()} lies outside the {width}x{height} frame: "
                "draw it over the image"
            )
        return Rect(x0, y0, x1 - x0, y1 - y0)

    def slices(self) -> tuple[slice, slice]:
        """``(rows, cols)`` slices selecting the rectangle in an image array."""
        return slice(self.y, self.y + self.h), slice(self.x, self.x + self.w)


MAX_STROKE_POINTS = 100_000
"""Points one stroke may hold (a stroke drawn for a minute at the screen's rate holds a few
thousand)."""
MAX_STROKE_WIDTH_PX = 1000.0
"""The widest stroke, pixels (OpenCV refuses thicker lines)."""
MAX_COORDINATE_PX = 1e6
"""The farthest a stroke's point may lie from the frame's origin, pixels."""


@dataclass(frozen=True, eq=False)
class Stroke:
    """One sketched polyline, drawn white on black to stand for a part of the animal.

    Attributes
    ----------
    points_xy : ndarray of shape (k, 2), float64
        Vertices in full-frame pixel coordinates (x, y); read-only copy of the input.
    width_px : float
        Pen width in pixels (positive).
    frame : int
        Clip frame (0-based) the stroke belongs to.

    Raises
    ------
    GaitInputError
        For points that are not a non-empty finite (k, 2) array, a non-positive width or a
        negative frame.

    Notes
    -----
    Paper Section 2.2: where segmentation fails the artist sketches the spine, legs and head
    with rough strokes; the rasterized strokes replace the binary silhouette.
    """

    points_xy: np.ndarray
    width_px: float
    frame: int

    def __post_init__(self) -> None:
        pts = np.array(self.points_xy, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] == 0:
            raise GaitInputError(
                f"stroke points must be an array of shape (k, 2) with k >= 1, got {pts.shape}"
            )
        if not np.isfinite(pts).all() or np.abs(pts).max() > MAX_COORDINATE_PX:
            raise GaitInputError(f"stroke points must be finite numbers of pixels, at most "
                                 f"{MAX_COORDINATE_PX:g} from the origin")
        if pts.shape[0] > MAX_STROKE_POINTS:
            raise GaitInputError(f"a stroke holds {pts.shape[0]} points, more than the "
                                 f"{MAX_STROKE_POINTS} one can: split it")
        width = float(self.width_px)
        if not 0 < width <= MAX_STROKE_WIDTH_PX:
            raise GaitInputError(f"stroke width must be a number of pixels in (0, "
                                 f"{MAX_STROKE_WIDTH_PX:g}], got {self.width_px}")
        if int(self.frame) != self.frame or self.frame < 0:
            raise GaitInputError(f"stroke frame must be a non-negative integer, got {self.frame}")
        pts.flags.writeable = False
        object.__setattr__(self, "points_xy", pts)
        object.__setattr__(self, "width_px", width)
        object.__setattr__(self, "frame", int(self.frame))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Stroke):
            return NotImplemented
        return (self.frame == other.frame and self.width_px == other.width_px
                and np.array_equal(self.points_xy, other.points_xy))

    __hash__ = None  # type: ignore[assignment]

    def moved(self, points_xy: np.ndarray, frame: int | None = None) -> Stroke:
        """A copy with new points (and optionally another frame), same width."""
        return Stroke(points_xy, self.width_px, self.frame if frame is None else frame)


SCRIBBLE_LABELS = ("subject", "background")


@dataclass(frozen=True, eq=False)
class Scribble(Stroke):
    """A corrective stroke: "this is the subject" or "this is background" on one frame.

    Attributes
    ----------
    label : {"subject", "background"}
        What the pixels under the stroke are; the graph cut of that frame takes them as hard
        labels (beyond the paper's Section 2.2, after After Effects' Roto Brush).

    Raises
    ------
    GaitInputError
        As :class:`Stroke`, and for an unknown label.
    """

    label: str = "subject"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.label not in SCRIBBLE_LABELS:
            raise GaitInputError(f"unknown scribble label {self.label!r}: use 'subject' or "
                                 "'background'")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Scribble):
            return NotImplemented
        return self.label == other.label and Stroke.__eq__(self, other)

    __hash__ = None  # type: ignore[assignment]

    def moved(self, points_xy: np.ndarray, frame: int | None = None) -> Scribble:
        """A copy with new points (and optionally another frame), same width and label."""
        return Scribble(points_xy, self.width_px, self.frame if frame is None else frame,
                        self.label)


def check_start(box: Rect | None, subject_rects: Sequence[Rect],
                background_rects: Sequence[Rect], scribbles: Sequence[Scribble]) -> None:
    """Raise GaitInputError when frame 0 has nothing to be cut from."""
    if box is None and not any(sc.frame == 0 and sc.label == "subject" for sc in scribbles):
        if not subject_rects:
            raise GaitInputError("no box and no subject rectangle given: draw a box around "
                                 "the subject on the first frame (--box x,y,w,h)")
        if not background_rects:
            raise GaitInputError("no background rectangle given: draw at least one on the "
                                 "first frame, or a box around the subject instead")


def check_scribbles(scribbles: Sequence[Scribble], n_frames: int,
                    shape: tuple[int, int]) -> None:
    """Raise GaitInputError for a scribble outside the clip or entirely outside the frame."""
    rows, cols = shape
    for sc in scribbles:
        if not 0 <= sc.frame < n_frames:
            raise GaitInputError(f"a {sc.label} scribble is on frame {sc.frame} but the clip has "
                                 f"{n_frames} frames (0..{n_frames - 1}): move or delete it")
        p = sc.points_xy
        if (p[:, 0].max() < 0 or p[:, 1].max() < 0 or p[:, 0].min() >= cols
                or p[:, 1].min() >= rows):
            raise GaitInputError(f"a {sc.label} scribble on frame {sc.frame} lies outside the "
                                 f"{cols}x{rows} frame: draw it over the image")
