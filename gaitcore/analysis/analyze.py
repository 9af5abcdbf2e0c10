"""The paper's pipeline from silhouettes to animation, as two steps a script or the GUI runs.

``analyze_silhouettes``: ROI crops at the animal's own scale, the frames where it is only
partly in view left out (framing.py) -> PCA -> the gait's rhythm in the components, drift
taken out (rhythm.py) -> spectral diagnosis of the pair it lives in -> key-image selection ->
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
from gaitcore.analysis.framing import Framing, footage_travel, frame_silhouettes, framing_notes
from gaitcore.analysis.image_pca import DENSE_LIMIT, ImagePCA
from gaitcore.analysis.kernel import DEFAULT_ALPHA
from gaitcore.analysis.keyimages import KeySelection, select_key_images
from gaitcore.analysis.rhythm import Rhythm, find_rhythm, longest_period
from gaitcore.analysis.spectrum import MIN_FRAMES, Diagnosis, diagnose
from gaitcore.analysis.verdict import no_repeat
from gaitcore.errors import GaitInputError
from gaitcore.limits import check_memory
from gaitcore.progress import Progress
from gaitcore.runs import true_runs
from gaitcore.silhouettes.tracking import WORK_SIDE_PX, RoiClip

N_DIAGNOSIS_PCS = 8
"""Components kept for the rhythm and the diagnosis table, whatever the number used to
animate: on real footage the gait's pair is often not among the first two."""

BRIDGED_GAP = 4
"""Runs of at most this many frames left out inside the analysed stretch are bridged (their
coordinates interpolated in time, as for lost frames); a longer run ends the stretch."""


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
        Compare the silhouettes at the animal's steady height, centred on its smoothed track
        (:func:`gaitcore.analysis.framing.frame_silhouettes`); False keeps the paper's one
        fixed-size window centred on each frame's centre of mass.
    key_time_limit_s : float or None
        Time budget of the exact key search; past it the best set found is used and the
        result is reported as not proven optimal.
    pinned, forbidden : tuple of int
        Frames the artist forces into, or out of, the key set.
    bring_back : tuple of int
        Source frames analysed although the animal looks only partly in view there.
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
    bring_back: tuple[int, ...] = ()

    @property
    def framing_key(self) -> tuple:
        """The settings that change the silhouettes the PCA sees: a change of any other one
        only needs the keys chosen again (:func:`rekey`)."""
        return self.max_side_px, self.stabilize_roi, tuple(sorted(self.bring_back))

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
        Normalized coordinates of every analysed frame on the principal components, their
        slow drift removed, the rhythm's pair first (C = min(8, available) components;
        ``component_names`` says which is which); frames left out are interpolated in time
        and listed in ``lost_frames``.
    lost_frames : tuple of int
        Source frames without a silhouette, or left out (partly in view), in the analysed
        range.
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
    framing : Framing or None
        Over every silhouette given (not only the analysed range): the frames left out and
        the scale each was compared at.
    rhythm : Rhythm or None
        The drift taken out and the gait cycle found.
    components : tuple of int
        The principal component (0-based, by decreasing variance) behind each column of
        ``projections``.
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
    framing: Framing | None = None
    rhythm: Rhythm | None = None
    components: tuple[int, ...] = ()

    @property
    def component_names(self) -> tuple[str, ...]:
        """"PC3", "PC4", ...: the principal component behind each column of ``projections``."""
        order = self.components or tuple(range(self.projections.shape[1]))
        return tuple(f"PC{k + 1}" for k in order)

    @property
    def pair_name(self) -> str:
        """The components used, e.g. "PC2 × PC4"."""
        return " × ".join(self.component_names[: max(2, self.settings.pcs)])

    @property
    def cycle_frames(self) -> float:
        """The gait cycle of a walk, frames: the diagnosis' period, or twice it when the
        pair's loop turns twice per cycle (:attr:`Rhythm.loops_per_cycle`)."""
        loops = 2 if self.rhythm is None else self.rhythm.loops_per_cycle
        return float(self.diagnosis.period_frames * loops)

    @property
    def partial_frames(self) -> tuple[int, ...]:
        """Source frames left out because the animal is only partly in view (or much smaller
        than in its neighbours), over every silhouette given."""
        if self.framing is None:
            return ()
        return tuple(int(t) + self.cycle_offset for t in np.flatnonzero(self.framing.partial))

    @property
    def travel(self) -> np.ndarray | None:
        """The animal's progress across the view on each analysed frame, in its own heights
        from the first (:func:`~gaitcore.analysis.framing.footage_travel`): None when it
        does not cross the view (it stays, or the camera follows it)."""
        if self.framing is None:
            return None
        start = self.first_frame - self.cycle_offset
        return footage_travel(self.framing, start, start + self.n_frames)

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
        The crops themselves (bool, or grey uint8) when they are small enough, else uint8
        grey levels 0..255 (a quarter of the memory of floats, which matters on long clips).
    """
    crops = roi.crops
    rows, cols = crops.shape[1:]
    scale = 1.0 if max_side_px is None else min(1.0, max_side_px / max(rows, cols))
    if scale >= 1.0:
        return crops
    size = (max(1, round(cols * scale)), max(1, round(rows * scale)))
    out = np.empty((crops.shape[0], size[1], size[0]), dtype=np.uint8)
    grey = crops.dtype == np.uint8
    for i, c in enumerate(crops):
        img = c if grey else c.astype(np.uint8) * np.uint8(255)
        out[i] = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
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
        of steady gait are searched over all the silhouettes all the same. Within it, the
        analysis keeps the longest stretch without frames left out (partly in view, lost),
        runs of up to ``BRIDGED_GAP`` of them bridged.
    sketched : bool
        The silhouettes come from sketches (changes the advice of an unusable diagnosis).
    progress : callable(done, total) -> bool, optional
        Reports the cycle search, the PCA and the key search as equal stages; returning False
        cancels with ``Cancelled``.

    Raises
    ------
    GaitInputError
        A trim outside the silhouettes, too few frames for the keys, no motion.
    """
    start, stop = _trim(frame_range, first_frame, roi.crops.shape[0])
    _check_memory(roi)
    back = tuple(f - first_frame for f in settings.bring_back)
    framed, framing = frame_silhouettes(roi, scale=settings.stabilize_roi, bring_back=back)
    lo, hi = _kept_stretch(framed.lost[start:stop])
    analysed = _slice(framed, start + lo, start + hi)
    given = _slice(roi, start + lo, start + hi)  # as tracked: the advice's cues, the checks
    _check_found(replace(given, lost=analysed.lost), settings)
    cycles = find_cycles(framed, progress=_stage(progress, 0, 3))
    pca, *described = _describe(analysed, settings, sketched, _stage(progress, 1, 3))
    origin = first_frame + start + lo
    motion = _unkeyed(settings, pca, *described, first_frame=origin,
                      lost_frames=tuple(int(t) + origin for t in np.nonzero(analysed.lost)[0]),
                      cycles=cycles, cycle_offset=first_frame, framing=framing)
    advice = advise(given, motion.diagnosis, cycles,
                    first_frame=first_frame, sketched=sketched,
                    slow_lag=described[1].slow_lag_frames,
                    notes=framing_notes(framing, first_frame))
    return rekey(replace(motion, advice=advice), settings, progress=_stage(progress, 2, 3))


def _unkeyed(settings: AnalysisSettings, pca: ImagePCA, proj: np.ndarray, rhythm: Rhythm,
             order: tuple[int, ...], diagnosis: Diagnosis, **fields) -> Analysis:
    """The analysis before its keys are chosen (:func:`rekey` chooses them): the loop angle
    of the rhythm's pair, four turns of pi per gait cycle as the switching models count."""
    theta = loop_angle(diagnosis.filtered) * (2 // max(1, rhythm.loops_per_cycle))
    for arr in (proj, theta):
        arr.setflags(write=False)
    none = KeySelection(frames=(), condition_number=float("nan"), exact=False, nodes_visited=0)
    return Analysis(settings=settings, pca=pca, projections=proj, diagnosis=diagnosis,
                    selection=none, loop_angle=theta, rhythm=rhythm, components=order,
                    **fields)


def _kept_stretch(left_out: np.ndarray) -> tuple[int, int]:
    """Rows ``lo, hi`` of the longest stretch without frames left out, runs of at most
    ``BRIDGED_GAP`` of them inside it bridged; the whole range when none is left out, or
    when that stretch is too short to diagnose (its frames left out are then bridged)."""
    kept = ~np.asarray(left_out, dtype=bool)
    for a, b in true_runs(~kept):
        if b - a <= BRIDGED_GAP and a > 0 and b < kept.size:
            kept[a:b] = True
    runs = true_runs(kept)
    longest = max(runs, key=lambda r: r[1] - r[0]) if runs else (0, 0)
    if longest[1] - longest[0] < MIN_FRAMES:
        return 0, kept.size
    return longest


STACK_BYTES_PER_VALUE = 5
"""Memory per pixel of the silhouette windows that the analysis holds at once (the crops,
their framed and working copies, the PCA's chunks): an upper bound, checked by a test."""
DENSE_BYTES_PER_VALUE = 16
"""Memory per value of a clip small enough for the dense PCA (its float matrix, the Gram
matrix, the cycle search): an upper bound, checked by a test."""


def memory_needed(n_frames: int, rows: int, cols: int) -> int:
    """Bytes the analysis of ``n_frames`` silhouette windows of ``rows`` × ``cols`` takes."""
    values = n_frames * rows * cols
    return max(STACK_BYTES_PER_VALUE * values, DENSE_BYTES_PER_VALUE * min(values, DENSE_LIMIT))


def _check_memory(roi: RoiClip) -> None:
    """Refuse up front a clip whose analysis cannot fit in the memory left."""
    n, rows, cols = roi.crops.shape
    check_memory(memory_needed(n, rows, cols),
                 job=f"analysing {n:,} frames of {cols} × {rows} pixels",
                 advice=lambda fits: f"trim the clip to at most {int(n * fits):,} frames "
                 "(--start and --stop, or the trim marks) and analyse its parts one by one")


def _check_found(roi: RoiClip, settings: AnalysisSettings) -> None:
    """Enough frames with a silhouette, and enough distinct ones, for the keys (before the
    framing resamples them, which would make every frame differ a little)."""
    found = np.flatnonzero(~roi.lost)
    if found.size < max(settings.keys, 2) + 1:
        raise GaitInputError(f"only {found.size} frame(s) with the whole subject in view for "
                             f"{settings.keys} key-images; use a longer clip or fewer keys")
    distinct = len({roi.crops[t].tobytes() for t in found})
    if distinct == 1:
        raise GaitInputError("the silhouettes of every frame are identical: there is no motion "
                             "to analyse; check the masks, or choose a clip where the animal "
                             "moves")
    if distinct < max(settings.keys, 2):
        raise GaitInputError(
            f"only {distinct} frames have distinct silhouettes, fewer than the "
            f"{settings.keys} key-images: use a clip where the animal moves, or fewer keys")


def _slice(roi: RoiClip, start: int, stop: int) -> RoiClip:
    return replace(roi, crops=roi.crops[start:stop], centers_xy=roi.centers_xy[start:stop],
                   lost=roi.lost[start:stop],
                   edges=None if roi.edges is None else roi.edges[start:stop])


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
) -> tuple[ImagePCA, np.ndarray, Rhythm, tuple[int, ...], Diagnosis]:
    """PCA of the crops where the subject was found, then :func:`_rhythm_coordinates`."""
    n = roi.crops.shape[0]
    found = np.nonzero(~roi.lost)[0]
    images = working_images(roi, settings.max_side_px)
    if found.size < n:
        images = images[found]
    pca = ImagePCA.fit(images, n_components=max(N_DIAGNOSIS_PCS, settings.pcs), progress=progress)
    return (pca, *_rhythm_coordinates(pca, found, n, sketched))


def _rhythm_coordinates(pca: ImagePCA, found: np.ndarray, n: int, sketched: bool
                        ) -> tuple[np.ndarray, Rhythm, tuple[int, ...], Diagnosis]:
    """The rhythm in the PCA's components; the normalized, drift-free coordinates of all
    ``n`` rows in the rhythm's order (rows not ``found`` interpolated in time); and the
    spectral diagnosis of the rhythm's pair."""
    if pca.n_components < 2:
        raise GaitInputError("the silhouettes vary along a single direction only: there is no "
                             "gait to diagnose; check the silhouettes of the clip")
    rhythm = find_rhythm(pca.projections * np.sqrt(pca.eigenvalues))
    order = rhythm.order
    coords = rhythm.detrended[:, order]
    spread = coords.std(axis=0)
    coords = coords / np.where(spread > 0, spread, 1.0)
    proj = np.empty((n, coords.shape[1]))
    proj[found] = coords
    if found.size < n:
        for k in range(coords.shape[1]):
            proj[:, k] = np.interp(np.arange(n), found, coords[:, k])
    hint = None if rhythm.period_frames is None else 1.0 / rhythm.period_frames
    names = tuple(f"PC{k + 1}" for k in order[:2])
    diagnosis = diagnose(proj, sketched=sketched, f0_hint=hint, names=names)
    if rhythm.lag_frames is None and found.size >= MIN_FRAMES:
        verdict, reason = no_repeat(found.size, longest_period(found.size),
                                    rhythm.slow_lag_frames)
        diagnosis = replace(diagnosis, verdict=verdict, reason=reason)
    return proj, rhythm, order, diagnosis


def analyze_features(features: np.ndarray, settings: AnalysisSettings = AnalysisSettings(), *,
                     first_frame: int = 0) -> Analysis:
    """The analysis of any per-frame feature vectors instead of silhouettes (keypoints, for
    a benchmark's oracle): PCA, rhythm, diagnosis, keys and alternates, no framing.

    Parameters
    ----------
    features : ndarray of shape (n, d)
        One finite vector per frame.
    settings : AnalysisSettings
    first_frame : int
        Source frame of row 0.

    Raises
    ------
    GaitInputError
        Too few frames or no variation.
    """
    x = np.asarray(features, dtype=float)
    if x.ndim != 2 or not np.all(np.isfinite(x)):
        raise GaitInputError("features must be a finite (frames, values) array")
    n = x.shape[0]
    pca = ImagePCA.fit(x.reshape(n, 1, -1), n_components=max(N_DIAGNOSIS_PCS, settings.pcs))
    motion = _unkeyed(settings, pca, *_rhythm_coordinates(pca, np.arange(n), n, False),
                      lost_frames=(), first_frame=first_frame, cycle_offset=first_frame)
    return rekey(motion, settings)


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
    forbidden = _rows(settings.forbidden + analysis.lost_frames, analysis)
    selection = select_key_images(
        coords,
        settings.keys,
        alpha=settings.alpha,
        pinned=_rows(settings.pinned, analysis),
        forbidden=forbidden,
        progress=progress,
        time_limit_s=settings.key_time_limit_s,
    )
    alternates, note = None, None
    if settings.switching:
        try:
            rows = propose_alternates(coords, selection.frames, theta=analysis.loop_angle,
                                      period_frames=analysis.cycle_frames / 2,
                                      forbidden=forbidden)
            alternates = tuple(r + analysis.first_frame for r in rows)
        except GaitInputError as exc:
            note = f"No alternates: {exc}."
    return replace(analysis, settings=settings, selection=selection, alternate_frames=alternates,
                   alternates_note=note)


def _rows(frames: tuple[int, ...], analysis: Analysis) -> tuple[int, ...]:
    """Source frames that lie in the analysed range, as its rows (sorted, once each)."""
    start, stop = analysis.frame_range
    return tuple(sorted({f - start for f in frames if start <= f < stop}))
