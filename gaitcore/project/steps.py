"""Project-level steps: what the ``gaitcore`` command and the app both do to a clip.

Each step a user takes is one function here, Qt-free, with progress and Cancel where it is
long: open the footage, get silhouettes (segment, track masks, rasterize sketches), analyse,
choose the keys again, read a rig, animate from the posed keys. The command calls them in a
row; the app calls them from its jobs and controllers and keeps only adapters (signals, undo
commands, widgets). Errors are :class:`~gaitcore.errors.GaitInputError` lines that read well
in a dialog and in a terminal alike.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path

import numpy as np

from gaitcore.analysis.alternates import swap_warning
from gaitcore.analysis.analyze import Analysis, AnalysisSettings, analyze_silhouettes, rekey
from gaitcore.animation.animate import AnalysisRecord, animate_record
from gaitcore.animation.root_motion import mean_speed
from gaitcore.animation.weights import InterpolationWeights, interpolation_weights, loop_cycle
from gaitcore.errors import GaitInputError
from gaitcore.footage.image_folder import iter_mask_folder
from gaitcore.footage.sources import DEFAULT_FPS, FrameSource, open_frames
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.motion import ExportMotion, export_motion
from gaitcore.progress import Progress
from gaitcore.project.document import AnimationOptions, Project, Silhouettes
from gaitcore.project.footage_fit import travel_metres
from gaitcore.rig.orient import guess_axes, reoriented
from gaitcore.rig.pose_library import PoseLibrary, shipped_library
from gaitcore.rig.skeleton import Skeleton
from gaitcore.silhouettes.annotations import Rect
from gaitcore.silhouettes.segmentation import segment_clip
from gaitcore.silhouettes.sketch import crop_sketches
from gaitcore.silhouettes.tracking import WORK_SIDE_PX, crop_rois

__all__ = [
    "Animation", "CLAMP_RANGE", "CENTIMETRE_RIG_M", "alternates_in_use", "analyze",
    "animate_project", "check_segmentation_input", "drag_library", "frame_rate",
    "frames_to_pose", "missing_poses", "open_source", "read_rig", "rekey", "segment",
    "silhouettes_from_masks", "sketched_silhouettes", "swap_warning_for",
]

CLAMP_RANGE = (0.0, 1.0)
"""The RBF weights' range when the project's animation options clamp them."""
CENTIMETRE_RIG_M = 10.0
"""A BVH rig taller than this (in file units read as metres) is taken to be in centimetres."""


# -- footage ---------------------------------------------------------------------------------
def open_source(project: Project) -> FrameSource | None:
    """The footage of ``project``, whole: the trim only limits the analysis, and every frame
    number of the project is a source frame number. None when it has none.

    Raises
    ------
    GaitInputError
        The footage cannot be read.
    """
    if project.footage is None:
        return None
    return open_frames(project.footage, fps=project.fps)


def frame_rate(project: Project, source: FrameSource | None) -> float:
    """Frames per second of the clip: the project's (set by the artist), else the footage's,
    else :data:`~gaitcore.footage.sources.DEFAULT_FPS`."""
    return float(project.fps or (source.fps if source is not None else None) or DEFAULT_FPS)


# -- silhouettes -----------------------------------------------------------------------------
def silhouettes_from_masks(folder: Path, progress: Progress | None = None, *,
                           start: int = 0, stop: int | None = None) -> Silhouettes:
    """Tracked silhouettes of a folder of binary masks, streamed (segmentation is skipped).

    ``start`` and ``stop`` trim the clip to masks ``start <= f < stop`` in name order.
    """
    masks = islice(iter_mask_folder(Path(folder)), start, stop)
    roi = crop_rois(masks, max_side=WORK_SIDE_PX, progress=progress)
    return Silhouettes(roi, "masks")


def segment(source: FrameSource, project: Project, progress: Progress | None = None, *,
            box: Rect | None = None,
            mask_sink: Callable[[int, np.ndarray], None] | None = None) -> Silhouettes:
    """Segment the whole clip from a box around the animal on the first frame (``box``, else
    the project's), or from the project's rectangles (paper Section 2.2), with the project's
    brush strokes (:attr:`Project.scribbles`) as hard labels on their frames.

    The ``gaitcore segment`` command with the same box, rectangles and scribbles file gives
    the same silhouettes. To keep the engine for corrections, use
    :class:`gaitcore.project.roto_session.RotoSession` instead.

    Raises
    ------
    GaitInputError
        No box and not a subject and a background rectangle, or no subject found.
    """
    box = box or project.box
    check_segmentation_input(project, box)
    rects = () if box is not None else (project.subject_rects, project.background_rects)
    roi = segment_clip(source, *rects, box=box, scribbles=project.scribbles, progress=progress,
                       settings=project.segmentation, mask_sink=mask_sink, max_side=WORK_SIDE_PX)
    return Silhouettes(roi, "segmented")


def check_segmentation_input(project: Project, box: Rect | None = None) -> None:
    """Raise GaitInputError when the project gives the segmentation nothing to start from:
    no box, no subject and background rectangles, and no subject brush stroke on frame 0."""
    box = box or project.box
    on_first = any(sc.label == "subject" for sc in project.scribbles_on(0))
    if box is None and not (project.subject_rects and project.background_rects) and not on_first:
        raise GaitInputError("draw a box around the animal, or at least one subject and one "
                             "background rectangle, on the first frame, then segment again")


def sketched_silhouettes(project: Project, n_frames: int, shape_rc: tuple[int, int],
                         progress: Progress | None = None) -> Silhouettes:
    """Silhouettes made of the sketch strokes; frames without strokes count as lost."""
    roi = crop_sketches(project.strokes, n_frames, shape_rc, max_side=WORK_SIDE_PX,
                        progress=progress)
    return Silhouettes(roi, "sketched")


# -- analysis --------------------------------------------------------------------------------
def analyze(silhouettes: Silhouettes, settings: AnalysisSettings,
            progress: Progress | None = None, *, first_frame: int = 0,
            trim: tuple[int, int | None] | None = None) -> Analysis:
    """The analysis step of the paper (Sections 2.3, 3.1, 3.2, 5.2) on the trimmed
    silhouettes, and the stretches of steady gait of all of them.

    Parameters
    ----------
    silhouettes : Silhouettes
    settings : AnalysisSettings
    progress : callable(done, total) -> bool, optional
    first_frame : int
        Source frame of the first silhouette (when they are of part of a clip).
    trim : (int, int or None), optional
        Source frames ``start <= f < stop`` to analyse (the project's trim); a stop past the
        silhouettes means their end. None: all.

    To choose the keys again on the same silhouettes, call :func:`rekey` instead: it reuses
    the PCA.
    """
    frame_range = None
    if trim is not None:
        end = first_frame + silhouettes.n_frames
        stop = end if trim[1] is None else min(trim[1], end)
        frame_range = (min(trim[0], max(first_frame, stop - 1)), stop)
    return analyze_silhouettes(silhouettes.roi, settings, first_frame=first_frame,
                               frame_range=frame_range, sketched=silhouettes.origin == "sketched",
                               progress=progress)


# -- rig and poses ---------------------------------------------------------------------------
def read_rig(path: Path) -> tuple[Skeleton, str]:
    """A rig from a skeleton JSON or a BVH file, and a note on how it was read ('' if none).

    A BVH rig taller than :data:`CENTIMETRE_RIG_M` read as metres is read in centimetres.
    It is then stood up in Gait Studio's frame (Y up, facing +X, feet on the ground under
    the origin: :func:`gaitcore.rig.orient.guess_axes`); the note says which axes it had,
    and when they were ambiguous, what to check.

    Raises
    ------
    GaitInputError
        Unreadable or invalid file.
    """
    path = Path(path)
    if path.suffix.lower() != ".bvh":
        return Skeleton.from_json(path), ""
    skeleton = read_bvh(path)[0]
    rest = skeleton.joint_positions(skeleton.rest_pose())
    notes = []
    if np.ptp(rest, axis=0).max() > CENTIMETRE_RIG_M:
        skeleton = read_bvh(path, scale=0.01)[0]
        notes.append("read in centimetres")
    axes = guess_axes(skeleton)
    skeleton = reoriented(skeleton, up=axes.up, forward=axes.forward)
    if (axes.up, axes.forward) != ("+Y", "+X"):
        notes.append(f"turned from {axes.up} up, facing {axes.forward}")
    if axes.ambiguous:
        notes.append(f"its axes are ambiguous ({axes.reason}): check that it stands and faces "
                     "the direction of travel, or fix it with Pose > Rig axes")
    return skeleton, f"{path.name}: {', '.join(notes)}" if notes else ""


def alternates_in_use(project: Project, analysis: Analysis | None) -> tuple[int, ...]:
    """The accepted alternates when switching is on and they still pair with the keys."""
    if analysis is None or not project.settings.switching:
        return ()
    keys, alts = analysis.key_frames, project.alternates
    if len(alts) != len(keys) or set(alts) & set(keys):
        return ()
    return tuple(alts)


def frames_to_pose(project: Project, analysis: Analysis | None) -> tuple[int, ...]:
    """Key-images, then the alternates in use: every frame that needs a pose."""
    if analysis is None:
        return ()
    return tuple(analysis.key_frames) + alternates_in_use(project, analysis)


def missing_poses(project: Project, analysis: Analysis | None, n_channels: int) -> tuple[int, ...]:
    """Frames to pose that have no pose (or one of another rig's length)."""
    return tuple(f for f in frames_to_pose(project, analysis)
                 if len(project.key_poses.get(f, ())) != n_channels)


def drag_library(project: Project, skeleton: Skeleton, frame: int) -> PoseLibrary:
    """The examples an end drag on ``frame`` folds its chain like: the shipped gait library
    and the poses of the project's other keys (only chains whose channels they name use
    them; a rig of other names gets no example and drags as plain IK).

    Parameters
    ----------
    project : Project
    skeleton : Skeleton
        The rig being posed.
    frame : int
        The key being posed (its own stored pose is left out).
    """
    others = [p for f, p in sorted(project.key_poses.items())
              if f != frame and len(p) == skeleton.n_channels]
    library = shipped_library()
    if not others:
        return library
    return library.with_poses(skeleton, np.array(others), f"{len(others)} other key(s) posed")


# -- animation -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Animation:
    """Curves of every frame and what produced them.

    Attributes
    ----------
    curves : ndarray of shape (n, k)
        A pose per analysed frame (the trim), laid out as ``skeleton.channel_names``.
    weights : InterpolationWeights
    options : AnimationOptions
    skeleton : Skeleton
    cycle_start : int
        Row of ``curves`` where the loop cycle starts (0 without ``options.loop``).
    cycle : ndarray of shape (P, k) or None
        The loop cycle when ``options.loop``.
    key_poses : dict of int to ndarray of shape (k,)
        The posed frames animated from, by row of ``curves`` (their root positions give the
        export's speed; their feet anchor the ground contact).
    period_frames : float
        Gait period the loop is cut at.
    first_frame : int
        Source frame of row 0 of ``curves`` (the start of the trim).
    travel_m : ndarray of shape (n,) or None
        The animal's progress in the footage on each row, in the rig's metres (None: it does
        not cross the view).
    fps : float
        Frame rate of the clip (turns the speed the artist gives into metres per frame).
    """

    curves: np.ndarray
    weights: InterpolationWeights
    options: AnimationOptions
    skeleton: Skeleton
    cycle_start: int = 0
    cycle: np.ndarray | None = None
    key_poses: dict[int, np.ndarray] = field(default_factory=dict)
    period_frames: float = float("nan")
    first_frame: int = 0
    travel_m: np.ndarray | None = None
    fps: float = DEFAULT_FPS

    @property
    def given_speed_m(self) -> float | None:
        """The speed the artist gave, metres per frame (None: from the footage or keys)."""
        speed = self.options.root_speed_m_s
        return speed / self.fps if speed > 0 else None

    def pose_at(self, frame: int) -> np.ndarray:
        """The pose shown at source frame ``frame`` (the loop repeats in step with the clip;
        outside the trim, the nearest end's pose)."""
        row = frame - self.first_frame
        if self.cycle is not None:
            return self.cycle[(row - self.cycle_start) % len(self.cycle)]
        return self.curves[min(max(row, 0), len(self.curves) - 1)]

    def export_motion(self, progress: Progress | None = None) -> ExportMotion:
        """The motion the exporters write, as ``gaitcore animate`` makes it: loop or clip,
        root motion and ground contact of :attr:`options` (seconds on long clips: run it off
        the GUI thread)."""
        return export_motion(self.curves, self.skeleton.channel_names, key_poses=self.key_poses,
                             skeleton=self.skeleton, loop=self.options.loop,
                             period_frames=self.period_frames,
                             root_motion=self.options.root_motion,
                             ground_contact=self.options.ground_contact,
                             first_frame=self.first_frame, travel_m=self.travel_m,
                             speed_m=self.given_speed_m, progress=progress)

    def exported(self) -> tuple[np.ndarray, np.ndarray]:
        """Source frame numbers and poses to export: every analysed frame, or the cycle
        numbered from 0."""
        if self.cycle is not None:
            return np.arange(len(self.cycle)), self.cycle
        return self.first_frame + np.arange(len(self.curves)), self.curves


def animate_project(project: Project, analysis: Analysis | None, skeleton: Skeleton,
                    options: AnimationOptions = AnimationOptions(), *,
                    fps: float = DEFAULT_FPS) -> Animation:
    """Animate the clip from the posed keys (and alternates), as ``gaitcore animate`` does.

    The root travels as the animal does in the footage, at the scale the footage is placed
    behind the rig (:func:`~gaitcore.project.footage_fit.travel_metres`); ``fps`` turns a
    speed the artist gives into metres per frame.

    The numbers come from :meth:`AnalysisRecord.from_analysis`, those ``analysis.json``
    holds, so an export from the app and from the command agree byte for byte.

    Raises
    ------
    GaitInputError
        No analysis, keys without a pose (the message lists them), or a failed interpolation.
    """
    if analysis is None:
        raise GaitInputError("no key-images yet: analyse the clip first")
    missing = missing_poses(project, analysis, skeleton.n_channels)
    if missing:
        raise GaitInputError(f"pose every key first "
                             f"(missing: frames {', '.join(map(str, missing))})")
    record = AnalysisRecord.from_analysis(analysis)
    alternates = alternates_in_use(project, analysis) or None
    posed = record.key_frames + (alternates or ())
    poses = {f: np.asarray(project.key_poses[f], dtype=float) for f in posed}
    clamp = CLAMP_RANGE if options.clamp else None
    curves = animate_record(record, poses, alternates=alternates, filtered=options.filtered,
                            clamp=clamp)
    coords = record.filtered_projections if options.filtered else record.projections
    weights = interpolation_weights(
        coords, record.rows(record.key_frames),
        alternate_frames=record.rows(alternates) if alternates else None,
        theta=record.loop_angle, alpha=record.alpha, clamp=clamp)
    start, cycle = 0, None
    if options.loop:
        start, cycle = loop_cycle(curves, analysis.diagnosis.period_frames)
    return Animation(curves, weights, options, skeleton, start, cycle, record.rows_of(poses),
                     float(analysis.diagnosis.period_frames), record.first_frame,
                     travel_metres(record.travel, skeleton, project.footage_fit), float(fps))


@dataclass(frozen=True)
class FootageSpeed:
    """The animal's speed in the footage, at the scale the footage sits behind the rig.

    Attributes
    ----------
    speed_m_s : float
        Metres per second.
    stride_m : float
        Metres per gait cycle (NaN when the analysis found no period).
    """

    speed_m_s: float
    stride_m: float

    def describe(self) -> str:
        stride = f", a stride of {self.stride_m:.2f} m" if np.isfinite(self.stride_m) else ""
        return f"{self.speed_m_s:.2f} m/s{stride}"


def footage_speed(project: Project, analysis: Analysis | None, skeleton: Skeleton,
                  fps: float) -> FootageSpeed | None:
    """The animal's mean speed in the footage (None: it does not cross the view, or there is
    no analysis): what the root follows by default, offered where the camera pans."""
    travel = None if analysis is None else travel_metres(analysis.travel, skeleton,
                                                          project.footage_fit)
    if travel is None or len(travel) < 2:
        return None
    per_frame = mean_speed(travel)
    return FootageSpeed(per_frame * fps, per_frame * analysis.cycle_frames)


def swap_warning_for(project: Project, analysis: Analysis | None) -> str | None:
    """The warning of :func:`gaitcore.analysis.alternates.swap_warning` for the alternates the
    artist accepted (None when switching is off or they are fine)."""
    alternates = alternates_in_use(project, analysis)
    if analysis is None or not alternates:
        return None
    return swap_warning(analysis.loop_angle, analysis.rows(analysis.key_frames),
                        analysis.rows(alternates))
