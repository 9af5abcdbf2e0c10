"""Undoable edits of the project: one QUndoCommand per action of the artist.

A project is an immutable value, so every command computes the new value when it is made and
only swaps before and after on redo and undo. Commands that concern one frame go back to that
frame when they are undone or redone, so the artist sees what changed.
"""

from __future__ import annotations

from dataclasses import replace
from enum import IntEnum, unique

from PySide6.QtGui import QUndoCommand

from app.state import AppState
from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.project.document import AnimationOptions, FootageFit, Project, Silhouettes
from gaitcore.project.footage_fit import facing_travel
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke
from gaitcore.silhouettes.settings import SegmentationSettings


@unique
class MergeId(IntEnum):
    """Undo merge ids (``QUndoCommand.id``), one per kind of command that merges; unique."""

    SETTINGS = 1001
    FOOTAGE_FIT = 1002
    POSE = 1003
    PROPORTIONS = 1004


class ProjectCommand(QUndoCommand):
    """Replace the project by ``after``; undo puts back the project it replaced.

    Parameters
    ----------
    state : AppState
    after : Project
        The project after the edit.
    text : str
        What the Edit menu shows ("Undo <text>").
    frame : int, optional
        Frame to show on redo and undo.
    """

    def __init__(self, state: AppState, after: Project, text: str,
                 frame: int | None = None) -> None:
        super().__init__(text)
        self._state = state
        self._before = state.project
        self._after = after
        self._frame = frame

    def redo(self) -> None:
        self._state.set_project(self._after)
        self._show_frame()

    def undo(self) -> None:
        self._state.set_project(self._before)
        self._show_frame()

    def _show_frame(self) -> None:
        if self._frame is not None:
            self._state.set_frame(self._frame)


class AddRectCommand(ProjectCommand):
    """Add a subject or background rectangle (drawn on the first frame)."""

    def __init__(self, state: AppState, rect: Rect, *, subject: bool) -> None:
        kind = "subject" if subject else "background"
        super().__init__(state, state.project.with_rect(rect, subject=subject),
                         f"add {kind} rectangle", frame=0)


class SetBoxCommand(ProjectCommand):
    """Draw the box around the animal on the first frame (it replaces the previous one)."""

    def __init__(self, state: AppState, box: Rect) -> None:
        super().__init__(state, replace(state.project, box=box), "draw box around the animal",
                         frame=0)


class RemoveRectCommand(ProjectCommand):
    """Remove a subject or background rectangle."""

    def __init__(self, state: AppState, rect: Rect) -> None:
        super().__init__(state, state.project.without_rect(rect), "remove rectangle", frame=0)


class AddStrokesCommand(ProjectCommand):
    """Add strokes: one drawn stroke, or strokes copied or propagated to a frame."""

    def __init__(self, state: AppState, strokes: list[Stroke], text: str = "draw stroke") -> None:
        frame = strokes[0].frame if strokes else None
        super().__init__(state, state.project.with_strokes(tuple(strokes)), text, frame=frame)


class EraseStrokesCommand(ProjectCommand):
    """Remove the strokes at positions ``indices`` of ``project.strokes``."""

    def __init__(self, state: AppState, indices: set[int]) -> None:
        strokes = state.project.strokes
        frame = strokes[min(indices)].frame if indices else None
        text = "erase stroke" if len(indices) == 1 else f"erase {len(indices)} strokes"
        super().__init__(state, state.project.without_strokes(indices), text, frame=frame)


class AddScribblesCommand(ProjectCommand):
    """Add brush strokes; with ``silhouettes``, the segmentation they corrected too (one
    correction is one undo step: undo puts back both the strokes and the silhouettes)."""

    def __init__(self, state: AppState, scribbles: list[Scribble], text: str, *,
                 silhouettes: Silhouettes | None = None) -> None:
        after = state.project.with_scribbles(tuple(scribbles))
        if silhouettes is not None:
            after = replace(after, silhouettes=silhouettes)
        super().__init__(state, after, text, frame=scribbles[0].frame if scribbles else None)


class EraseScribblesCommand(ProjectCommand):
    """Remove the brush strokes at positions ``indices`` of ``project.scribbles``; with
    ``silhouettes``, the segmentation re-propagated without them too, and with ``strokes``
    the sketch strokes the same eraser drag went over, those still in the project (one undo
    step: undo puts back the strokes, the sketch and the silhouettes)."""

    def __init__(self, state: AppState, indices: set[int], *,
                 silhouettes: Silhouettes | None = None,
                 strokes: tuple[Stroke, ...] = ()) -> None:
        project = state.project
        gone = {id(s) for s in strokes}
        sketch = {i for i, s in enumerate(project.strokes) if id(s) in gone}
        after = project.without_scribbles(indices).without_strokes(sketch)
        if silhouettes is not None:
            after = replace(after, silhouettes=silhouettes)
        text = "erase brush stroke" if len(indices) == 1 else f"erase {len(indices)} brush strokes"
        if sketch:
            text += " and " + ("a sketch stroke" if len(sketch) == 1
                               else f"{len(sketch)} sketch strokes")
        frame = state.project.scribbles[min(indices)].frame if indices else None
        super().__init__(state, after, text, frame=frame)


class PinKeyCommand(ProjectCommand):
    """Force a frame into the key set (or release it)."""

    def __init__(self, state: AppState, frame: int, pinned: bool = True) -> None:
        after = state.project.with_key_constraint(frame, pinned=pinned, forbidden=None)
        super().__init__(state, after, f"{'pin' if pinned else 'unpin'} frame {frame}", frame=frame)


class ForbidKeyCommand(ProjectCommand):
    """Keep a frame out of the key set, e.g. drop a key the artist dislikes (or allow it)."""

    def __init__(self, state: AppState, frame: int, forbidden: bool = True) -> None:
        after = state.project.with_key_constraint(frame, pinned=None, forbidden=forbidden)
        text = f"{'drop' if forbidden else 'allow'} key frame {frame}"
        super().__init__(state, after, text, frame=frame)


class ClearKeyConstraintsCommand(ProjectCommand):
    """Unpin and allow every frame."""

    def __init__(self, state: AppState) -> None:
        settings = replace(state.project.settings, pinned=(), forbidden=())
        super().__init__(state, replace(state.project, settings=settings),
                         "clear pinned and dropped keys")


class BringBackCommand(ProjectCommand):
    """Analyse frames left out as partly in view (or leave them out again)."""

    def __init__(self, state: AppState, frames: tuple[int, ...], back: bool = True) -> None:
        kept = set(state.project.settings.bring_back)
        kept = kept | set(frames) if back else kept - set(frames)
        settings = replace(state.project.settings, bring_back=tuple(sorted(kept)))
        what = f"frame {frames[0]}" if len(frames) == 1 else f"frames {frames[0]}–{frames[-1]}"
        super().__init__(state, replace(state.project, settings=settings),
                         f"{'bring back' if back else 'leave out'} {what}", frame=frames[0])


class _FieldCommand(ProjectCommand):
    """A change of one field of a project part; consecutive changes of that field (a spin box
    held down) merge into one undo step."""

    _ID = 0

    def __init__(self, state: AppState, after: Project, field_name: str, text: str) -> None:
        super().__init__(state, after, text)
        self._field = field_name

    def id(self) -> int:
        return self._ID

    def mergeWith(self, other: QUndoCommand) -> bool:
        if type(other) is not type(self) or other._field != self._field:
            return False
        self._after = other._after
        return True


class ChangeSettingsCommand(_FieldCommand):
    """Change the analysis settings (one field)."""

    _ID = MergeId.SETTINGS

    def __init__(self, state: AppState, settings: AnalysisSettings, field_name: str) -> None:
        super().__init__(state, replace(state.project, settings=settings), field_name,
                         f"change {field_name}")


class FootageFitCommand(_FieldCommand):
    """Scale, shift or mirror the footage behind the skeleton (one field)."""

    _ID = MergeId.FOOTAGE_FIT

    def __init__(self, state: AppState, fit: FootageFit, field_name: str) -> None:
        super().__init__(state, replace(state.project, footage_fit=fit), field_name,
                         f"change footage {field_name}")


class TrimCommand(ProjectCommand):
    """Set the in and out marks: the source frames the analysis and the exports use."""

    def __init__(self, state: AppState, start: int, stop: int | None, text: str = "trim") -> None:
        super().__init__(state, state.project.with_trim(start, stop), text)


def set_in_mark(state: AppState) -> None:
    """Start the trim at the current frame (I); an out mark before it is dropped."""
    frame, stop = state.frame, state.project.frame_stop
    state.undo_stack.push(TrimCommand(state, frame,
                                      stop if stop is not None and stop > frame else None,
                                      f"set the in mark at frame {frame}"))


def set_out_mark(state: AppState) -> None:
    """End the trim at the current frame, included (O); an in mark after it is dropped."""
    frame, start = state.frame, state.project.frame_start
    stop = None if frame + 1 >= state.n_frames else frame + 1
    state.undo_stack.push(TrimCommand(state, start if start <= frame else 0, stop,
                                      f"set the out mark at frame {frame}"))


class SegmentationProfileCommand(ProjectCommand):
    """Segment the clip with other settings (a profile read from a file)."""

    def __init__(self, state: AppState, settings: SegmentationSettings, name: str) -> None:
        super().__init__(state, replace(state.project, segmentation=settings),
                         f"use segmentation settings {name}")


class FrameRateCommand(ProjectCommand):
    """Set the clip's frame rate (image folders have none; a video's header may be wrong)."""

    def __init__(self, state: AppState, fps: float | None) -> None:
        super().__init__(state, replace(state.project, fps=fps),
                         f"set frame rate to {fps:g} fps" if fps else "use the file's frame rate")


class AcceptAlternatesCommand(ProjectCommand):
    """Accept alternate frames for the switching models (paper Section 3.2)."""

    def __init__(self, state: AppState, frames: tuple[int, ...]) -> None:
        super().__init__(state, replace(state.project, alternates=tuple(frames)),
                         "accept alternates" if frames else "clear alternates")


class SetSilhouettesCommand(ProjectCommand):
    """Replace the silhouettes, e.g. with the result of segmenting the clip; the first ones
    also turn the footage behind the rig to the way the animal walks (one undo step)."""

    def __init__(self, state: AppState, silhouettes: Silhouettes | None, text: str) -> None:
        project = state.project
        fit = project.footage_fit
        if project.silhouettes is None and silhouettes is not None:
            fit = facing_travel(fit, silhouettes)
        super().__init__(state, replace(project, silhouettes=silhouettes, footage_fit=fit), text)


class AnimationOptionsCommand(ProjectCommand):
    """Change how the keys are animated (filtered, clamped, looped): saved with the project."""

    def __init__(self, state: AppState, options: AnimationOptions) -> None:
        super().__init__(state, replace(state.project, animation=options),
                         "change animation options")
