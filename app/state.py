"""The one object that holds what the window shows: project, footage, frame, analysis.

Widgets never talk to each other: they read :class:`AppState` and listen to its signals, and
every edit of the project goes through a command on :attr:`AppState.undo_stack`
(see :mod:`app.commands`).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QUndoStack

from gaitcore.analysis.analyze import Analysis
from gaitcore.footage.sources import FrameSource
from gaitcore.project.document import Project
from gaitcore.rig.proportions import proportioned
from gaitcore.rig.skeleton import Skeleton
from gaitcore.rig.templates import load_template

DEFAULT_SKELETON = "horse"


@lru_cache(maxsize=1)
def default_skeleton() -> Skeleton:
    """The bundled horse template, posed when the project names no rig of its own."""
    return load_template(DEFAULT_SKELETON)


class AppState(QObject):
    """Project, footage, current frame, analysis and selected key of the window.

    Signals
    -------
    projectChanged(Project)
        The project value was replaced (an edit, an undo, or a newly opened project).
    projectOpened(Project)
        A different project (or footage) was opened; the undo history was cleared.
    pathChanged(object)
        The project file path changed (Path or None for an unsaved project).
    sourceChanged(object)
        The footage (FrameSource or None) changed.
    frameChanged(int)
        The current frame changed.
    analysisChanged(object)
        A new Analysis (or None) is available.
    analysisFailed(str)
        The analysis of the current project failed; the message is for the artist.
    selectedKeyChanged(int)
        The selected key frame changed (-1: none): the key clicked in the PC plot, shown
        highlighted there and on the timeline.
    selectedJointChanged(str)
        The joint selected for posing changed ("" for none), in the 3D viewport or the list.
    """

    projectChanged = Signal(object)
    projectOpened = Signal(object)
    pathChanged = Signal(object)
    sourceChanged = Signal(object)
    frameChanged = Signal(int)
    analysisChanged = Signal(object)
    analysisFailed = Signal(str)
    selectedKeyChanged = Signal(int)
    selectedJointChanged = Signal(str)

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._project = Project()
        self._path: Path | None = None
        self._source: FrameSource | None = None
        self._frame = 0
        self._analysis: Analysis | None = None
        self._selected_key = -1
        self._selected_joint = ""
        self._opened = 0
        self.undo_stack = QUndoStack(self)

    # -- read ---------------------------------------------------------------------------
    @property
    def project(self) -> Project:
        return self._project

    @property
    def path(self) -> Path | None:
        """Where the project was last saved or opened from (None: never saved)."""
        return self._path

    @property
    def source(self) -> FrameSource | None:
        return self._source

    @property
    def frame(self) -> int:
        return self._frame

    @property
    def analysis(self) -> Analysis | None:
        return self._analysis

    @property
    def selected_key(self) -> int:
        return self._selected_key

    @property
    def selected_joint(self) -> str:
        return self._selected_joint

    @property
    def skeleton(self) -> Skeleton:
        """The rig being posed and exported: the project's (or the bundled horse template) in
        the project's proportions (the same object while they do not change)."""
        return proportioned(self._project.skeleton or default_skeleton(), self._project.proportions)

    @property
    def template_skeleton(self) -> Skeleton:
        """The rig being posed before the project's proportions."""
        return self._project.skeleton or default_skeleton()

    @property
    def opened_count(self) -> int:
        """How many projects were opened so far: a job compares it to know whether the
        project it started on is still the open one."""
        return self._opened

    @property
    def fps(self) -> float | None:
        """The clip's frame rate: the project's (set by the artist), else the video's."""
        return self._project.fps or (self._source.fps if self._source is not None else None)

    @property
    def n_frames(self) -> int:
        """Frames of the clip: from the footage, else from the silhouettes, else 0."""
        if self._source is not None:
            return len(self._source)
        sil = self._project.silhouettes
        return sil.n_frames if sil is not None else 0

    # -- write --------------------------------------------------------------------------
    def open(self, project: Project, path: Path | None, source: FrameSource | None) -> None:
        """Start over with another project: new footage, frame 0, empty undo history."""
        if self._source is not None and self._source is not source:
            self._source.close()
        self._source = source
        self._path = path
        self._project = project
        self._opened += 1
        self._analysis = None
        self.undo_stack.clear()
        self.sourceChanged.emit(source)
        self.pathChanged.emit(path)
        self.analysisChanged.emit(None)
        self.projectOpened.emit(project)
        self.projectChanged.emit(project)
        self.set_selected_joint("")
        self._frame = -1
        self.set_frame(0)

    def set_project(self, project: Project) -> None:
        """Replace the project value (commands call this; everything else pushes commands)."""
        if project is not self._project:
            self._project = project
            self.projectChanged.emit(project)
            if self._selected_joint not in self.skeleton.joint_names:
                self.set_selected_joint("")

    def set_path(self, path: Path | None) -> None:
        if path != self._path:
            self._path = path
            self.pathChanged.emit(path)

    def set_frame(self, frame: int) -> None:
        """Go to ``frame``, clamped to the clip."""
        n = self.n_frames
        frame = 0 if n == 0 else max(0, min(int(frame), n - 1))
        if frame != self._frame:
            self._frame = frame
            self.frameChanged.emit(frame)

    def set_analysis(self, analysis: Analysis | None) -> None:
        self._analysis = analysis
        self.analysisChanged.emit(analysis)

    def set_selected_joint(self, name: str) -> None:
        """Select joint ``name`` of the skeleton for posing ("" or an unknown name: none)."""
        name = name if name in self.skeleton.joint_names else ""
        if name != self._selected_joint:
            self._selected_joint = name
            self.selectedJointChanged.emit(name)

    def set_selected_key(self, frame: int) -> None:
        if frame != self._selected_key:
            self._selected_key = frame
            self.selectedKeyChanged.emit(frame)
