"""The paper's pipeline from silhouettes to animation, as two steps a script or the GUI runs.

``analyze_silhouettes``: ROI crops -> PCA -> spectral diagnosis -> key-image selection ->
(optionally) alternates for the switching models; beside it, the stretches of steady gait of
the whole clip and advice that names what stands in the way. ``rekey`` redoes the keys only.

Frames: the silhouettes given start at source frame ``first_frame``; a trim (``frame_range``,
source frames) restricts the analysis to part of them. An :class:`Analysis` names frames by
their source numbers (keys, alternates, lost frames, as the artist sees them and as settings
give them); its arrays have one row per analysed frame, row 0 being ``first_frame``
(``Analysis.rows`` converts).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from gaitcore.analysis.advice import Advice, advise
from gaitcore.analysis.alternates import loop_angle, propose_alternates
from gaitcore.analysis.cycles import Cycle, find_cycles
from gaitcore.analysis.image_pca import ImagePCA
from gaitcore.analysis.kernel import DEFAULT_ALPHA
from gaitcore.analysis.keyimages import KeySelection, select_key_images
from gaitcore.analysis.spectrum import Diagnosis, diagnose
from gaitcore.analysis.verdict import Verdict
from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress
from gaitcore.silhouettes.tracking import WORK_SIDE_PX, RoiClip, stabilize_rois

N_DIAGNOSIS_PCS = 5
"""Components kept for the spectral diagnosis table, whatever the number used to animate."""


@dataclass(frozen=True)
class AnalysisSettings:
    """Choices of the analysis step.

    Attributes
    ----------
    pcs : int
        Principal components used for key selection and interpolation (the paper's c; 2).
    keys : int
        Key-images to select (the paper's m; 4 for runs, 4 + 4 alternates for walks).
    switching : bool
        Propose alternates and animate with switching models (walks).
    alpha : float
        RBF kernel width.
    max_side_px : int or None
        ROI crops are shrunk (area averaging) so their longer side is at most this, to keep
        PCA cheap on long clips; None keeps full resolution.
    stabilize_roi : bool
        Re-centre the crops on the track averaged over one gait period found by a first
        diagnosis (:func:`gaitcore.silhouettes.tracking.stabilize_rois`), then analyse again.
    key_time_limit_s : float or None
        Time budget of the exact key search; past it the best set found is used and the
        result is reported as not proven optimal.
    pinned, forbidden : tuple of int
        Frames the artist forces into, or out of, the key set.
    """

    pcs: int = 2
    keys: int = 4
    switching: bool = False
    alpha: float = DEFAULT_ALPHA
    max_side_px: int | None = WORK_SIDE_PX
    stabilize_roi: bool = True
    key_time_limit_s: float | None = 60.0
    pinned: tuple[int, ...] = ()
    forbidden: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.pcs < 1:
            raise GaitInputError(f"the number of principal components must be at least 1, "
                                 f"got {self.pcs}")
        if self.keys < 1:
            raise GaitInputError(f"the number of key-images must be at least 1, got {self.keys}")
        if self.max_side_px is not None and self.max_side_px < 8:
            raise GaitInputError(f"working size must be at least 8 pixels, got {self.max_side_px}")


@dataclass(frozen=True, eq=False)
class Analysis:
    """Everything the analysis step computes about a clip.

    Attributes
    ----------
    settings : AnalysisSettings
    pca : ImagePCA
        Fitted on the frames where the subject was found.
    projections : ndarray of shape (n, C)
        Normalized PCA coordinates of every analysed frame (C = min(5, available)
        components); lost frames are interpolated in time and listed in ``lost_frames``.
    lost_frames : tuple of int
        Source frames.
    diagnosis : Diagnosis
    selection : KeySelection
        The key search, in rows (``key_frames`` gives source frames).
    loop_angle : ndarray of shape (n,)
        Unwrapped angle around the (PC1, PC2) loop of the filtered trajectory.
    alternate_frames : tuple of int or None
        Source frames, one per key, in key order, when switching is on and every key has one.
    alternates_note : str or None
        Why no alternates are proposed although switching is on, or a warning about them.
    first_frame : int
        Source frame of row 0 (the start of the trim).
    cycles : tuple of Cycle
        Stretches of steady gait over all the silhouettes given (not only the trim), in
        their rows; ``cycle_offset`` maps them to source frames.
    cycle_offset : int
        Source frame of the first silhouette given.
    advice : Advice
        What stands in the way of a usable analysis, and the one next step.
    """

    settings: AnalysisSettings
    pca: ImagePCA
    projections: np.ndarray
    lost_frames: tuple[int, ...]
    diagnosis: Diagnosis
    selection: KeySelection
    loop_angle: np.ndarray
    alternate_frames: tuple[int, ...] | None = field(default=None)
    alternates_note: str | None = None
    first_frame: int = 0
    cycles: tuple[Cycle, ...] = ()
    cycle_offset: int = 0
    advice: Advice | None = None

    @property
    def n_frames(self) -> int:
        return int(self.projections.shape[0])

    @property
    def coords(self) -> np.ndarray:
        """The c coordinates used for keys and interpolation, shape (n, pcs)."""
        return self.projections[:, : self.settings.pcs]

    @property
    def key_frames(self) -> tuple[int, ...]:
        """Source frames of the key-images, sorted."""
        return tuple(f + self.first_frame for f in self.selection.frames)

    def rows(self, frames: tuple[int, ...] | list[int]) -> list[int]:
        """Rows of the arrays for source ``frames`` (which must lie in :attr:`frame_range`)."""
        return [int(f) - self.first_frame for f in frames]

    @property
    def posed_frames(self) -> tuple[int, ...]:
        """Every frame the artist must pose: keys, then alternates when switching."""
        return self.key_frames + (self.alternate_frames or ())

    @property
    def frame_range(self) -> tuple[int, int]:
        """Source frames ``start <= f < stop`` analysed."""
        return self.first_frame, self.first_frame + self.n_frames


def working_images(roi: RoiClip, max_side_px: int | None) -> np.ndarray:
    """ROI crops shrunk (area averaging) so that the longer side is at most max_side_px.

    Returns
    -------
    ndarray of shape (n, rows, cols)
        The crops themselves (bool) when they are small enough, else uint8 grey levels
        0..255 (a quarter of the memory of floats, which matters on long clips).
    """
    crops = roi.crops
    rows, cols = crops.shape[1:]
    scale = 1.0 if max_side_px is None else min(1.0, max_side_px / max(rows, cols))
    if scale >= 1.0:
        return crops
    size = (max(1, round(cols * scale)), max(1, round(rows * scale)))
    out = np.empty((crops.shape[0], size[1], size[0]), dtype=np.uint8)
    for i, c in enumerate(crops):
        out[i] = cv2.resize(c.astype(np.uint8) * np.uint8(255), size, interpolation=cv2.INTER_AREA)
    return out


def analyze_silhouettes(
    roi: RoiClip,
    settings: AnalysisSettings = AnalysisSettings(),
    *,
    first_frame: int = 0,
    frame_range: tuple[int, int | None] | None = None,
    sketched: bool = False,
    progress: Progress | None = None,
) -> Analysis:
    """Run PCA, diagnosis, key selection and (optionally) alternates on tracked silhouettes.

    Parameters
    ----------
    roi : RoiClip
        Fixed-size binary crops of the subject, one per frame.
    settings : AnalysisSettings
    first_frame : int
        Source frame of the first crop (when the silhouettes are of part of a clip).
    frame_range : (int, int or None), optional
        Source frames ``start <= f < stop`` to analyse (the trim; None: all). The stretches
        of steady gait are searched over all the silhouettes all the same.
    sketched : bool
        The silhouettes come from sketches (changes the advice of an unusable diagnosis).
    progress : callable(done, total) -> bool, optional
        Reports the cycle search, the PCA (per crop placement) and the key search as equal
        stages; returning False cancels with ``Cancelled``.

    Raises
    ------
    GaitInputError
        A trim outside the silhouettes, too few frames for the keys, no motion.
    """
    start, stop = _trim(frame_range, first_frame, roi.crops.shape[0])
    whole, roi = roi, _slice(roi, start, stop)
    _check_found(roi, settings)
    stages = 4 if settings.stabilize_roi else 3
    cycles = find_cycles(whole, progress=_stage(progress, 0, stages))
    pca, proj, diagnosis = _describe(roi, settings, sketched, _stage(progress, 1, stages))
    if settings.stabilize_roi and diagnosis.verdict is not Verdict.NOT_USABLE:
        roi = stabilize_rois(roi, diagnosis.period_frames)
        pca, proj, diagnosis = _describe(roi, settings, sketched, _stage(progress, 2, stages))
    theta = loop_angle(diagnosis.filtered)
    for arr in (proj, theta):
        arr.setflags(write=False)
    motion = Analysis(
        settings=settings,
        pca=pca,
        projections=proj,
        lost_frames=tuple(int(t) + first_frame + start for t in np.nonzero(roi.lost)[0]),
        diagnosis=diagnosis,
        selection=KeySelection(frames=(), condition_number=float("nan"), exact=False,
                               nodes_visited=0),
        loop_angle=theta,
        first_frame=first_frame + start,
        cycles=cycles,
        cycle_offset=first_frame,
        advice=advise(roi, diagnosis, cycles, first_frame=first_frame, sketched=sketched),
    )
    return rekey(motion, settings, progress=_stage(progress, stages - 1, stages))


def _check_found(roi: RoiClip, settings: AnalysisSettings) -> None:
    found = int(np.count_nonzero(~roi.lost))
    if found < max(settings.keys, 2) + 1:
        raise GaitInputError(f"only {found} frame(s) with a subject for {settings.keys} "
                             "key-images; use a longer clip or fewer keys")


def _slice(roi: RoiClip, start: int, stop: int) -> RoiClip:
    return replace(roi, crops=roi.crops[start:stop], centers_xy=roi.centers_xy[start:stop],
                   lost=roi.lost[start:stop])


def _trim(frame_range: tuple[int, int | None] | None, first_frame: int, n: int) -> tuple[int, int]:
    """Rows ``start, stop`` of the silhouettes that a trim in source frames selects."""
    if frame_range is None:
        return 0, n
    start = int(frame_range[0]) - first_frame
    stop = n if frame_range[1] is None else int(frame_range[1]) - first_frame
    if not 0 <= start < stop <= n:
        last = first_frame + n
        raise GaitInputError(
            f"frames {frame_range[0]}:{frame_range[1]} are outside the clip's frames "
            f"{first_frame}:{last}: choose {first_frame} <= start < stop <= {last}"
        )
    return start, stop


_STAGE_STEPS = 1000


def _stage(progress: Progress | None, index: int, count: int) -> Progress | None:
    """``progress`` as seen by stage ``index`` of ``count`` equal stages."""
    if progress is None:
        return None

    def report(done: int, total: int) -> bool:
        step = round(_STAGE_STEPS * done / total) if total > 0 else 0
        return progress(index * _STAGE_STEPS + step, count * _STAGE_STEPS)

    return report


def _describe(
    roi: RoiClip, settings: AnalysisSettings, sketched: bool, progress: Progress | None = None
) -> tuple[ImagePCA, np.ndarray, Diagnosis]:
    """PCA of the crops where the subject was found, projections of every frame (lost ones
    interpolated in time), and the spectral diagnosis."""
    n = roi.crops.shape[0]
    found = np.nonzero(~roi.lost)[0]
    images = working_images(roi, settings.max_side_px)
    if found.size < n:
        images = images[found]
    pca = ImagePCA.fit(images, n_components=max(N_DIAGNOSIS_PCS, settings.pcs), progress=progress)
    proj = np.empty((n, pca.n_components))
    proj[found] = pca.projections
    if found.size < n:
        for k in range(pca.n_components):
            proj[:, k] = np.interp(np.arange(n), found, pca.projections[:, k])
    diag_input = proj if proj.shape[1] >= 2 else np.column_stack([proj, np.zeros(n)])
    return pca, proj, diagnose(diag_input, sketched=sketched)


def rekey(
    analysis: Analysis, settings: AnalysisSettings, *, progress: Progress | None = None
) -> Analysis:
    """Select key-images (and alternates) again with new settings, reusing the PCA.

    Changing the number of components or keys, or pinning a frame, needs no new PCA: this
    is what the GUI calls when the artist turns those knobs.

    Raises
    ------
    GaitInputError
        More components than the analysis kept, or a key selection that is impossible.
    """
    if settings.pcs > analysis.projections.shape[1]:
        raise GaitInputError(
            f"the clip has only {analysis.projections.shape[1]} independent silhouette "
            f"change(s) for {settings.pcs} principal components; use at most "
            f"{analysis.projections.shape[1]} or a clip with more motion"
        )
    coords = analysis.projections[:, : settings.pcs]
    selection = select_key_images(
        coords,
        settings.keys,
        alpha=settings.alpha,
        pinned=_rows(settings.pinned, analysis),
        forbidden=_rows(settings.forbidden + analysis.lost_frames, analysis),
        progress=progress,
        time_limit_s=settings.key_time_limit_s,
    )
    alternates, note = None, None
    if settings.switching:
        try:
            rows = propose_alternates(coords, selection.frames, theta=analysis.loop_angle,
                                      period_frames=analysis.diagnosis.period_frames)
            alternates = tuple(r + analysis.first_frame for r in rows)
        except GaitInputError as exc:
            note = f"No alternates: {exc}."
    return replace(analysis, settings=settings, selection=selection, alternate_frames=alternates,
                   alternates_note=note)


def _rows(frames: tuple[int, ...], analysis: Analysis) -> tuple[int, ...]:
    """Source frames that lie in the analysed range, as its rows (sorted, once each)."""
    start, stop = analysis.frame_range
    return tuple(sorted({f - start for f in frames if start <= f < stop}))
