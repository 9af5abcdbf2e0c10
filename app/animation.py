"""The animation preview: curves from the posed keys, kept in step with the project.

:func:`compute_animation` is the one place the GUI animates, with the very numbers
``gaitcore animate`` reads from ``analysis.json`` (:func:`gaitcore.io.analysis_file.analysis_record`),
so an export from the window and the command line agree exactly. :class:`AnimationController`
recomputes it whenever the poses, the keys or the options change (coalesced: a spin box held
down recomputes at most every 40 ms); it is milliseconds even for long clips, so it runs on
the GUI thread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import QObject, QTimer, Signal

from app.commands import AnimationOptionsCommand
from app.posing import alternates_in_use, missing_poses
from app.state import AppState
from gaitcore.analysis.alternates import swap_warning
from gaitcore.analysis.analyze import Analysis
from gaitcore.animation.animate import animate
from gaitcore.animation.weights import InterpolationWeights, interpolation_weights, loop_cycle
from gaitcore.errors import GaitInputError
from gaitcore.io.analysis_file import analysis_record
from gaitcore.project.document import AnimationOptions, Project
from gaitcore.rig.skeleton import Skeleton

CLAMP_RANGE = (0.0, 1.0)
_COALESCE_MS = 40


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
    first_frame : int
        Source frame of row 0 of ``curves`` (the start of the trim).
    """

    curves: np.ndarray
    weights: InterpolationWeights
    options: AnimationOptions
    skeleton: Skeleton
    cycle_start: int = 0
    cycle: np.ndarray | None = None
    first_frame: int = 0

    def pose_at(self, frame: int) -> np.ndarray:
        """The pose shown at source frame ``frame`` (the loop repeats in step with the clip;
        outside the trim, the nearest end's pose)."""
        row = frame - self.first_frame
        if self.cycle is not None:
            return self.cycle[(row - self.cycle_start) % len(self.cycle)]
        return self.curves[min(max(row, 0), len(self.curves) - 1)]

    def exported(self) -> tuple[np.ndarray, np.ndarray]:
        """Source frame numbers and poses to export: every analysed frame, or the cycle
        numbered from 0."""
        if self.cycle is not None:
            return np.arange(len(self.cycle)), self.cycle
        return self.first_frame + np.arange(len(self.curves)), self.curves


def swap_warning_for(project: Project, analysis: Analysis | None) -> str | None:
    """The warning of :func:`gaitcore.analysis.alternates.swap_warning` for the alternates the
    artist accepted (None when switching is off or they are fine)."""
    alternates = alternates_in_use(project, analysis)
    if analysis is None or not alternates:
        return None
    return swap_warning(analysis.loop_angle, analysis.rows(analysis.key_frames),
                        analysis.rows(alternates))


def missing_message(missing: tuple[int, ...]) -> str:
    return f"pose every key first (missing: frames {', '.join(map(str, missing))})"


def compute_animation(project: Project, analysis: Analysis | None, skeleton: Skeleton,
                      options: AnimationOptions = AnimationOptions()) -> Animation:
    """Animate the clip from the posed keys (and alternates), as ``gaitcore animate`` does.

    Raises
    ------
    GaitInputError
        No analysis, keys without a pose (the message lists them), or a failed interpolation.
    """
    if analysis is None:
        raise GaitInputError("no key-images yet: analyse the clip first")
    missing = missing_poses(project, analysis, skeleton.n_channels)
    if missing:
        raise GaitInputError(missing_message(missing))
    record = analysis_record(analysis)  # frames in rows of the analysed range
    first = record.first_frame
    alternates = tuple(f - first for f in alternates_in_use(project, analysis)) or None
    posed = tuple(record.key_frames) + tuple(alternates or ())
    poses = {f: np.asarray(project.key_poses[f + first], dtype=float) for f in posed}
    coords = record.filtered_projections if options.filtered else record.projections
    clamp = CLAMP_RANGE if options.clamp else None
    kwargs = dict(alternate_frames=alternates, theta=record.loop_angle, alpha=record.alpha, clamp=clamp)
    curves = animate(coords, record.key_frames, poses, **kwargs)
    weights = interpolation_weights(coords, record.key_frames, **kwargs)
    start, cycle = 0, None
    if options.loop:
        start, cycle = loop_cycle(curves, analysis.diagnosis.period_frames)
    return Animation(curves, weights, options, skeleton, start, cycle, first)


class AnimationController(QObject):
    """Keep :attr:`animation` in step with the project, the analysis and the options.

    Signals
    -------
    animationChanged(object)
        The new :class:`Animation`, or None when keys lack poses or it failed.
    statusChanged(str)
        What the preview shows, or why there is none (e.g. which keys lack a pose).
    """

    animationChanged = Signal(object)
    statusChanged = Signal(str)

    def __init__(self, state: AppState, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._animation: Animation | None = None
        self._status = ""
        self._timer = QTimer(self, singleShot=True, interval=_COALESCE_MS)
        self._timer.timeout.connect(self.recompute)
        state.projectChanged.connect(self._schedule)
        state.analysisChanged.connect(self._schedule)

    @property
    def animation(self) -> Animation | None:
        return self._animation

    @property
    def options(self) -> AnimationOptions:
        """The project's options (saved with it; changed by an undoable command)."""
        return self._state.project.animation

    @property
    def status(self) -> str:
        return self._status

    @property
    def pending(self) -> bool:
        return self._timer.isActive()

    def set_options(self, options: AnimationOptions) -> None:
        """Change the options as one undo step; the preview follows at once."""
        if options != self.options:
            self._state.undo_stack.push(AnimationOptionsCommand(self._state, options))
            self.recompute()

    def _schedule(self, *_changed) -> None:
        self._timer.start()

    def recompute(self) -> None:
        """Compute the animation now (also called by the coalescing timer)."""
        self._timer.stop()
        state = self._state
        try:
            animation = compute_animation(state.project, state.analysis, state.skeleton,
                                          self.options)
        except GaitInputError as exc:
            animation, status = None, str(exc)
        else:
            n_posed = len(animation.weights.pose_frames)
            status = f"animated {len(animation.curves)} frames from {n_posed} posed frames"
            if animation.cycle is not None:
                status += (f"; loop of {len(animation.cycle)} frames from frame "
                           f"{animation.first_frame + animation.cycle_start}")
            warning = swap_warning_for(state.project, state.analysis)
            if warning:
                status += f". Warning: {warning}"
        self._animation = animation
        self._status = status
        self.animationChanged.emit(animation)
        self.statusChanged.emit(status)
