"""The main window: the frame view in the middle, docks around it, menus and shortcuts.

The window only assembles: state (:mod:`app.state`), file operations (:mod:`app.document`),
analysis (:mod:`app.analysis_controller`), tools (:mod:`app.tools`), playback
(:mod:`app.playback`) and the widgets. Window geometry and dock layout are remembered with
QSettings.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QByteArray, QPoint, QRect, QSettings, QStandardPaths, Qt
from PySide6.QtGui import QAction, QKeySequence, QPainter, QPixmap
from PySide6.QtWidgets import (
    QDockWidget,
    QFrame,
    QMainWindow,
    QMenu,
    QScrollArea,
    QSplitter,
    QWidget,
)

from app.analysis_controller import AnalysisController
from app.animation import AnimationController
from app.autosave import Autosaver, find_recovery_copies
from app.commands import FrameRateCommand, set_in_mark, set_out_mark
from app.dialogs import Asker
from app.document import DocumentController
from app.export import KINDS, ExportController
from app.playback import Player
from app.posing import PosingController
from app.state import AppState
from app.tools import ToolsController
from app.widgets.animation_view import AnimationView
from app.widgets.batch_table import BatchTableDialog
from app.widgets.diagnosis_panel import DiagnosisPanel
from app.widgets.eigen_view import EigenImagesView
from app.widgets.frame_view import FrameView
from app.widgets.pc_plot import PCPlotWidget
from app.widgets.pose_panel import PosePanel
from app.widgets.pose_viewport import PoseViewport
from app.widgets.timeline import TimelineWidget
from app.workers import FrameLoader, JobRunner
from gaitcore.errors import GaitInputError
from gaitcore.project.batch import read_summary
from gaitcore.project.steps import frame_rate
from gaitcore.rig.orient import AXES

APP_NAME = "Gait Studio"


def default_recovery_dir() -> Path:
    """``<user app data>/recovery``: where autosaved copies go."""
    data = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.AppLocalDataLocation)
    return Path(data) / "recovery"


LOOP_WIDTH = 300
"""The loop and verdict dock's width at a first start (the posing dock gets its panel's
narrowest, every button whole); the centre, footage and rig, takes the rest."""


class MainWindow(QMainWindow):
    """Gait Studio's window.

    Parameters
    ----------
    asker : Asker, optional
        Dialogs (tests pass a scripted one).
    recovery_dir : Path, optional
        Folder of autosaved copies (default :func:`default_recovery_dir`).
    autosave_ms : int
        Interval between autosaves.
    remember_layout : bool
        Restore the window geometry and dock layout of the last session, and save them at
        close (off for screenshots and tests, which want the default layout).
    """

    def __init__(self, *, asker: Asker | None = None, recovery_dir: Path | None = None,
                 autosave_ms: int = 60_000, remember_layout: bool = True) -> None:
        super().__init__()
        self._remember_layout = remember_layout
        self._layout_before_large: tuple[QByteArray, list[int]] | None = None
        self.batch_table: BatchTableDialog | None = None
        self.setObjectName("mainWindow")
        self.state = AppState(self)
        self.runner = JobRunner(self)
        self.loader = FrameLoader(self)
        self.asker = asker or Asker(self)
        self.autosaver = Autosaver(self.state, recovery_dir or default_recovery_dir(), autosave_ms,
                                   self)
        self.documents = DocumentController(self.state, self.asker, self.runner, self.autosaver,
                                            self)
        self.analysis = AnalysisController(self.state, self.runner, self)
        self.player = Player(self.state, self)
        self.posing = PosingController(self.state, self.asker, self.runner, self)
        self.animator = AnimationController(self.state, self)
        self.exporter = ExportController(self.state, self.animator, self.documents, self)

        self._build_views()
        self._build_docks()
        self.tools = ToolsController(self.state, self.frame_view, self.documents, self)
        self.timeline.frames_to_check = self.tools.roto.frames_to_check
        self.addToolBar(self.tools.toolbar)
        self._build_menus()

        self._connect_messages()
        self._default_layout = self.saveState()
        self._views_fitted = False
        self._set_default_sizes()
        if remember_layout:
            self._restore_layout()
        self._update_title()

    def _build_views(self) -> None:
        """The footage and the rig side by side in the centre, and the docked widgets."""
        self.frame_view = FrameView(self.state, self.loader)
        self.timeline = TimelineWidget(self.state)
        self.pc_plot = PCPlotWidget(self.state)
        self.diagnosis = DiagnosisPanel(self.state)
        self.eigen = EigenImagesView(self.state)
        self.viewport = PoseViewport(self.state, self.loader, self.posing, self.animator,
                                     is_playing=lambda: self.player.playing)
        self.views = QSplitter(Qt.Orientation.Horizontal)  # footage and skeleton side by side
        self.views.addWidget(self.frame_view)
        self.views.addWidget(self.viewport)
        self.views.setChildrenCollapsible(False)
        self.frame_view.setMinimumSize(240, 180)
        self.setCentralWidget(self.views)
        self.pose_panel = PosePanel(self.state, self.posing)
        self.animation_view = AnimationView(self.state, self.animator, self.posing)

    def _build_docks(self) -> None:
        """Dock the widgets: timeline and weights below, loop and verdict right, posing left."""
        self.docks = {
            "timeline": self._dock("Timeline", self.timeline,
                                   Qt.DockWidgetArea.BottomDockWidgetArea),
            "animation": self._dock("Animation weights", self.animation_view,
                                    Qt.DockWidgetArea.BottomDockWidgetArea),
            "pcs": self._dock("Gait loop and key-images", self.pc_plot,
                              Qt.DockWidgetArea.RightDockWidgetArea),
            "diagnosis": self._dock("Diagnosis", self.diagnosis,
                                    Qt.DockWidgetArea.RightDockWidgetArea, scroll=True),
            "posing": self._dock("Posing", self.pose_panel, Qt.DockWidgetArea.LeftDockWidgetArea,
                                 scroll=True),
            "eigen": self._dock("Eigen-images", self.eigen, Qt.DockWidgetArea.LeftDockWidgetArea),
        }
        self.splitDockWidget(self.docks["timeline"], self.docks["animation"],
                             Qt.Orientation.Vertical)
        # The loop and the verdict are read together: one above the other, never tabbed.
        self.splitDockWidget(self.docks["pcs"], self.docks["diagnosis"], Qt.Orientation.Vertical)
        self.tabifyDockWidget(self.docks["posing"], self.docks["eigen"])
        self.docks["posing"].raise_()

    def _connect_messages(self) -> None:
        """Status-bar messages and the window title follow the controllers and the state."""
        for source in (self.frame_view, self.pc_plot, self.documents, self.posing):
            source.messageRaised.connect(self._show_message)
        self.state.analysisFailed.connect(self._show_message)
        self.state.undo_stack.cleanChanged.connect(self._update_title)
        self.state.pathChanged.connect(self._update_title)
        self.state.sourceChanged.connect(self._update_title)
        self.documents.recentChanged.connect(self._fill_recent)

    def reset_layout(self) -> None:
        """Every panel back where a first start puts it, at its size (View > Reset layout)."""
        self.set_large_footage(False)
        self.restoreState(self._default_layout)
        for dock in self.docks.values():
            dock.show()
        self.docks["posing"].raise_()
        self._set_default_sizes()

    def _fit_views(self) -> None:
        """The footage takes what the rig's viewport, its bars whole, leaves of the centre
        (once the window is shown: before, the splitter has no width yet)."""
        rig = self.viewport.minimumSizeHint().width()
        centre = self.views.width() - self.views.handleWidth()
        self._views_fitted = self.isVisible() and centre > rig
        if self._views_fitted:
            self.views.setSizes([centre - rig, rig])

    def showEvent(self, event) -> None:  # noqa: N802 - Qt API
        super().showEvent(event)
        if not self._views_fitted:
            self._fit_views()

    def _set_default_sizes(self) -> None:
        """The layout of a first start (a remembered one replaces it)."""
        self.resize(1500, 950)
        posing = max(self.pose_panel.minimumSizeHint().width(),
                     self.eigen.minimumSizeHint().width())  # the two tabs of that dock
        self.resizeDocks([self.docks["posing"], self.docks["pcs"]], [posing, LOOP_WIDTH],
                         Qt.Orientation.Horizontal)
        self.layout().activate()  # the docks at their new widths before the centre is split
        self._fit_views()
        self.resizeDocks([self.docks["timeline"], self.docks["animation"]], [70, 170],
                         Qt.Orientation.Vertical)
        self.resizeDocks([self.docks["pcs"], self.docks["diagnosis"]], [360, 300],
                         Qt.Orientation.Vertical)

    def _dock(self, title: str, widget: QWidget, area: Qt.DockWidgetArea, *,
              scroll: bool = False) -> QDockWidget:
        """A dock of ``widget``; with ``scroll`` (docks of text) a dock made small scrolls
        up and down instead of cutting the text off."""
        dock = QDockWidget(title, self)
        dock.setObjectName(title.split()[0].lower() + "Dock")
        if scroll:
            scroller = QScrollArea()
            scroller.setWidget(widget)
            scroller.setWidgetResizable(True)
            scroller.setFrameShape(QFrame.Shape.NoFrame)
            scroller.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
            widget = scroller
        dock.setWidget(widget)
        self.addDockWidget(area, dock)
        return dock

    # -- menus ---------------------------------------------------------------------------------
    def _action(self, menu: QMenu, text: str, shortcut, slot) -> QAction:
        action = menu.addAction(text)
        if shortcut is not None:
            action.setShortcut(QKeySequence(shortcut))
        action.triggered.connect(lambda _checked=False: slot())
        return action

    def _build_menus(self) -> None:
        bar = self.menuBar()
        self._build_file_menu(bar.addMenu("&File"))

        edit = bar.addMenu("&Edit")
        undo = self.state.undo_stack.createUndoAction(self, "&Undo")
        undo.setShortcut(QKeySequence.StandardKey.Undo)
        redo = self.state.undo_stack.createRedoAction(self, "&Redo")
        keys = QKeySequence.keyBindings(QKeySequence.StandardKey.Redo)  # Ctrl+Y on some desktops
        redo.setShortcuts(keys + [QKeySequence("Ctrl+Y")] * (QKeySequence("Ctrl+Y") not in keys))
        edit.addActions([undo, redo])

        play = bar.addMenu("&Playback")
        self.play_action = self._action(play, "Play / pause", Qt.Key.Key_Space, self.player.toggle)
        self._action(play, "Next frame", Qt.Key.Key_Right, lambda: self.player.step(1))
        self._action(play, "Previous frame", Qt.Key.Key_Left, lambda: self.player.step(-1))
        self._action(play, "First frame", Qt.Key.Key_Home, lambda: self.player.go_to(0))
        self._action(play, "Last frame", Qt.Key.Key_End, lambda: self.player.go_to(-1))
        self._action(play, "Next frame to chec&k", Qt.Key.Key_K, self._next_to_check)
        play.addSeparator()
        self._action(play, "Set &in mark", Qt.Key.Key_I, lambda: set_in_mark(self.state))
        self._action(play, "Set &out mark", Qt.Key.Key_O, lambda: set_out_mark(self.state))
        self._action(play, "Set &frame rate...", None, self._ask_frame_rate)

        self._build_pose_menu(bar.addMenu("P&ose"))

        tools = bar.addMenu("&Tools")
        tools.addActions(list(self.tools.tool_actions.values()))
        tools.addSeparator()
        tools.addActions([self.tools.segment_action, self.tools.copy_action,
                          self.tools.propagate_action, self.tools.sketch_action,
                          self.tools.sketch_engine_action])
        tools.addSeparator()
        tools.addActions([self.tools.load_profile_action, self.tools.save_profile_action])

        view = bar.addMenu("&View")
        for key, flag in (("silhouette", "Silhouette overlay"),
                          ("onion", "Onion skin (previous strokes)")):
            action = view.addAction(flag)
            action.setCheckable(True)
            action.setChecked(True)
            action.toggled.connect(lambda on, k=key: self.frame_view.set_overlays(**{k: on}))
        view.addSeparator()
        self.large_footage_action = view.addAction("&Large footage (for segmenting)")
        self.large_footage_action.setCheckable(True)
        self.large_footage_action.setShortcut(QKeySequence("Ctrl+Space"))
        self.large_footage_action.setToolTip("The footage over the whole window but the "
                                             "timeline, to draw the box and brush strokes at "
                                             "full size; again to bring the panels back")
        self.large_footage_action.toggled.connect(self.set_large_footage)
        self._action(view, "&Reset layout", None, self.reset_layout)
        view.addSeparator()
        for dock in self.docks.values():
            view.addAction(dock.toggleViewAction())
        view.addAction(self.tools.toolbar.toggleViewAction())

    def _build_file_menu(self, file: QMenu) -> None:
        self._action(file, "&Open project or video...", QKeySequence.StandardKey.Open,
                     self.open_dialog)
        self._action(file, "Open image or &mask folder...", "Ctrl+Shift+O", self.open_folder_dialog)
        self._action(file, "Open &batch summary...", None, self.open_batch_dialog)
        self.recent_menu = file.addMenu("Open &recent")
        self._fill_recent(self.documents.recent_files())
        file.addSeparator()
        self._action(file, "&Save", QKeySequence.StandardKey.Save, self.documents.save)
        self._action(file, "Save &as...", QKeySequence.StandardKey.SaveAs, self.documents.save_as)
        file.addSeparator()
        export = file.addMenu("&Export")
        self.export_actions = {
            suffix: self._action(export, f"{label}...", None,
                                 lambda s=suffix: self.exporter.export(s))
            for suffix, label in KINDS.items()
        }
        export.addSeparator()
        roto = self.tools.roto
        self._action(export, "Masks and segmentation.json...", None, roto.export_masks)
        self._action(export, "Scribbles (brush strokes)...", None, roto.export_scribbles)
        self._action(file, "&Import scribbles...", None, roto.import_scribbles)
        file.addSeparator()
        self._action(file, "&Quit", QKeySequence.StandardKey.Quit, self.close)

    def _build_pose_menu(self, pose: QMenu) -> None:
        posing = self.posing
        self._action(pose, "&Copy pose", "Ctrl+Alt+C", posing.copy)  # Ctrl+Shift+C: copy strokes
        self._action(pose, "&Paste pose", "Ctrl+Alt+V", posing.paste)
        self._action(pose, "Paste &mirrored pose", "Ctrl+Alt+M",
                     lambda: posing.paste(mirrored=True))
        self._action(pose, "M&irror left/right", "Ctrl+M", posing.mirror)
        self._action(pose, "Pose alternate as mirror of its &key", None, posing.mirror_of_key)
        self._action(pose, "&Reset pose", None, lambda: posing.reset(joint_only=False))
        self.library_action = pose.addAction("Drags fold legs, neck and tail as the &gait library")
        self.library_action.setCheckable(True)
        self.library_action.setChecked(posing.drags_use_library)
        self.library_action.setToolTip("A dragged hoof, head or tail tip starts its chain from the "
                                       "example poses nearest the target (the shipped gait "
                                       "library and the other keys), then IK reaches it")
        self.library_action.toggled.connect(posing.set_drags_use_library)
        pose.addSeparator()
        self._action(pose, "Import pose from &CSV...", None, posing.import_csv)
        self._action(pose, "Import pose from &BVH frame...", None, posing.import_bvh)
        pose.addSeparator()
        self._action(pose, "&Load rig from BVH...", None, posing.load_rig)
        axes = pose.addMenu("Rig &axes")  # when an imported rig's axes were read wrong
        for axis in AXES:
            forward = "+X" if axis[1] != "X" else ("-Y" if axis == "+X" else "+Y")
            self._action(axes, f"Up is the rig's {axis} as shown", None,
                         lambda a=axis, f=forward: posing.turn_rig(a, f))
        axes.addSeparator()
        for axis in ("+X", "-X", "+Z", "-Z"):
            self._action(axes, f"Forward is the rig's {axis} as shown", None,
                         lambda a=axis: posing.turn_rig("+Y", a))
        self._action(pose, "Use the &horse template", None, posing.use_template)

    def _fill_recent(self, files: list[str]) -> None:
        self.recent_menu.clear()
        for f in files:
            self.recent_menu.addAction(f).triggered.connect(
                lambda _c=False, p=f: self.open_path(Path(p)))
        self.recent_menu.setEnabled(bool(files))

    # -- file actions --------------------------------------------------------------------------
    def open_path(self, path: Path) -> bool:
        """Open a project or footage after saving or discarding unsaved changes."""
        return self.documents.may_close() and self.documents.open_path(path)

    def open_dialog(self) -> None:
        path = self.asker.open_path(self.state.path.parent if self.state.path else None)
        if path is not None:
            self.open_path(path)

    def open_folder_dialog(self) -> None:
        path = self.asker.open_folder(None)
        if path is not None:
            self.open_path(path)

    def open_batch_dialog(self) -> None:
        path = self.asker.open_file("Open batch summary", "Batch summaries (*.json *.csv)")
        if path is not None:
            self.open_batch_summary(path)

    def open_batch_summary(self, path: Path) -> BatchTableDialog | None:
        """Show a ``gaitcore batch`` summary; its clips open as projects from there."""
        try:
            rows = read_summary(path)
        except GaitInputError as exc:
            self.asker.error("Cannot open the batch summary", str(exc))
            return None
        self.batch_table = BatchTableDialog(rows, path, self)
        self.batch_table.clipChosen.connect(self.open_path)
        self.batch_table.messageRaised.connect(self._show_message)
        self.batch_table.show()
        return self.batch_table

    def offer_recovery(self) -> bool:
        """Offer the newest autosaved copy left by a crash; True when one was recovered."""
        copies = find_recovery_copies(self.autosaver.directory)
        for copy in copies:
            if self.asker.recover(copy.describe()):
                return self.documents.recover(copy)
            copy.discard()
        return False

    def is_ready(self) -> bool:
        """True once the footage's current frame is shown and the analysis is up to date."""
        state = self.state
        frame_ok = state.source is None or self.frame_view.shown_frame == state.frame
        silhouettes = state.project.silhouettes
        analysis_ok = silhouettes is None or (state.analysis is not None
                                              and not self.analysis.running)
        return frame_ok and analysis_ok and not self.runner.busy and not self.animator.pending

    def snapshot(self) -> QPixmap:
        """The window as shown, with the 3D view (``grab()`` leaves native GL windows out)."""
        pixmap = self.grab()
        container = self.viewport.gl_container
        if container is not None and container.isVisible():
            painter = QPainter(pixmap)
            rect = QRect(container.mapTo(self, QPoint(0, 0)), container.size())
            painter.drawImage(rect, self.viewport.gl_view.render_image())
            painter.end()
        return pixmap

    def _next_to_check(self) -> None:
        """Go to the next frame the segmentation says is worth a look (lost, or of a low
        confidence, and not corrected), after the current one and round to the start."""
        roto = self.tools.roto
        frames = roto.frames_to_check()
        if not frames:
            self._show_message(
                "no frame to check: every frame stands out about as well as its key frame"
                if roto.checks_known else
                "no frames to check yet: they are marked when the clip is segmented or "
                "corrected")
            return
        later = [f for f in frames if f > self.state.frame]
        self.player.go_to(later[0] if later else frames[0])
        self._show_message(f"frame {self.state.frame}: {len(frames)} frames to check "
                           "(faint red on the timeline)")

    def _ask_frame_rate(self) -> None:
        fps = self.asker.frame_rate(frame_rate(self.state.project, self.state.source))
        if fps is not None:
            self.state.undo_stack.push(FrameRateCommand(self.state, fps))

    # -- window --------------------------------------------------------------------------------
    def _show_message(self, message: str) -> None:
        self.statusBar().showMessage(message, 10_000)

    def _update_title(self, *_changed) -> None:
        state = self.state
        if state.path is not None:
            name = state.path.name
        elif state.project.footage is not None:
            name = f"{state.project.footage.name} (unsaved)"
        else:
            name = "untitled"
        self.setWindowTitle(f"{name}[*] — {APP_NAME}")
        self.setWindowModified(not state.undo_stack.isClean())

    def set_large_footage(self, on: bool) -> None:
        """The footage over the whole window but the timeline (the 3D viewport and the other
        panels hidden), or the layout from before it back."""
        if on and self._layout_before_large is None:
            self._layout_before_large = (self.saveState(), self.views.sizes())
            for name, dock in self.docks.items():
                if name != "timeline":
                    dock.hide()
            self.viewport.hide()
        elif not on and self._layout_before_large is not None:
            layout, sizes = self._layout_before_large
            self._layout_before_large = None
            self.viewport.show()
            self.restoreState(layout)
            self.views.setSizes(sizes)
        self.large_footage_action.setChecked(on)

    def _restore_layout(self) -> None:
        settings = QSettings()
        geometry, layout = settings.value("window/geometry"), settings.value("window/state")
        if geometry is not None:
            self.restoreGeometry(geometry)
        if layout is not None:
            self.restoreState(layout)

    def closeEvent(self, event) -> None:  # noqa: N802 - Qt API
        if not self.documents.may_close():
            event.ignore()
            return
        if self._remember_layout:
            settings = QSettings()
            settings.setValue("window/geometry", self.saveGeometry())
            # Closed with the footage large, the next start opens with the panels.
            before = self._layout_before_large
            settings.setValue("window/state", self.saveState() if before is None else before[0])
        self.player.stop()
        self.runner.shutdown()
        self.loader.stop()
        self.autosaver.discard()
        event.accept()
