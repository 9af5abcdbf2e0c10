"""A Gait Studio project as plain, immutable data (no Qt).

Everything the artist makes on a clip lives in one :class:`Project` value: the footage and its
frame range, the segmentation rectangles drawn on the first frame, the sketch strokes, the
analysis settings (with pinned and forbidden key-images), the alternates accepted for the
switching models, the skeleton being posed (None: the bundled horse template) and a pose per
posed frame (key-images and accepted alternates). The tracked
silhouettes are kept too (:class:`Silhouettes`), because segmenting a long clip is slow; the
analysis itself is recomputed from them when a project is opened.

An edit makes a new value (:func:`dataclasses.replace` or the helpers below), so the GUI's
undo stack only swaps whole values. :mod:`gaitcore.project.storage` reads and writes projects.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType

import numpy as np

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.animation.root_motion import ROOT_MODES
from gaitcore.errors import GaitInputError
from gaitcore.io.bone_names import BONE_NAMINGS
from gaitcore.io.motion import AUTO
from gaitcore.rig.proportions import RigProportions
from gaitcore.rig.skeleton import Skeleton
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke
from gaitcore.silhouettes.settings import SegmentationSettings
from gaitcore.silhouettes.tracking import RoiClip

ORIGINS = ("segmented", "sketched", "masks")
"""Where silhouettes come from: colour segmentation, sketch strokes, or a folder of masks."""


@dataclass(frozen=True, eq=False)
class Silhouettes:
    """Tracked silhouettes of a clip and how they were made.

    Attributes
    ----------
    roi : RoiClip
        Fixed-size binary crops around the subject, one per frame (paper Section 2.2).
    origin : {"segmented", "sketched", "masks"}
        Colour segmentation, rasterized sketch strokes, or a folder of binary masks.

    Raises
    ------
    GaitInputError
        For an unknown origin or arrays whose lengths disagree.
    """

    roi: RoiClip
    origin: str

    def __post_init__(self) -> None:
        if self.origin not in ORIGINS:
            raise GaitInputError(f"unknown silhouette origin {self.origin!r}: use one of {ORIGINS}")
        n = self.roi.crops.shape[0]
        if (self.roi.crops.ndim != 3 or self.roi.centers_xy.shape != (n, 2)
                or self.roi.lost.shape != (n,)
                or (self.roi.edges is not None and self.roi.edges.shape != (n,))):
            raise GaitInputError(
                f"silhouette arrays disagree: crops {self.roi.crops.shape}, centres "
                f"{self.roi.centers_xy.shape}, lost {self.roi.lost.shape}"
            )

    @property
    def n_frames(self) -> int:
        return int(self.roi.crops.shape[0])

    def areas(self) -> np.ndarray:
        """Each frame's silhouette, pixels of the crops (0 where lost)."""
        crops = self.roi.crops
        return np.count_nonzero(crops.reshape(crops.shape[0], -1), axis=1)

    def window_xywh(self, frame: int) -> tuple[float, float, float, float] | None:
        """The ROI window of ``frame`` in source pixels (x, y, w, h), None where lost.

        The crops are the window shrunk by ``roi.scale``; the window is centred on the
        subject's centre of mass.
        """
        if self.roi.lost[frame]:
            return None
        rows, cols = self.roi.size_rc
        w, h = cols / self.roi.scale, rows / self.roi.scale
        cx, cy = self.roi.centers_xy[frame]
        return float(round(cx - w / 2)), float(round(cy - h / 2)), float(w), float(h)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Silhouettes):
            return NotImplemented
        a, b = self.roi, other.roi
        return (self.origin == other.origin and a.scale == b.scale
                and np.array_equal(a.crops, b.crops) and np.array_equal(a.lost, b.lost)
                and np.array_equal(a.centers_xy, b.centers_xy, equal_nan=True)
                and (a.edges is None) == (b.edges is None)
                and (a.edges is None or np.array_equal(a.edges, b.edges)))

    __hash__ = None  # type: ignore[assignment]


MAX_SPEED_M_S = 100.0
"""The fastest root speed accepted, metres per second (a cheetah runs under 30)."""


@dataclass(frozen=True)
class AnimationOptions:
    """How the animation is computed from the posed keys, in the preview and the exports.

    Attributes
    ----------
    filtered : bool
        Drive the animation with the band-pass filtered PC trajectories (paper 5.2).
    clamp : bool
        Clamp the RBF weights to [0, 1] (paper 2.4).
    loop : bool
        Play and export one gait cycle, cut at the detected period and closed on itself.
    root_motion : {"auto", "in-place", "footage", "forward", "as-keys"}
        Horizontal root motion of the exports (:func:`gaitcore.io.motion.export_motion`);
        ``auto`` is in place for a loop; for the whole clip, along the animal's progress in
        the footage when it crosses the view, else forward.
    root_speed_m_s : float
        The speed of ``forward``, metres per second, 0 for the footage's (or the keys').
    ground_contact : bool
        Plant the feet through stance and keep them above the ground in the exports.
    bone_names : {"as-is", "rigify"}
        Joint names in BVH and glTF exports (``rigify``: ``hip.L``).

    Raises
    ------
    GaitInputError
        An unknown root motion or bone naming.
    """

    filtered: bool = False
    clamp: bool = False
    loop: bool = False
    root_motion: str = AUTO
    root_speed_m_s: float = 0.0
    ground_contact: bool = True
    bone_names: str = "as-is"

    def __post_init__(self) -> None:
        if self.root_motion not in (AUTO, *ROOT_MODES):
            raise GaitInputError(f"unknown root motion {self.root_motion!r}; use one of "
                                 f"{', '.join((AUTO, *ROOT_MODES))}")
        if not (np.isfinite(self.root_speed_m_s) and 0 <= self.root_speed_m_s <= MAX_SPEED_M_S):
            raise GaitInputError(f"the root's speed must be between 0 and {MAX_SPEED_M_S:g} "
                                 f"metres per second, got {self.root_speed_m_s}")
        if self.bone_names not in BONE_NAMINGS:
            raise GaitInputError(f"unknown bone naming {self.bone_names!r}; use one of "
                                 f"{', '.join(BONE_NAMINGS)}")


@dataclass(frozen=True)
class FootageFit:
    """How the footage sits behind the skeleton in the 3D viewport, set by the artist.

    The automatic placement scales each frame so that the animal's height on it (the slow
    trend of its silhouette's height) equals the skeleton's height and puts the silhouette's
    centre on the skeleton's centre; these correct it.

    Attributes
    ----------
    scale : float
        Size of the footage relative to the automatic placement (1: unchanged), > 0.
    offset_x_m, offset_y_m : float
        Shift of the footage along the direction of travel and up, metres.
    flip : bool
        Mirror the footage left-right (an animal moving to the left).

    Raises
    ------
    GaitInputError
        For a scale that is not a positive number or a non-finite offset.
    """

    scale: float = 1.0
    offset_x_m: float = 0.0
    offset_y_m: float = 0.0
    flip: bool = False

    def __post_init__(self) -> None:
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise GaitInputError(f"footage scale must be a positive number, got {self.scale}")
        if not (np.isfinite(self.offset_x_m) and np.isfinite(self.offset_y_m)):
            raise GaitInputError("footage offsets must be finite numbers of metres")


@dataclass(frozen=True)
class Project:
    """Everything the artist made on one clip.

    Attributes
    ----------
    footage : Path or None
        Video file or image folder (absolute in memory; the project file stores it relative
        to itself). None for an empty project.
    frame_start, frame_stop : int, int or None
        The trim (the in and out marks): the analysis, the animation and the exports use
        source frames ``frame_start <= f < frame_stop`` (None: to the end). The footage is
        opened whole and every frame number of the project is a source frame number.
    fps : float or None
        Frame rate to use instead of the file's (image folders have none).
    box : Rect or None
        Around the animal on the first frame: enough to segment the clip (the GrabCut
        convention); the rectangles are then not needed.
    subject_rects, background_rects : tuple of Rect
        Drawn on the first frame to seed the colour models (paper Section 2.2).
    strokes : tuple of Stroke
        Sketch strokes of every frame (each knows its frame), in drawing order.
    scribbles : tuple of Scribble
        Subject and background brush strokes on any frame (source frame numbers), in
        painting order: hard labels for the segmentation, which re-propagates from each
        frame that has them (:mod:`gaitcore.silhouettes.roto`).
    settings : AnalysisSettings
        Number of PCs and keys, switching, and the pinned and forbidden key frames.
    alternates : tuple of int
        Alternate frames the artist accepted for the switching models (paper Section 3.2).
    key_poses : mapping of int to tuple of float
        Pose vector per posed frame, laid out as the skeleton's ``channel_names`` (metres,
        degrees). Poses of frames that are no longer keys are kept (nothing is lost when the
        artist changes the key set and back).
    skeleton : Skeleton or None
        The rig being posed; None means the bundled ``horse`` template.
    silhouettes : Silhouettes or None
        The tracked silhouettes, once segmented, sketched or read from masks.
    animation : AnimationOptions
        How the preview and the exports animate the keys.
    footage_fit : FootageFit
        How the footage sits behind the skeleton while posing.
    proportions : RigProportions
        Per-part length scales of the rig (legs, neck, body, head, tail): the rig is posed
        and exported in these proportions (:func:`gaitcore.rig.proportions.proportioned`).
    segmentation : SegmentationSettings
        The profile the clip is segmented with, in the app, the command and a batch alike.
    """

    footage: Path | None = None
    frame_start: int = 0
    frame_stop: int | None = None
    fps: float | None = None
    box: Rect | None = None
    subject_rects: tuple[Rect, ...] = ()
    background_rects: tuple[Rect, ...] = ()
    strokes: tuple[Stroke, ...] = ()
    scribbles: tuple[Scribble, ...] = ()
    settings: AnalysisSettings = field(default_factory=AnalysisSettings)
    alternates: tuple[int, ...] = ()
    key_poses: Mapping[int, tuple[float, ...]] = field(default_factory=dict)
    silhouettes: Silhouettes | None = None
    skeleton: Skeleton | None = None
    animation: AnimationOptions = field(default_factory=AnimationOptions)
    footage_fit: FootageFit = field(default_factory=FootageFit)
    proportions: RigProportions = field(default_factory=RigProportions)
    segmentation: SegmentationSettings = field(default_factory=SegmentationSettings)

    def __post_init__(self) -> None:
        if self.footage is not None:
            object.__setattr__(self, "footage", Path(self.footage))
        if self.frame_start < 0 or (self.frame_stop is not None
                                    and self.frame_stop <= self.frame_start):
            raise GaitInputError(
                f"frame range {self.frame_start}:{self.frame_stop} is empty or negative: "
                "choose 0 <= start < stop"
            )
        for name in ("subject_rects", "background_rects", "strokes", "scribbles", "alternates"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        poses = {int(k): tuple(float(v) for v in pose) for k, pose in self.key_poses.items()}
        object.__setattr__(self, "key_poses", MappingProxyType(poses))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Project):
            return NotImplemented
        names = self.__dataclass_fields__
        return all(_field_equal(k, getattr(self, k), getattr(other, k)) for k in names)

    __hash__ = None  # type: ignore[assignment]

    @property
    def trim(self) -> tuple[int, int | None]:
        """``(frame_start, frame_stop)``: the source frames analysed, stop excluded."""
        return self.frame_start, self.frame_stop

    def with_trim(self, start: int, stop: int | None) -> Project:
        """A copy trimmed to source frames ``start <= f < stop`` (None: to the end).

        Raises
        ------
        GaitInputError
            An empty or negative range.
        """
        return replace(self, frame_start=int(start), frame_stop=None if stop is None else int(stop))

    # -- queries ----------------------------------------------------------------------
    def strokes_on(self, frame: int) -> tuple[Stroke, ...]:
        """Strokes drawn on clip frame ``frame``, in drawing order."""
        return tuple(s for s in self.strokes if s.frame == frame)

    def sketched_frames(self) -> tuple[int, ...]:
        """Sorted frames that hold at least one stroke."""
        return tuple(sorted({s.frame for s in self.strokes}))

    def scribbles_on(self, frame: int) -> tuple[Scribble, ...]:
        """Brush strokes painted on source frame ``frame``, in painting order."""
        return tuple(s for s in self.scribbles if s.frame == frame)

    def corrected_frames(self) -> tuple[int, ...]:
        """Sorted frames that hold at least one brush stroke (the segmentation's keys)."""
        return tuple(sorted({s.frame for s in self.scribbles}))

    # -- edits: each returns a new project ---------------------------------------------
    def with_rect(self, rect: Rect, *, subject: bool) -> Project:
        """A copy with ``rect`` appended to the subject (or background) rectangles."""
        if subject:
            return replace(self, subject_rects=self.subject_rects + (rect,))
        return replace(self, background_rects=self.background_rects + (rect,))

    def without_rect(self, rect: Rect) -> Project:
        """A copy without the box, or else the first rectangle, equal to ``rect``.

        Raises
        ------
        GaitInputError
            When the project has no such rectangle.
        """
        if rect == self.box:
            return replace(self, box=None)
        for name in ("subject_rects", "background_rects"):
            rects = list(getattr(self, name))
            if rect in rects:
                rects.remove(rect)
                return replace(self, **{name: tuple(rects)})
        raise GaitInputError(f"the project has no rectangle {rect.as_tuple()}")

    def with_strokes(self, strokes: tuple[Stroke, ...]) -> Project:
        """A copy with ``strokes`` appended."""
        return replace(self, strokes=self.strokes + tuple(strokes))

    def with_scribbles(self, scribbles: tuple[Scribble, ...]) -> Project:
        """A copy with brush strokes ``scribbles`` appended."""
        return replace(self, scribbles=self.scribbles + tuple(scribbles))

    def without_strokes(self, indices: set[int]) -> Project:
        """A copy without the strokes at positions ``indices`` of :attr:`strokes`."""
        return replace(self, strokes=tuple(s for i, s in enumerate(self.strokes)
                                           if i not in indices))

    def without_scribbles(self, indices: Collection[int]) -> Project:
        """A copy without the brush strokes at positions ``indices`` of :attr:`scribbles`."""
        return replace(self, scribbles=tuple(s for i, s in enumerate(self.scribbles)
                                             if i not in indices))

    def with_key_constraint(self, frame: int, *, pinned: bool | None,
                            forbidden: bool | None) -> Project:
        """A copy where ``frame`` is (or is not) pinned and forbidden; None leaves it as is.

        Pinning a frame unforbids it and forbidding unpins it, so the two never overlap.
        """
        pin, forb = set(self.settings.pinned), set(self.settings.forbidden)
        if pinned is not None:
            (pin.add if pinned else pin.discard)(frame)
            if pinned:
                forb.discard(frame)
        if forbidden is not None:
            (forb.add if forbidden else forb.discard)(frame)
            if forbidden:
                pin.discard(frame)
        settings = replace(self.settings, pinned=tuple(sorted(pin)), forbidden=tuple(sorted(forb)))
        return replace(self, settings=settings)

    def with_pose(self, frame: int, pose: np.ndarray | None) -> Project:
        """A copy where ``frame`` has pose vector ``pose`` (None removes its pose).

        Raises
        ------
        GaitInputError
            A pose that is not a flat vector of finite numbers.
        """
        poses = dict(self.key_poses)
        if pose is None:
            poses.pop(int(frame), None)
        else:
            p = np.asarray(pose, dtype=float)
            if p.ndim != 1 or not np.all(np.isfinite(p)):
                raise GaitInputError(f"a pose must be a flat vector of finite numbers, "
                                     f"got shape {p.shape}")
            poses[int(frame)] = tuple(p.tolist())
        return replace(self, key_poses=poses)

    def strokes_hit(self, frame: int, xy: tuple[float, float], radius_px: float) -> set[int]:
        """Positions in :attr:`strokes` of the strokes of ``frame`` passing near ``xy``.

        A stroke is hit when the point lies within ``radius_px`` of its pen's edge, i.e. the
        distance from ``xy`` to its polyline is at most ``width_px / 2 + radius_px``.
        """
        return _hits(self.strokes, frame, xy, radius_px)

    def scribbles_hit(self, frame: int, xy: tuple[float, float], radius_px: float) -> set[int]:
        """Positions in :attr:`scribbles` of the brush strokes of ``frame`` passing near
        ``xy``, as :meth:`strokes_hit`."""
        return _hits(self.scribbles, frame, xy, radius_px)


def _field_equal(name: str, a, b) -> bool:
    if name == "key_poses":
        return dict(a) == dict(b)
    if name == "skeleton" and a is not None and b is not None:
        return a is b or a.to_dict() == b.to_dict()
    return a == b


def _hits(strokes: tuple[Stroke, ...], frame: int, xy: tuple[float, float],
          radius_px: float) -> set[int]:
    """Positions of the strokes of ``frame`` within ``radius_px`` of their pen's edge from
    ``xy``."""
    p = np.asarray(xy, dtype=float)
    return {i for i, s in enumerate(strokes)
            if s.frame == frame
            and _distance_to_polyline(s.points_xy, p) <= s.width_px / 2 + radius_px}


def _distance_to_polyline(points_xy: np.ndarray, p: np.ndarray) -> float:
    """Euclidean distance from point ``p`` (2,) to the polyline ``points_xy`` (k, 2)."""
    if len(points_xy) == 1:
        return float(np.linalg.norm(points_xy[0] - p))
    a, b = points_xy[:-1], points_xy[1:]
    ab = b - a
    length2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    t = np.clip(((p - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
    return float(np.linalg.norm(a + t[:, None] * ab - p, axis=1).min())
