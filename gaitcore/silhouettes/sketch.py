"""Sketched silhouettes: strokes drawn white on black where segmentation fails (paper 2.2).

The artist draws rough strokes over the spine, legs and head of the animal, frame by frame.
Rasterized, they replace the segmented silhouette and enter the same fixed-window ROI
pipeline (:class:`gaitcore.silhouettes.tracking.RoiAccumulator`). To spare the artist from redrawing
every frame, strokes can be copied to the next frame (:func:`carry_strokes`) or moved there by
optical flow (:func:`propagate_strokes`), leaving only corrections to draw.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.silhouettes.annotations import Stroke
from gaitcore.silhouettes.tracking import WORK_SIDE_PX, RoiAccumulator, RoiClip

_SHIFT = 4  # fixed-point bits of the vertex coordinates given to OpenCV (1/16 pixel)
FLOW_MARGIN_PX = 64  # optical flow is computed in the strokes' bounding box grown by this


def rasterize_strokes(strokes: Iterable[Stroke], shape: tuple[int, int]) -> np.ndarray:
    """Draw strokes white on black, without anti-aliasing.

    Parameters
    ----------
    strokes : iterable of Stroke
        All are drawn, whatever their ``frame`` (select them first, e.g. with
        :func:`strokes_of_frame`).
    shape : (rows, cols)
        Size of the frame.

    Returns
    -------
    ndarray of shape (rows, cols), uint8
        255 under the strokes, 0 elsewhere.

    Notes
    -----
    Paper Section 2.2 ("white strokes on a black background create the binary image").
    Lines are ``cv2.polylines`` of thickness ``round(width_px)`` (OpenCV draws thick lines
    up to two pixels wider than that); a stroke of one point is a dot of the pen's width.
    """
    rows, cols = (int(v) for v in shape)
    if rows <= 0 or cols <= 0:
        raise GaitInputError(f"frame shape must be positive (rows, cols), got {shape}")
    out = np.zeros((rows, cols), np.uint8)
    scale = float(1 << _SHIFT)
    for s in strokes:
        pts = np.round(s.points_xy * scale).astype(np.int32)
        width = max(1, int(round(s.width_px)))
        if len(pts) == 1:
            radius = int(round(width / 2 * scale))
            cv2.circle(out, tuple(int(v) for v in pts[0]), radius, 255, -1, cv2.LINE_8, _SHIFT)
        else:
            cv2.polylines(out, [pts.reshape(-1, 1, 2)], False, 255, width, cv2.LINE_8, _SHIFT)
    return out


def strokes_of_frame(strokes: Iterable[Stroke], frame: int) -> list[Stroke]:
    """The strokes drawn on clip frame ``frame``, in their original order."""
    return [s for s in strokes if s.frame == frame]


def sketch_masks(
    strokes: Sequence[Stroke], n_frames: int, shape: tuple[int, int]
) -> Iterator[np.ndarray]:
    """Rasterized sketches of frames 0 .. n_frames-1, one at a time.

    Parameters
    ----------
    strokes : sequence of Stroke
        Strokes of any frames of the clip.
    n_frames : int
        Length of the clip.
    shape : (rows, cols)
        Frame size.

    Yields
    ------
    ndarray of shape (rows, cols), uint8
        0/255 mask of each frame in order (all zeros where nothing is drawn).

    Raises
    ------
    GaitInputError
        When a stroke belongs to a frame outside the clip.

    Notes
    -----
    Paper Section 2.2: sketches stand for the segmented silhouettes.
    """
    by_frame: dict[int, list[Stroke]] = {}
    for s in strokes:
        if s.frame >= n_frames:
            raise GaitInputError(
                f"a stroke is on frame {s.frame} but the clip has {n_frames} frames: delete it"
            )
        by_frame.setdefault(s.frame, []).append(s)
    for t in range(n_frames):
        yield rasterize_strokes(by_frame.get(t, ()), shape)


def crop_sketches(
    strokes: Sequence[Stroke],
    n_frames: int,
    shape: tuple[int, int],
    *,
    margin: float = 0.05,
    max_side: int | None = WORK_SIDE_PX,
    progress: Progress | None = None,
) -> RoiClip:
    """Sketches of a clip as fixed-size ROI crops, like segmented silhouettes.

    Parameters
    ----------
    strokes : sequence of Stroke
        Strokes of any frames of the clip.
    n_frames : int
        Length of the clip.
    shape : (rows, cols)
        Frame size.
    margin, max_side, progress
        As in :func:`gaitcore.silhouettes.tracking.crop_rois` (but ``max_side`` defaults to
        :data:`~gaitcore.silhouettes.tracking.WORK_SIDE_PX`, the PCA working size, as for
        segmentation).

    Returns
    -------
    RoiClip
        Frames without strokes are flagged in ``lost`` (not filled in).

    Raises
    ------
    GaitInputError
        When no frame has a stroke, or a stroke lies outside the clip.

    Notes
    -----
    Paper Section 2.2: the window is centred on the centre of mass of the whole sketch of
    each frame (every stroke counts, touching or not) and has one size per clip, as for
    segmented silhouettes. Masks are made one frame at a time, so memory does not grow with
    the clip's length.
    """
    acc = RoiAccumulator()
    for t, mask in enumerate(sketch_masks(strokes, n_frames, shape)):
        x, y, w, h = cv2.boundingRect(mask)
        if w == 0:
            acc.add_lost()
        else:
            m = cv2.moments(mask, binaryImage=True)
            acc.add(mask[y : y + h, x : x + w] > 0, np.array([x, y, w, h]),
                    np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]), frame_shape=shape)
        report(progress, t + 1, n_frames, "sketch cropping cancelled")
    return acc.finish(margin=margin, max_side=max_side)


def carry_strokes(strokes: Iterable[Stroke], to_frame: int) -> list[Stroke]:
    """Copy strokes to another frame, as a starting point for the artist there.

    Parameters
    ----------
    strokes : iterable of Stroke
    to_frame : int
        Clip frame of the copies (usually the next one).

    Returns
    -------
    list of Stroke
        Same points and widths, ``frame == to_frame``; the inputs are unchanged.
    """
    return [s.moved(s.points_xy, frame=to_frame) for s in strokes]


def propagate_strokes(
    strokes: Sequence[Stroke],
    frame_a_bgr: np.ndarray,
    frame_b_bgr: np.ndarray,
    *,
    to_frame: int | None = None,
) -> list[Stroke]:
    """Move strokes drawn on frame A to frame B by dense optical flow.

    Parameters
    ----------
    strokes : sequence of Stroke
        Strokes of frame A.
    frame_a_bgr, frame_b_bgr : ndarray of shape (rows, cols, 3) or (rows, cols), uint8
        The two frames (colour or grey).
    to_frame : int, optional
        Frame index of the new strokes (default: each stroke's frame + 1).

    Returns
    -------
    list of Stroke
        Same widths, points displaced by the flow from A to B sampled (bilinearly) under them.

    Raises
    ------
    GaitInputError
        When the frames differ in size or are not 8-bit images.

    Notes
    -----
    Goes beyond the paper's per-frame sketching (Section 2.2): the artist corrects moved
    strokes instead of redrawing them. Uses OpenCV's DIS optical flow (medium preset) in the
    strokes' bounding box grown by ``FLOW_MARGIN_PX``; points are kept inside the frame.
    """
    a, b = _grey(frame_a_bgr, "frame A"), _grey(frame_b_bgr, "frame B")
    if a.shape != b.shape:
        raise GaitInputError(f"frames A {a.shape} and B {b.shape} differ in size: give two "
                             "frames of the same clip")
    strokes = list(strokes)
    if not strokes:
        return []
    rows, cols = a.shape
    allpts = np.concatenate([s.points_xy for s in strokes])
    x0 = int(np.clip(np.floor(allpts[:, 0].min()) - FLOW_MARGIN_PX, 0, cols - 1))
    y0 = int(np.clip(np.floor(allpts[:, 1].min()) - FLOW_MARGIN_PX, 0, rows - 1))
    x1 = int(np.clip(np.ceil(allpts[:, 0].max()) + FLOW_MARGIN_PX + 1, x0 + 1, cols))
    y1 = int(np.clip(np.ceil(allpts[:, 1].max()) + FLOW_MARGIN_PX + 1, y0 + 1, rows))
    flow = _dis_flow(a[y0:y1, x0:x1], b[y0:y1, x0:x1])
    out = []
    for s in strokes:
        local = (s.points_xy - [x0, y0]).astype(np.float32)
        dxy = cv2.remap(flow, local[:, 0].reshape(1, -1), local[:, 1].reshape(1, -1),
                        cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)[0]
        moved = np.clip(s.points_xy + dxy, [0, 0], [cols - 1, rows - 1])
        out.append(s.moved(moved, frame=s.frame + 1 if to_frame is None else to_frame))
    return out


def _dis_flow(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """DIS optical flow from ``a`` to ``b``, shape (rows, cols, 2) float32 (dx, dy)."""
    if min(a.shape) < 16:  # too small for DIS's patches: pad with edge pixels
        pad = ((0, max(0, 16 - a.shape[0])), (0, max(0, 16 - a.shape[1])))
        return _dis_flow(np.pad(a, pad, mode="edge"), np.pad(b, pad, mode="edge"))[
            : a.shape[0], : a.shape[1]
        ]
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    # OpenCV refuses non-contiguous views such as the crops taken above.
    return dis.calc(np.ascontiguousarray(a), np.ascontiguousarray(b), None)


def _grey(img: np.ndarray, what: str) -> np.ndarray:
    arr = np.asarray(img)
    if arr.dtype != np.uint8 or arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] != 3):
        raise GaitInputError(
            f"{what} must be an 8-bit grey or BGR image, got {arr.shape} {arr.dtype}: "
            "pass frames as read from the clip"
        )
    return cv2.cvtColor(arr, cv2.COLOR_BGR2GRAY) if arr.ndim == 3 else np.ascontiguousarray(arr)
