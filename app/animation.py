"""The animation preview: curves from the posed keys, kept in step with the project.

The curves come from :func:`gaitcore.project.steps.animate_project`, the function behind
``gaitcore animate`` too, so an export from the window and the command line agree exactly.
:class:`AnimationController` recomputes it whenever the poses, the keys or the options change
(coalesced: a spin box held down recomputes at most every 40 ms); it is milliseconds even for
long clips, so it runs on the GUI thread.
"""

from __future__ import annotations

from PySide6.QtCore import QObject, QTimer, Signal

from app.commands import AnimationOptionsCommand
from app.state import AppState
from gaitcore.errors import GaitInputError
from gaitcore.project.document import AnimationOptions
from gaitcore.project.steps import Animation, animate_project, swap_warning_for

_COALESCE_MS = 40


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
            animation = animate_project(state.project, state.analysis, state.skeleton,
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
