"""Segmentation and sketch tools: the toolbar, and the gaitcore calls behind it.

The box (A) and the subject and background brushes (S, B: any frame, the Roto Brush model)
feed the segmentation, which :class:`app.roto.RotoController` runs and corrects; the paper's
subject and background rectangles on the first frame (Shift+S, Shift+B) still work.
Rasterizing sketches is :mod:`gaitcore.project.steps`; moving strokes from frame to frame is
in the two functions at the top. Long work runs as a job with a progress dialog and Cancel;
results land as undoable commands.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QObject
from PySide6.QtGui import QAction, QActionGroup, QKeySequence
from PySide6.QtWidgets import QSpinBox, QToolBar

from app.commands import AddStrokesCommand, SegmentationProfileCommand, SetSilhouettesCommand
from app.document import DocumentController
from app.roto import RotoController
from app.state import AppState
from app.widgets.frame_canvas import Tool
from app.widgets.frame_view import FrameView
from app.workers import Job
from gaitcore.errors import GaitInputError
from gaitcore.footage.sources import FrameSource
from gaitcore.project.document import Project
from gaitcore.project.steps import sketched_silhouettes
from gaitcore.silhouettes.annotations import Stroke
from gaitcore.silhouettes.settings import read_settings, write_settings
from gaitcore.silhouettes.sketch import carry_strokes, propagate_strokes

TOOL_KEYS = {Tool.NAVIGATE: "N", Tool.BOX: "A", Tool.SUBJECT_BRUSH: "S",
             Tool.BACKGROUND_BRUSH: "B", Tool.DRAW: "D", Tool.ERASE: "E",
             Tool.SUBJECT: "Shift+S", Tool.BACKGROUND: "Shift+B"}
"""Shortcut of each tool: the brushes, the main way to mark subject and background on any
frame, get the plain letters; the paper's rectangles (first frame only) the shifted ones."""
TOOLBAR_TOOLS = (Tool.NAVIGATE, Tool.BOX, Tool.SUBJECT_BRUSH, Tool.BACKGROUND_BRUSH, Tool.DRAW,
                 Tool.ERASE)
"""Tools on the toolbar; the rectangles are in the Tools menu only."""


def copied_strokes(project: Project, frame: int) -> list[Stroke]:
    """The strokes of ``frame - 1`` moved unchanged onto ``frame``."""
    return carry_strokes(project.strokes_on(frame - 1), frame)


def propagated_strokes(source: FrameSource, project: Project, frame: int) -> list[Stroke]:
    """The strokes of ``frame - 1`` moved onto ``frame`` by optical flow."""
    return propagate_strokes(project.strokes_on(frame - 1), source.frame(frame - 1),
                             source.frame(frame), to_frame=frame)


class ToolsController(QObject):
    """The Tools toolbar and menu actions; runs segmentation and stroke propagation."""

    def __init__(self, state: AppState, view: FrameView, documents: DocumentController,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._view = view
        self._documents = documents
        self.roto = RotoController(state, view, documents, self)
        self.toolbar = QToolBar("Tools")
        self.toolbar.setObjectName("toolsToolBar")
        self.tool_actions: dict[Tool, QAction] = {}
        group = QActionGroup(self)
        for tool, key in TOOL_KEYS.items():
            action = QAction(tool.value.capitalize(), self, checkable=True)
            action.setShortcut(QKeySequence(key))
            action.setToolTip(f"{tool.value.capitalize()} ({key})")
            action.triggered.connect(lambda _c=False, t=tool: view.set_tool(t))
            group.addAction(action)
            if tool in TOOLBAR_TOOLS:
                self.toolbar.addAction(action)
            self.tool_actions[tool] = action
        self.tool_actions[Tool.NAVIGATE].setChecked(True)
        self.pen = QSpinBox(minimum=1, maximum=60, value=int(view.pen_width_px), suffix=" px")
        self.pen.setToolTip("Pen width of new strokes and brush strokes")
        self.pen.valueChanged.connect(lambda v: setattr(view, "pen_width_px", float(v)))
        self.toolbar.addWidget(self.pen)
        self.toolbar.addSeparator()
        self.segment_action = self._action("Segment clip", "Ctrl+G", self.segment)
        self.copy_action = self._action("Copy strokes from previous frame", "Ctrl+Shift+C",
                                        self.copy_previous)
        self.propagate_action = self._action("Propagate strokes by optical flow", "Ctrl+Shift+F",
                                             self.propagate)
        self.sketch_action = self._action("Use sketches as silhouettes", "Ctrl+Shift+K",
                                          self.use_sketches)
        self.sketch_engine_action = self._action("Propagate this frame's sketch with the "
                                                 "segmentation", "Ctrl+Shift+G",
                                                 self.roto.propagate_sketch)
        for action in (self.segment_action, self.copy_action, self.propagate_action,
                       self.sketch_action):
            self.toolbar.addAction(action)
        self.load_profile_action = QAction("Load segmentation settings...", self)
        self.load_profile_action.setToolTip("Segment with the settings of a profile ('gaitcore "
                                            "segment --save-settings' writes one)")
        self.load_profile_action.triggered.connect(lambda _c=False: self.load_profile())
        self.save_profile_action = QAction("Save segmentation settings...", self)
        self.save_profile_action.triggered.connect(lambda _c=False: self.save_profile())

    def _action(self, text: str, shortcut: str, slot) -> QAction:
        action = QAction(text, self)
        action.setShortcut(QKeySequence(shortcut))
        action.triggered.connect(lambda _c=False: slot())
        return action

    # -- segmentation -----------------------------------------------------------------------
    def segment(self) -> Job | None:
        """Segment the clip in the background (:meth:`RotoController.segment`)."""
        job = self.roto.segment()
        if job is not None and self.segment_action.isEnabled():
            self.segment_action.setEnabled(False)
            job.finished.connect(lambda: self.segment_action.setEnabled(True))
        return job

    def use_sketches(self) -> Job | None:
        """Build the silhouettes from the sketch strokes of every frame."""
        state, project, source = self._state, self._state.project, self._state.source
        if source is None or not project.strokes:
            self._documents.messageRaised.emit("draw strokes on the footage first (D)")
            return None
        n, shape = len(source), source.shape[:2]
        job = Job(lambda progress: sketched_silhouettes(project, n, shape, progress),
                  "Rasterizing the sketches")
        return self._documents.run(job, lambda sil: state.undo_stack.push(
            SetSilhouettesCommand(state, sil, "use sketches as silhouettes")))

    def load_profile(self) -> bool:
        """Segment with the settings of a profile file from now on (one undo step)."""
        asker = self._documents.asker
        path = asker.open_file("Load segmentation settings", "Segmentation profiles (*.json)")
        if path is None:
            return False
        try:
            settings = read_settings(path)
        except GaitInputError as exc:
            asker.error("Cannot load the segmentation settings", str(exc))
            return False
        state = self._state
        state.undo_stack.push(SegmentationProfileCommand(state, settings, path.name))
        self._documents.messageRaised.emit(f"segmentation settings of {path.name}: segment "
                                           "the clip again (Ctrl+G) to use them everywhere")
        return True

    def save_profile(self) -> bool:
        """Write the project's segmentation settings to a profile file."""
        asker = self._documents.asker
        path = asker.export_path("Save segmentation settings",
                                 Path("segmentation-settings.json"),
                                 "Segmentation profiles (*.json)")
        if path is None:
            return False
        try:
            write_settings(path, self._state.project.segmentation)
        except OSError as exc:
            asker.error("Cannot save the segmentation settings",
                        f"{path}: {exc.strerror or exc}")
            return False
        self._documents.messageRaised.emit(f"wrote {path}")
        return True

    # -- strokes ----------------------------------------------------------------------------
    def copy_previous(self) -> None:
        """Copy the previous frame's strokes onto the current frame (one undo step)."""
        frame = self._state.frame
        strokes = copied_strokes(self._state.project, frame) if frame > 0 else []
        if not strokes:
            self._documents.messageRaised.emit("the previous frame has no strokes to copy")
            return
        self._state.undo_stack.push(AddStrokesCommand(self._state, strokes,
                                                      f"copy strokes from frame {frame - 1}"))

    def propagate(self) -> Job | None:
        """Move the previous frame's strokes onto this frame by optical flow (background job)."""
        state, project, source, frame = (self._state, self._state.project, self._state.source,
                                         self._state.frame)
        if source is None or frame == 0 or not project.strokes_on(frame - 1):
            self._documents.messageRaised.emit("the previous frame has no strokes to propagate")
            return None
        job = Job(lambda _progress: propagated_strokes(source, project, frame),
                  "Propagating strokes")
        return self._documents.run(job, lambda strokes: state.undo_stack.push(
            AddStrokesCommand(state, strokes, f"propagate strokes from frame {frame - 1}")))
