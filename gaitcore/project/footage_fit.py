"""Where the key-image goes in the 3D viewport so that the animal roughly overlaps the skeleton.

The footage is a plane in gaitcore's XY plane, behind the skeleton (negative Z, away from the
side camera). Its scale makes the height of the animal in the shown frame (the slow trend of
its silhouette's height, :func:`gaitcore.analysis.framing.height_trend`, so that an animal
walking away keeps the rig's size on every frame) equal to the skeleton's rest height, and
the silhouette's centre of mass in the shown frame (the ROI centre, paper Section 2.2) lands
on the skeleton's centre (area-weighted centre of its bone
ellipsoids seen from the side); the project's :class:`~gaitcore.project.document.FootageFit`
corrects that placement (scale about the anchor, shift, mirror). Only the part of the frame
around the subject is uploaded, shrunk to at most :data:`MAX_TEXTURE_SIDE` pixels.

:func:`fit_rig` does both fits from the key-image's silhouette: the rig's proportions
(:mod:`gaitcore.rig.silhouette_fit`) and the footage's size and place that put the
silhouette on the proportioned rig.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gaitcore.analysis.framing import MIN_TRAVEL, height_trend, view_travel
from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress
from gaitcore.project.document import FootageFit, Silhouettes
from gaitcore.rig.proportions import RigProportions, proportioned
from gaitcore.rig.silhouette_fit import ProportionsFit, fit_proportions
from gaitcore.rig.skeleton import Skeleton

MAX_TEXTURE_SIDE = 512
CONTEXT = 1.6
"""The uploaded crop is the ROI window grown by this factor (clipped to the frame)."""
PLANE_GAP_M = 0.25
WASH_OUT = 0.4
"""Share of white mixed into the footage, so the skeleton stands out in front of it."""
FALLBACK_HEIGHT_SHARE = 0.6
"""Without silhouettes, the skeleton is assumed to fill this share of the frame height."""


def travel_direction(silhouettes: Silhouettes) -> int:
    """Which way the animal crosses the view: +1 to the right, -1 to the left, 0 when it
    moves by less than :data:`~gaitcore.analysis.framing.MIN_TRAVEL` of its heights over the
    clip (it stays in place, or the camera follows it)."""
    travel = view_travel(silhouettes.roi)
    return 0 if abs(travel) < MIN_TRAVEL else int(np.sign(travel))


def facing_travel(fit: FootageFit, silhouettes: Silhouettes) -> FootageFit:
    """``fit`` mirrored when the animal walks to the left: the rig faces +X, the way it walks
    once the footage behind it is mirrored. A fit the artist changed is kept as it is."""
    if fit != FootageFit() or travel_direction(silhouettes) >= 0:
        return fit
    return FootageFit(flip=True)


@dataclass(frozen=True)
class SkeletonExtent:
    """Side-view size of a skeleton at rest, metres (gaitcore frame)."""

    center_xy: tuple[float, float]
    height_m: float
    depth_m: float
    """Half its extent along Z (towards the side camera)."""
    length_m: float
    """Its extent along X (the direction of travel)."""
    box_center_xy: tuple[float, float]
    """Centre of its side-view bounding box (where cameras look)."""


def skeleton_extent(skeleton: Skeleton) -> SkeletonExtent:
    """Area-weighted centre and height of the bone ellipsoids of ``skeleton`` at rest."""
    world = skeleton.forward_kinematics(skeleton.rest_pose())
    bones = skeleton.bone_ellipsoids()
    if not bones:
        pos = world[:, :3, 3]
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        return SkeletonExtent(((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2),
                              float(max(hi[1] - lo[1], 0.5)), float(max(hi[2], -lo[2], 0.1)),
                              float(max(hi[0] - lo[0], 0.5)),
                              ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2))
    boxes = [b.world_box(world) for b in bones]
    c, e = np.array([centre for centre, _ in boxes]), np.array([half for _, half in boxes])
    a = np.array([b.radii[0] * b.radii[1] for b in bones])
    centre = (a[:, None] * c).sum(axis=0) / a.sum()
    top, bottom = (c[:, 1] + e[:, 1]).max(), (c[:, 1] - e[:, 1]).min()
    depth = float(np.abs(np.r_[c[:, 2] + e[:, 2], c[:, 2] - e[:, 2]]).max())
    left, right = (c[:, 0] - e[:, 0]).min(), (c[:, 0] + e[:, 0]).max()
    return SkeletonExtent((float(centre[0]), float(centre[1])), float(top - bottom), depth,
                          float(right - left), (float(left + right) / 2, float(top + bottom) / 2))


def travel_metres(travel: np.ndarray | None, skeleton: Skeleton,
                  fit: FootageFit = FootageFit()) -> np.ndarray | None:
    """The animal's progress in the footage (in its own heights, :attr:`Analysis.travel`) in
    the rig's metres: the viewport's placement makes the animal's height on every frame the
    rig's side-view height times the fit's scale, so a height of travel is that many metres."""
    if travel is None:
        return None
    return np.asarray(travel, float) * skeleton_extent(skeleton).height_m * fit.scale


def silhouette_heights_px(silhouettes: Silhouettes) -> np.ndarray | None:
    """The animal's height on each frame in source pixels (None: too few silhouettes)."""
    return height_trend(silhouettes.roi)


@dataclass(frozen=True)
class ReferenceImage:
    """A texture for ``GLImageItem`` and its placement.

    Attributes
    ----------
    rgba_xy : ndarray of shape (w, h, 4), uint8
        Indexed (x, y) with y up, as GLImageItem wants it.
    transform : ndarray of shape (4, 4)
        Texel -> gaitcore world (metres).
    pixel_to_world : ndarray of shape (3, 3)
        Source pixel (u, v, 1) -> gaitcore world (x, y, z) on the plane, metres, to draw
        anything measured on the frame (the silhouette's outline) over the footage.
    """

    rgba_xy: np.ndarray
    transform: np.ndarray
    pixel_to_world: np.ndarray


def reference_image(bgr: np.ndarray, frame: int, skeleton: SkeletonExtent,
                    silhouettes: Silhouettes | None, *, fit: FootageFit = FootageFit(),
                    heights_px: np.ndarray | None = None) -> ReferenceImage:
    """Crop, shrink and place footage frame ``bgr`` (source pixels) behind the skeleton.

    Parameters
    ----------
    bgr : ndarray of shape (H, W, 3) or (H, W)
    frame : int
        Clip frame of ``bgr`` (its silhouette gives the anchor).
    skeleton : SkeletonExtent
    silhouettes : Silhouettes or None
    fit : FootageFit
        The artist's correction of the automatic placement: scale about the anchor, shift,
        left-right mirror (for an animal moving towards -X in the clip).
    heights_px : ndarray, optional
        :func:`silhouette_heights_px` of ``silhouettes``, when already computed.
    """
    img = np.asarray(bgr)
    if img.dtype == bool:
        img = img.astype(np.uint8) * 255
    if img.ndim == 2:
        img = cv2.cvtColor(img.astype(np.uint8), cv2.COLOR_GRAY2BGR)
    rows, cols = img.shape[:2]
    (u0, v0), metres_per_px, window = _anchor(frame, skeleton, silhouettes, (cols, rows),
                                              heights_px)
    if window is not None:
        x, y, w, h = window
        cx, cy, w, h = x + w / 2, y + h / 2, w * CONTEXT, h * CONTEXT
        x0, x1 = int(max(0, cx - w / 2)), int(min(cols, cx + w / 2))
        y0, y1 = int(max(0, cy - h / 2)), int(min(rows, cy + h / 2))
    else:
        x0, x1, y0, y1 = 0, cols, 0, rows
    if x1 - x0 < 2 or y1 - y0 < 2:
        x0, x1, y0, y1 = 0, cols, 0, rows
    crop = img[y0:y1, x0:x1]
    texel_px = max(1.0, max(crop.shape[:2]) / MAX_TEXTURE_SIDE)
    if texel_px > 1.0:
        size = (max(2, round(crop.shape[1] / texel_px)), max(2, round(crop.shape[0] / texel_px)))
        crop = cv2.resize(crop, size, interpolation=cv2.INTER_AREA)
        texel_px = (x1 - x0) / size[0]
    rgba = np.empty(crop.shape[:2] + (4,), np.uint8)
    rgba[..., :3] = crop[..., ::-1] * (1 - WASH_OUT) + 255 * WASH_OUT
    rgba[..., 3] = 255
    data = np.ascontiguousarray(rgba[::-1].transpose(1, 0, 2))
    sign = -1.0 if fit.flip else 1.0
    s, t = metres_per_px * fit.scale, texel_px
    tex_h = crop.shape[0]
    X0, Y0 = skeleton.center_xy[0] + fit.offset_x_m, skeleton.center_xy[1] + fit.offset_y_m
    transform = np.array([
        [sign * t * s, 0, 0, X0 + sign * (x0 - u0) * s],
        [0, t * s, 0, Y0 - (y0 + tex_h * t - v0) * s],
        [0, 0, 1, -(skeleton.depth_m + PLANE_GAP_M)],
        [0, 0, 0, 1.0],
    ])
    pixel_to_world = np.array([[sign * s, 0, X0 - sign * u0 * s],
                               [0, -s, Y0 + v0 * s],
                               [0, 0, transform[2, 3]]])
    return ReferenceImage(data, transform, pixel_to_world)


def _anchor(frame: int, skeleton: SkeletonExtent, silhouettes: Silhouettes | None,
            size: tuple[int, int], heights_px: np.ndarray | None):
    """The source pixel that lands on the skeleton's centre, the metres per source pixel of
    the automatic placement, and the ROI window of ``frame`` (None when it has none)."""
    cols, rows = size
    window = (silhouettes.window_xywh(frame)
              if silhouettes is not None and frame < silhouettes.n_frames else None)
    if heights_px is None and silhouettes is not None:
        heights_px = silhouette_heights_px(silhouettes)
    if window is not None and heights_px is not None:
        u0, v0 = (float(v) for v in silhouettes.roi.centers_xy[frame])
        return (u0, v0), skeleton.height_m / float(heights_px[frame]), window
    return (cols / 2, rows / 2), skeleton.height_m / (FALLBACK_HEIGHT_SHARE * rows), None


def footage_from_world(frame: int, skeleton: SkeletonExtent, silhouettes: Silhouettes | None,
                       size: tuple[int, int], *, fit: FootageFit = FootageFit(),
                       heights_px: np.ndarray | None = None) -> np.ndarray:
    """The affine map from the skeleton's side view (world X, Y in metres) to source pixels
    of frame ``frame``: the inverse of the placement of :func:`reference_image`, so that a
    skeleton drawn with it sits on the footage as it does in the 3D viewport.

    Parameters
    ----------
    frame : int
        Source frame (its silhouette gives the anchor).
    skeleton : SkeletonExtent
    silhouettes : Silhouettes or None
    size : (int, int)
        Width and height of the frame, pixels.
    fit : FootageFit
    heights_px : ndarray, optional
        :func:`silhouette_heights_px` of ``silhouettes``, when already computed.

    Returns
    -------
    ndarray of shape (2, 3)
        ``[u, v] = A @ [X, Y, 1]``.
    """
    (u0, v0), metres_per_px, _ = _anchor(frame, skeleton, silhouettes, size, heights_px)
    s = metres_per_px * fit.scale
    sign = -1.0 if fit.flip else 1.0
    x0, y0 = skeleton.center_xy[0] + fit.offset_x_m, skeleton.center_xy[1] + fit.offset_y_m
    return np.array([[sign / s, 0.0, u0 - sign * x0 / s],
                     [0.0, -1.0 / s, v0 + y0 / s]])


def footage_maps(frames: list[int] | range, skeleton: Skeleton, silhouettes: Silhouettes | None,
                 size: tuple[int, int], fit: FootageFit = FootageFit()) -> np.ndarray:
    """:func:`footage_from_world` of each of ``frames`` (source frames), shape (n, 2, 3): what
    :func:`gaitcore.io.export.write_preview_video` needs to draw the skeleton over the footage."""
    extent = skeleton_extent(skeleton)
    heights = silhouette_heights_px(silhouettes) if silhouettes is not None else None
    return np.stack([footage_from_world(f, extent, silhouettes, size, fit=fit, heights_px=heights)
                     for f in frames])


def silhouette_outline_px(silhouettes: Silhouettes, frame: int) -> list[np.ndarray]:
    """Outlines of the silhouette of ``frame`` in source pixels, [] where it is lost.

    Returns
    -------
    list of ndarray of shape (n, 2)
        One closed polyline (x, y) per outer boundary of the mask, first point not repeated.
    """
    window = silhouettes.window_xywh(frame) if 0 <= frame < silhouettes.n_frames else None
    if window is None:
        return []
    mask = np.ascontiguousarray(silhouettes.roi.crops[frame], dtype=np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    scale = silhouettes.roi.scale
    return [np.asarray(window[:2]) + (c[:, 0, :].astype(float) + 0.5) / scale
            for c in contours if len(c) >= 3]


@dataclass(frozen=True)
class RigFit:
    """The rig and the footage fitted to one key-image's silhouette.

    Attributes
    ----------
    proportions : RigProportions
    footage_fit : FootageFit
        Puts the silhouette on the rig in those proportions, in the viewport's placement.
    measures : ProportionsFit
        Overlap and the fitted rig's body length, height at the withers and leg length.
    """

    proportions: RigProportions
    footage_fit: FootageFit
    measures: ProportionsFit


def fit_rig(template: Skeleton, pose: np.ndarray, silhouettes: Silhouettes, frame: int, *,
            start: RigProportions = RigProportions(), flip: bool = False,
            progress: Progress | None = None) -> RigFit:
    """Fit the rig's part scales and the footage's placement to the silhouette of ``frame``.

    Parameters
    ----------
    template : Skeleton
        The rig before proportions.
    pose : ndarray of shape (k,)
        Its pose on ``frame`` (the key's pose, or the rest pose).
    silhouettes : Silhouettes
    frame : int
    start : RigProportions
        The proportions the search starts from (the body scale is kept: the reference).
    flip : bool
        The animal moves to the left in the clip (the footage is mirrored).
    progress : callable(done, total) -> bool, optional

    Raises
    ------
    GaitInputError
        ``frame`` has no silhouette, or the fit is poor
        (:meth:`~gaitcore.rig.silhouette_fit.ProportionsFit.problems`): nothing is fitted.
    """
    window = silhouettes.window_xywh(frame) if 0 <= frame < silhouettes.n_frames else None
    heights = silhouette_heights_px(silhouettes)
    if window is None or heights is None:
        raise GaitInputError(f"frame {frame} has no silhouette: segment or sketch it, or fit "
                             "the rig on another key")
    crop = silhouettes.roi.crops[frame]
    fit = fit_proportions(crop[:, ::-1] if flip else crop, template, pose, start=start,
                          progress=progress)
    problems = fit.problems()
    if problems:
        raise GaitInputError(
            f"the rig does not fit frame {frame} ({'; '.join(problems)}): the rig is left as it "
            "was; check the silhouette of this frame, pose the key roughly, or fit on another "
            "key")
    rig = proportioned(template, fit.proportions)
    extent = skeleton_extent(rig)
    k = silhouettes.roi.scale
    cx, cy = silhouettes.roi.centers_xy[frame]
    col, row = (cx - window[0]) * k - 0.5, (cy - window[1]) * k - 0.5  # the anchor in the crop
    if flip:
        col = crop.shape[1] - 1 - col
    anchor = np.array([col - fit.origin_px[0], fit.origin_px[1] - row]) * fit.metres_per_px
    lift = rig.offsets[0, 1] - template.offsets[0, 1]  # the fit posed the template's root
    follow = rig.joint_positions(pose)[0, 0] - rig.offsets[0, 0]  # the viewport follows the root
    footage = FootageFit(scale=fit.metres_per_px * k * float(heights[frame]) / extent.height_m,
                         offset_x_m=float(anchor[0] - extent.center_xy[0] - follow),
                         offset_y_m=float(anchor[1] + lift - extent.center_xy[1]), flip=flip)
    return RigFit(fit.proportions, footage, fit)
