"""Export of animation curves, picked by file suffix, and a side-by-side preview video.

``EXPORTERS`` maps a suffix to an :class:`Exporter`: ``.csv`` (curves with ``frame,time_s``
then one column per channel), ``.bvh`` (Biovision hierarchy) and ``.glb`` (binary glTF with a
skinned mesh). :func:`export_animation` picks one from the path. :func:`write_preview_video`
writes the footage at its own size with the predicted skeleton drawn over it where the artist
fitted it, beside a side render of the skeleton, to judge the result at a glance.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gaitcore.errors import GaitInputError
from gaitcore.io.pose_table import PoseTable, pose_matrix, write_pose_table
from gaitcore.progress import Progress, report
from gaitcore.rig.skeleton import Skeleton


@dataclass(frozen=True)
class Exporter:
    """One file type the animation can be exported to.

    Attributes
    ----------
    suffix : str
        Lower-case file suffix with its dot.
    description : str
        For file dialogs ("BVH motion (*.bvh)").
    needs_skeleton : bool
    write : callable (path, skeleton or None, table, fps, naming) -> None
        ``naming`` is the bone naming of :func:`gaitcore.io.bone_names.bone_names` (the CSV
        keeps channel names as they are).
    """

    suffix: str
    description: str
    needs_skeleton: bool
    write: Callable[[Path, Skeleton | None, PoseTable, float, str], None]


def _write_csv(path: Path, skeleton: Skeleton | None, table: PoseTable, fps: float,
               naming: str) -> None:
    write_pose_table(path, table, fps=fps)


def _write_bvh(path: Path, skeleton: Skeleton | None, table: PoseTable, fps: float,
               naming: str) -> None:
    from gaitcore.io.bvh.writer import write_bvh

    write_bvh(path, skeleton, table, fps=fps, naming=naming)


def _write_glb(path: Path, skeleton: Skeleton | None, table: PoseTable, fps: float,
               naming: str) -> None:
    from gaitcore.io.gltf import write_glb

    write_glb(path, skeleton, pose_matrix(skeleton, table), fps, naming=naming)


EXPORTERS: dict[str, Exporter] = {
    e.suffix: e for e in (
        Exporter(".csv", "Joint-angle curves (*.csv)", False, _write_csv),
        Exporter(".bvh", "BVH motion (*.bvh)", True, _write_bvh),
        Exporter(".glb", "glTF binary, skinned (*.glb)", True, _write_glb),
    )
}


def export_animation(path: str | Path, skeleton: Skeleton | None, table: PoseTable,
                     fps: float = 24.0, *, naming: str = "as-is") -> Path:
    """Write animation curves in the format named by the suffix of ``path``.

    Parameters
    ----------
    path : str or Path
        Output file; its suffix (case-insensitive) picks the exporter from ``EXPORTERS``.
    skeleton : Skeleton or None
        Needed by ``.bvh`` and ``.glb``.
    table : PoseTable
        One row per frame; columns named like ``skeleton.channel_names`` (extra columns are
        ignored by the skeletal formats).
    fps : float
        Frame rate: ``time_s = frame / fps`` in CSV, BVH frame time and glTF key times.
    naming : {"as-is", "rigify"}
        Bone names in BVH and glTF (:func:`gaitcore.io.bone_names.bone_names`).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    GaitInputError
        Unknown suffix (the message lists the known ones), no skeleton for a skeletal format,
        channels of the skeleton missing from the table (all listed), or a bad frame rate.
    """
    path = Path(path)
    exporter = EXPORTERS.get(path.suffix.lower())
    if exporter is None:
        known = ", ".join(f"{s} ({e.description.split(' (')[0]})" for s, e in EXPORTERS.items())
        raise GaitInputError(f"cannot export to {path.name!r}: unknown file type "
                             f"{path.suffix or '(none)'!r}; use one of {known}")
    if exporter.needs_skeleton and skeleton is None:
        raise GaitInputError(f"{exporter.suffix} export needs a skeleton (its joint hierarchy); "
                             "give one (a skeleton .json or .bvh file)")
    if not (np.isfinite(fps) and fps > 0):
        raise GaitInputError(f"frame rate must be a positive number, got {fps}")
    exporter.write(path, skeleton, table, float(fps), naming)
    return path


# ---------------------------------------------------------------- preview video
VIDEO_CODECS = (("mp4v", None), ("MJPG", ".avi"))
"""FourCC codes tried in turn, with the suffix forced on the file (None keeps the asked one)."""


@dataclass(frozen=True)
class PreviewVideo:
    """What :func:`write_preview_video` wrote.

    Attributes
    ----------
    path : Path
        The file, which differs from the one asked for when a fallback codec was used.
    codec : str
        FourCC of the codec used.
    frames : int
    note : str or None
        Why the file or codec differs from the request, to show the user; None otherwise.
    """

    path: Path
    codec: str
    frames: int
    note: str | None = None


def write_preview_video(path: str | Path, footage_frames: Iterable[np.ndarray],
                        skeleton: Skeleton, poses: np.ndarray, fps: float = 24.0, *,
                        footage_from_world: np.ndarray | None = None,
                        view_height_m: float | None = None,
                        progress: Progress | None = None) -> PreviewVideo:
    """Write the footage at its own size with the posed skeleton drawn over it, and a side
    render of the skeleton beside it, to judge the result at a glance.

    Parameters
    ----------
    path : str or Path
        Output video, normally ``.mp4`` (codec mp4v). When this OpenCV cannot encode mp4v,
        an MJPG ``.avi`` is written next to it instead and ``note`` says so.
    footage_frames : iterable of ndarray
        Frames in clip order: BGR uint8 (H, W, 3), or grey / binary masks (H, W), all of one
        size. At least ``len(poses)`` are needed; frames past that are not read.
    skeleton : Skeleton
        Must have bones to draw (see :meth:`Skeleton.bone_ellipsoids`).
    poses : ndarray of shape (n, k)
        Predicted pose per frame, laid out as ``skeleton.channel_names``.
    fps : float
    footage_from_world : ndarray of shape (n, 2, 3), optional
        Per frame, the affine map from the skeleton's side view (world X, Y, metres) to
        footage pixels: where the artist fitted the footage behind the skeleton
        (:func:`gaitcore.project.footage_fit.footage_from_world`). Without it, no skeleton
        is drawn over the footage.
    view_height_m : float, optional
        World height of the side view; by default 1.4 times the skeleton's rest height.
    progress : callable (done, total) -> bool, optional
        Called before each frame and at the end; False cancels.

    Returns
    -------
    PreviewVideo

    Raises
    ------
    GaitInputError
        Bad poses, maps or frame rate, fewer footage frames than poses, frames of several
        sizes, or no usable codec.
    Cancelled
        ``progress`` returned False; the partial file is removed.
    """
    p = np.asarray(poses, dtype=float)
    if p.ndim != 2 or p.shape[0] == 0:
        raise GaitInputError(f"poses must have shape (frames, channels), got {p.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise GaitInputError(f"frame rate must be a positive number, got {fps}")
    if footage_from_world is not None and np.shape(footage_from_world) != (len(p), 2, 3):
        raise GaitInputError(f"footage_from_world must have shape ({len(p)}, 2, 3), got "
                             f"{np.shape(footage_from_world)}")
    world = skeleton.forward_kinematics(p)
    if view_height_m is None:
        view_height_m = (1.4 * float(np.ptp(skeleton.joint_positions(skeleton.rest_pose())[:, 1]))
                         or 2.9)
    frames = iter(footage_frames)
    first = next(frames, None)
    if first is None:
        raise GaitInputError(f"the footage has no frames for the {len(p)} poses; give the clip")
    return _encode(Path(path), first, frames, skeleton, world, fps, footage_from_world,
                   view_height_m, progress)


def _encode(path: Path, first: np.ndarray, frames, skeleton: Skeleton, world: np.ndarray,
            fps: float, maps: np.ndarray | None, view_height_m: float,
            progress: Progress | None) -> PreviewVideo:
    """Render and write every frame of the preview (see :func:`write_preview_video`)."""
    n = len(world)
    height, width = _as_bgr(first).shape[:2]
    side = (max(16, round(height * 4 / 3)), max(16, height))
    renderer = _side_renderer(skeleton, side, view_height_m)
    try:
        writer, used, note = _open_writer(path, fps, (width + side[0], height))
        try:
            for done, image in enumerate(_paired(first, frames, n)):
                report(progress, done, n, f"preview video cancelled at frame {done} of {n}")
                affine = None if maps is None else maps[done]
                writer.write(_preview_frame(image, done, skeleton, world[done], affine, renderer,
                                            (width, height)))
        except BaseException:
            writer.release()
            used[0].unlink(missing_ok=True)
            raise
        writer.release()
    finally:
        renderer.close()
    if progress is not None:
        progress(n, n)
    return PreviewVideo(used[0], used[1], n, note)


def _paired(first: np.ndarray, rest, n: int):
    """The first ``n`` footage frames; a shorter footage raises when it runs out."""
    image = first
    for done in range(n):
        if image is None:
            raise GaitInputError(f"the footage has {done} frames but there are {n} poses; give "
                                 "the clip the animation was made from")
        yield image
        image = next(rest, None) if done + 1 < n else None


def _preview_frame(image: np.ndarray, index: int, skeleton: Skeleton, world: np.ndarray,
                   affine: np.ndarray | None, renderer, size: tuple[int, int]) -> np.ndarray:
    """One frame of the preview: the footage with the skeleton over it, the side view beside."""
    view = _as_bgr(image).copy()
    if (view.shape[1], view.shape[0]) != size:
        raise GaitInputError(f"footage frame {index} is {view.shape[1]}x{view.shape[0]} but the "
                             f"first is {size[0]}x{size[1]}: give frames of one size")
    if affine is not None:
        _draw_skeleton(view, skeleton, world, affine)
    rgb, _ = renderer.render_world(world)
    panel = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    cv2.putText(panel, f"frame {index}", (6, panel.shape[0] - 8), cv2.FONT_HERSHEY_SIMPLEX,
                0.4, (30, 30, 30), 1, cv2.LINE_AA)
    return np.hstack([view, panel])


BONE_COLOUR = (0, 200, 255)
"""Colour (BGR) of the skeleton drawn over the footage; joints in white."""


def _side_renderer(skeleton: Skeleton, size: tuple[int, int], view_height_m: float):
    from gaitcore.rig.render import SkeletonRenderer

    return SkeletonRenderer(skeleton, width=size[0], height=size[1], view_height_m=view_height_m)


def _draw_skeleton(image: np.ndarray, skeleton: Skeleton, world: np.ndarray,
                   affine: np.ndarray) -> None:
    """Draw the bones of one pose (joint transforms (J, 4, 4)) over ``image`` in place,
    through the side-view-to-pixel map ``affine`` (2, 3). The footage is tracked (the animal
    stays in its window), so the skeleton's travel along X is taken off, as the 3D viewport
    does by following the root."""
    xy = world[:, :2, 3].copy()
    xy[:, 0] -= world[0, 0, 3] - skeleton.offsets[0, 0]
    uv = xy @ affine[:, :2].T + affine[:, 2]
    thick = max(1, round(image.shape[0] / 270))
    points = [tuple(int(round(c)) for c in q) for q in uv]
    for child, parent in enumerate(skeleton.parents):
        if parent >= 0:
            cv2.line(image, points[parent], points[child], BONE_COLOUR, thick + 1, cv2.LINE_AA)
    for q in points:
        cv2.circle(image, q, thick + 1, (255, 255, 255), -1, cv2.LINE_AA)


def _open_writer(path: Path, fps: float, frame_size: tuple[int, int]):
    """The first codec of ``VIDEO_CODECS`` that opens: (writer, (path, fourcc), note)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tried: list[str] = []
    for fourcc, suffix in VIDEO_CODECS:
        target = path if suffix is None else path.with_suffix(suffix)
        writer = cv2.VideoWriter(str(target), cv2.VideoWriter_fourcc(*fourcc), fps, frame_size)
        if writer.isOpened():
            note = None
            if tried:
                note = (f"codec {tried[0]} is not available in this OpenCV build; wrote "
                        f"{fourcc} video to {target.name} instead of {path.name}")
            return writer, (target, fourcc), note
        writer.release()
        target.unlink(missing_ok=True)
        tried.append(fourcc)
    raise GaitInputError(f"cannot write video {path}: none of the codecs {', '.join(tried)} is "
                         "available in this OpenCV build; install opencv-python with FFmpeg")


def _as_bgr(image: np.ndarray) -> np.ndarray:
    """A footage frame as BGR uint8 (H, W, 3): colour as is, grey or binary masks expanded."""
    img = np.asarray(image)
    if img.dtype == bool:
        img = img.astype(np.uint8) * 255
    if img.ndim == 2 and img.dtype == np.uint8:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise GaitInputError(f"footage frames must be uint8 images (H, W, 3) or (H, W), got "
                             f"{img.dtype} {img.shape}")
    return img
