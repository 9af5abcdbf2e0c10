"""Opening, saving and recovering projects, and the list of recent files.

The controller does the work and leaves every question to :class:`app.dialogs.Asker`. A
project that cannot be read (damaged, newer version) is reported and never written over:
the window simply keeps what it had.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from PySide6.QtCore import QObject, QSettings, Signal

from app.autosave import Autosaver, RecoveryCopy
from app.dialogs import Asker
from app.state import AppState
from app.workers import Job, JobRunner, ProgressDialog
from gaitcore.errors import GaitInputError
from gaitcore.footage.sources import DEFAULT_FPS
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.footage_fit import facing_travel
from gaitcore.project.steps import frame_rate, open_source, silhouettes_from_masks
from gaitcore.project.storage import SUFFIX, load_project, missing_footage, save_project
from gaitcore.silhouettes.extract import is_mask_folder

MAX_RECENT = 8


class DocumentController(QObject):
    """File operations of the main window.

    Signals
    -------
    recentChanged(list)
        The recent files (list of str), newest first.
    messageRaised(str)
        A line for the status bar.
    projectSaved(Path)
        The project was written to this file (what goes beside it, such as the segmentation
        engine, may follow).
    """

    recentChanged = Signal(list)
    messageRaised = Signal(str)
    projectSaved = Signal(object)

    def __init__(self, state: AppState, asker: Asker, runner: JobRunner, autosaver: Autosaver,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self.asker = asker
        self._runner = runner
        self.autosaver = autosaver

    # -- opening ----------------------------------------------------------------------------
    def open_path(self, path: Path) -> bool:
        """Open a project file, a video, an image folder or a folder of masks."""
        path = Path(path)
        if path.suffix == SUFFIX:
            return self.open_project(path)
        return self.open_footage(path)

    def open_footage(self, path: Path) -> bool:
        """Start a new project on footage; a folder of binary masks is tracked at once."""
        try:
            masks = is_mask_folder(path)
            project = Project(footage=path.absolute())
            source = open_source(project)
        except GaitInputError as exc:
            self.asker.error("Cannot open footage", str(exc))
            return False
        if source is not None and source.fps is None:  # an image folder says no rate
            fps = self.asker.frame_rate(frame_rate(project, source))
            if fps is not None:
                project = replace(project, fps=fps)
            else:
                self.messageRaised.emit(f"frame rate unknown: {DEFAULT_FPS:g} fps assumed "
                                        "(Playback > Set frame rate)")
        self._state.open(project, None, source)
        self._add_recent(path)
        if source is not None and source.note:
            self.messageRaised.emit(source.note)
        if masks:
            self.run(Job(lambda progress: silhouettes_from_masks(path, progress),
                         "Tracking the masks"),
                     lambda sil: self._set_initial_silhouettes(project, sil))
        return True

    def open_project(self, path: Path, *, recovered: RecoveryCopy | None = None) -> bool:
        """Open a project file; a damaged or newer file is reported and left untouched."""
        try:
            project = recovered.load() if recovered else load_project(path)
        except GaitInputError as exc:
            self.asker.error("Cannot open project", str(exc))
            return False
        moved = missing_footage(project)
        if moved is not None:
            new = self.asker.locate_footage(moved)
            project = replace(project, footage=new.absolute() if new else None)
        try:
            source = open_source(project)
        except GaitInputError as exc:
            self.asker.error("Cannot open the footage", str(exc))
            project, source = replace(project, footage=None), None
        self._state.open(project, None if recovered and not recovered.original else path, source)
        if moved is not None or recovered is not None:
            self._state.undo_stack.resetClean()  # relocated or recovered: not saved yet
        else:
            self._add_recent(path)
        return True

    def open_demo(self, project: Project) -> None:
        """Show a ready-made project (the demo) as unsaved and unchanged."""
        self._state.open(project, None, open_source(project))

    def recover(self, copy: RecoveryCopy) -> bool:
        """Open an autosaved copy in place of its project, unsaved; the copy is deleted."""
        ok = self.open_project(copy.original or copy.project_file, recovered=copy)
        if ok:
            copy.discard()
        return ok

    # -- saving -----------------------------------------------------------------------------
    def save(self) -> bool:
        """Save to the current path (asks for one the first time)."""
        if self._state.path is None:
            return self.save_as()
        return self._save_to(self._state.path)

    def save_as(self) -> bool:
        suggested = self._state.path or Path.cwd() / f"untitled{SUFFIX}"
        path = self.asker.save_path(suggested)
        return path is not None and self._save_to(path)

    def _save_to(self, path: Path) -> bool:
        try:
            save_project(self._state.project, path)
        except GaitInputError as exc:
            self.asker.error("Cannot save project", str(exc))
            return False
        self._state.set_path(path)
        self._state.undo_stack.setClean()
        self.autosaver.discard()
        self._add_recent(path)
        self.projectSaved.emit(Path(path))
        self.messageRaised.emit(f"saved {path}")
        return True

    def may_close(self) -> bool:
        """True when the project has no unsaved change, or the artist saved or discarded it."""
        if self._state.undo_stack.isClean():
            return True
        footage = self._state.project.footage
        name = (self._state.path.name if self._state.path
                else f"the new project on {footage.name}" if footage is not None
                else "the untitled project")
        answer = self.asker.save_changes(name)
        return answer == "discard" or (answer == "save" and self.save())

    # -- jobs and recent files --------------------------------------------------------------
    def run(self, job: Job, on_success, *, tied: bool = True) -> Job:
        """Run ``job`` with a progress dialog; errors are shown, success calls ``on_success``.

        A ``tied`` job belongs to the project open when it starts: opening another project
        cancels it, and a result that arrives after that is dropped, never attached to the
        new project. An export (its files are written by the job itself) is not tied.
        """
        if tied:
            opened = self._state.opened_count

            def land(result, on_success=on_success) -> None:
                if self._state.opened_count == opened:
                    on_success(result)
                else:
                    self.messageRaised.emit(f"{job.title}: dropped, its project was closed")

            self._state.projectOpened.connect(job.cancel)
            job.finished.connect(lambda: self._state.projectOpened.disconnect(job.cancel))
            on_success = land
        job.succeeded.connect(on_success)
        job.failed.connect(lambda message: self.asker.error(job.title, message))
        job.cancelled.connect(lambda: self.messageRaised.emit(f"{job.title}: cancelled"))
        ProgressDialog(job, self.parent())
        return self._runner.start(job)

    def _set_initial_silhouettes(self, opened: Project, silhouettes: Silhouettes) -> None:
        """Give the freshly opened mask folder its silhouettes, unless another was opened."""
        if self._state.project is opened:
            self._state.set_project(replace(
                opened, silhouettes=silhouettes,
                footage_fit=facing_travel(opened.footage_fit, silhouettes)))

    def recent_files(self) -> list[str]:
        value = QSettings().value("recentFiles", [])
        files = [value] if isinstance(value, str) else list(value or [])
        return [f for f in files if f]

    def _add_recent(self, path: Path) -> None:
        entry = str(Path(path).absolute())
        files = [entry] + [f for f in self.recent_files() if f != entry]
        QSettings().setValue("recentFiles", files[:MAX_RECENT])
        self.recentChanged.emit(files[:MAX_RECENT])
