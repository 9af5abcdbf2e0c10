"""Animate from key poses: the pose of every frame from the posed key-images (paper 2.4, 3.2).

:func:`animate_record` is what the ``gaitcore animate`` command and the app both call: it takes
an :class:`AnalysisRecord` (the numbers of ``analysis.json``, or of an analysis in memory,
rounded the same way, so both give bit-identical curves) and the poses of the keys, checks
them, and runs :func:`animate`: plain RBF interpolation, or switching models when the keys
have alternates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitcore.analysis.analyze import Analysis
from gaitcore.analysis.kernel import DEFAULT_ALPHA
from gaitcore.animation.rbf import RBFPoseMap
from gaitcore.animation.switching import SwitchingModel
from gaitcore.errors import GaitInputError

STORED_DECIMALS = 10
"""Decimals kept of every projection and angle in ``analysis.json`` (and in a record)."""


def stored(values: np.ndarray) -> np.ndarray:
    """``values`` as ``analysis.json`` keeps them (rounded to :data:`STORED_DECIMALS`)."""
    return np.round(np.asarray(values, dtype=float), STORED_DECIMALS)


@dataclass(frozen=True, eq=False)
class AnalysisRecord:
    """What animating needs from an analysis: the PCA coordinates, the keys and the kernel.

    Read from ``analysis.json`` (:func:`gaitcore.io.analysis_file.read_analysis_json`) or made
    from an analysis in memory (:meth:`from_analysis`); the numbers are the same either way.
    Frames (``key_frames``, ``alternate_frames``, pose keys) are source frame numbers; the
    arrays have one row per analysed frame, row 0 being ``first_frame`` (:meth:`rows`).
    """

    n_frames: int
    projections: np.ndarray
    filtered_projections: np.ndarray
    loop_angle: np.ndarray
    key_frames: tuple[int, ...]
    alternate_frames: tuple[int, ...] | None
    alpha: float
    period_frames: float = float("nan")
    """Gait period found by the diagnosis (NaN when the file has none): loops are cut at it."""
    first_frame: int = 0
    fps: float | None = None
    """Frame rate of the clip, None when the file does not know it."""
    travel: np.ndarray | None = None
    """The animal's progress across the footage on each row, in its own heights from row 0
    (:attr:`Analysis.travel`); None when it does not cross the view."""

    def rows(self, frames: tuple[int, ...] | list[int]) -> tuple[int, ...]:
        """Rows of the arrays for source ``frames``."""
        return tuple(int(f) - self.first_frame for f in frames)

    def rows_of(self, poses: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
        """``poses`` keyed by row instead of source frame."""
        return {int(f) - self.first_frame: p for f, p in poses.items()}

    @classmethod
    def from_analysis(cls, analysis: Analysis) -> AnalysisRecord:
        """The record that ``analysis.json`` of ``analysis`` would give back."""
        pcs = analysis.settings.pcs
        return cls(analysis.n_frames, stored(analysis.coords),
                   stored(analysis.diagnosis.filtered[:, :pcs]), stored(analysis.loop_angle),
                   tuple(int(f) for f in analysis.key_frames),
                   None if analysis.alternate_frames is None
                   else tuple(int(f) for f in analysis.alternate_frames),
                   float(analysis.settings.alpha), float(analysis.diagnosis.period_frames),
                   first_frame=int(analysis.first_frame),
                   travel=None if analysis.travel is None else stored(analysis.travel))


def animate_record(
    record: AnalysisRecord,
    poses: dict[int, np.ndarray],
    *,
    alternates: tuple[int, ...] | None = None,
    filtered: bool = False,
    clamp: tuple[float, float] | None = None,
) -> np.ndarray:
    """Pose of every frame of an analysed clip from the poses of its key-images.

    Parameters
    ----------
    record : AnalysisRecord
    poses : dict of int to ndarray of shape (k,)
        Pose of every key frame (and alternate frame, with ``alternates``) by source frame
        number; any other frame is refused.
    alternates : tuple of int, optional
        The alternates (source frames) to animate with (switching models); None animates
        with the keys alone.
    filtered : bool
        Drive the animation with the band-pass filtered trajectories.
    clamp : (float, float), optional
        Clamp the RBF weights to this range.

    Returns
    -------
    ndarray of shape (n_frames, k)
        One pose per analysed frame (row 0 is source frame ``record.first_frame``).

    Raises
    ------
    GaitInputError
        Poses of frames that are not keys or alternates, missing poses, or a failed fit.
    """
    posed = set(record.key_frames) | set(alternates or ())
    extra = sorted(set(poses) - posed)
    if extra:
        raise GaitInputError(
            f"frame(s) {extra} are not key-images of this analysis (keys {list(record.key_frames)}"
            + (f", alternates {list(alternates)}" if alternates else "") + ")")
    coords = record.filtered_projections if filtered else record.projections
    return animate(coords, record.rows(record.key_frames), record.rows_of(poses),
                   alternate_frames=record.rows(alternates) if alternates else None,
                   theta=record.loop_angle, alpha=record.alpha, clamp=clamp)


def animate(
    coords: np.ndarray,
    key_frames: tuple[int, ...],
    poses: dict[int, np.ndarray],
    *,
    alternate_frames: tuple[int, ...] | None = None,
    theta: np.ndarray | None = None,
    alpha: float = DEFAULT_ALPHA,
    clamp: tuple[float, float] | None = None,
) -> np.ndarray:
    """Pose of every frame by RBF interpolation of the posed key-images.

    Parameters
    ----------
    coords : ndarray of shape (n, c)
        PCA coordinates driving the animation (raw or band-pass filtered).
    key_frames : tuple of int
    poses : dict of int to ndarray of shape (k,)
        Pose vector of every key (and alternate) frame.
    alternate_frames : tuple of int, optional
        With ``theta``, animate with switching models (paper Section 3.2).
    theta : ndarray of shape (n,), optional
        Loop angle, required for switching.
    alpha, clamp
        RBF kernel width and optional weight clamp.

    Returns
    -------
    ndarray of shape (n, k)

    Raises
    ------
    GaitInputError
        A key without a pose, poses of different lengths, or a singular system.
    """
    needed = tuple(key_frames) + tuple(alternate_frames or ())
    missing = [f for f in needed if f not in poses]
    if missing:
        raise GaitInputError(
            f"the key poses lack frame(s) {missing}; add a row for every key"
            + (" and alternate" if alternate_frames else "")
            + " frame"
        )
    lengths = {np.asarray(poses[f]).shape for f in needed}
    if len(lengths) != 1:
        raise GaitInputError("every key pose must have the same channels")
    coords = np.asarray(coords, dtype=float)
    if alternate_frames:
        if theta is None:
            raise GaitInputError("switching models need the loop angle of every frame")
        model = SwitchingModel.fit(
            coords, theta, key_frames, alternate_frames, poses, alpha=alpha, clamp=clamp
        )
        return model.predict(coords, theta)
    rbf = RBFPoseMap.fit(
        coords[list(key_frames)], np.stack([poses[f] for f in key_frames]), alpha=alpha, clamp=clamp
    )
    return rbf.predict(coords)
