"""Segmentation from a box, corrected by brush strokes on any frame (the Roto Brush model).

The controller keeps the project's :class:`~gaitcore.project.roto_session.RotoSession` (the
engine of the last segmentation) and runs on it, as jobs with progress and Cancel: segmenting
the clip, re-propagating a brush correction or the erasing of brush strokes (one undo step:
the strokes and the silhouettes they changed), the first frame's cut-out before the clip
runs, exporting masks and ``segmentation.json``, and importing or exporting scribbles files.
Everything it computes is :mod:`gaitcore.project.roto_session`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject

from app.commands import (
    AddScribblesCommand,
    EraseScribblesCommand,
    ProjectCommand,
    SetSilhouettesCommand,
)
from app.document import DocumentController
from app.state import AppState
from app.widgets.frame_view import FrameView
from app.workers import Job
from gaitcore.errors import GaitInputError
from gaitcore.io.scribbles import read_scribbles, write_scribbles
from gaitcore.project.engine_file import resumed, save_engine, saved_frames_to_check
from gaitcore.project.roto_session import (
    RotoSession,
    corrected,
    erased,
    export_masks,
    preview_first_frame,
    segmentation_key,
    sketch_as_scribbles,
)
from gaitcore.project.steps import check_segmentation_input
from gaitcore.silhouettes.annotations import Scribble, Stroke, check_scribbles
from gaitcore.silhouettes.saliency import saliency_missing

SCRIBBLES_FILTER = "Scribbles (*.json)"


class RotoController(QObject):
    """Segment, correct, preview, export and import; see the module docstring."""

    def __init__(self, state: AppState, view: FrameView, documents: DocumentController,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._view = view
        self._documents = documents
        self._session: RotoSession | None = None
        self._checked: tuple[object, tuple[int, ...]] = (None, ())
        self._saved_check: tuple[tuple | None, tuple[int, ...]] = (None, ())
        self._running: Job | None = None
        self._pending: list[Scribble] = []
        self._landed = False
        self._preview_key: tuple | None = None
        self._opened_from: Path | None = None
        self.previewing: Job | None = None
        view.scribblePainted.connect(self.paint)
        view.scribblesErased.connect(self.erase)
        state.projectOpened.connect(self._forget)
        documents.projectSaved.connect(self._save_engine)
        state.projectChanged.connect(self._refresh_preview)

    @property
    def busy(self) -> bool:
        """A segmentation, a correction or a masks export is running (they share the
        engine: one at a time)."""
        return self._running is not None

    @property
    def session(self) -> RotoSession | None:
        """The engine of the last segmentation or correction (None before one)."""
        return self._session

    @property
    def checks_known(self) -> bool:
        """Whether :meth:`frames_to_check` knows the project's segmentation: one ran (or
        was corrected) in this session of the app, or its states were saved with the
        project's engine."""
        return (self._session is not None
                or self._saved_check[0] == segmentation_key(self._state.project))

    def frames_to_check(self) -> tuple[int, ...]:
        """The frames of the project's segmentation worth a look (lost, or of a low
        confidence, and not corrected: :meth:`RotoSession.to_check`), for the timeline. Before
        a segmentation or a correction in this session of the app, those saved with the
        project's engine (:func:`saved_frames_to_check`) while its segmentation inputs are
        the ones opened, else none. While a job changes the engine, those of the project it
        started from."""
        project = self._state.project
        if self._checked[0] is project or (self._running is not None and not self._landed):
            return self._checked[1]
        if self._session is not None:
            self._checked = (project, self._session.to_check(project))
        else:
            self._checked = (project, self._saved_check[1] if self.checks_known else ())
        return self._checked[1]

    def _forget(self, *_opened) -> None:
        """A project was opened: its engine, if saved with it, is put back by the first
        correction (in its job), never before; the frames to check saved with it are marked
        at once."""
        self._session, self._pending, self._preview_key = None, [], None
        self._checked = (None, ())
        self._opened_from = path = self._state.path
        project = self._state.project
        saved = None if path is None else saved_frames_to_check(path, project)
        self._saved_check = (None if saved is None else segmentation_key(project), saved or ())
        self._view.set_pending(())
        self._view.set_preview(None)
        self._say_how_many_to_check()

    def _say_how_many_to_check(self) -> None:
        """Tell the artist how many frames are marked to check, when any are, and that the
        silhouettes were cut without the salient-object network when it is missing."""
        parts = []
        if check := self.frames_to_check():
            frames = "frame" if len(check) == 1 else "frames"
            parts.append(f"{len(check)} {frames} to check (faint red on the timeline): K goes to "
                         "the next")
        if missing := saliency_missing():
            parts.append(missing)
        if parts:
            self._documents.messageRaised.emit("; ".join(parts))

    def _save_engine(self, path: Path) -> None:
        """Keep the engine of the project just saved beside its file (a running job changes
        the engine: then only an engine saved before is kept, if it still matches)."""
        session = None if self._running is not None else self._session
        try:
            save_engine(path, self._state.project, session, opened_from=self._opened_from)
        except GaitInputError as exc:
            self._documents.messageRaised.emit(str(exc))
        self._opened_from = path

    # -- segmenting -------------------------------------------------------------------------
    def segment(self) -> Job | None:
        """Segment the whole clip in the background; the result is an undoable command."""
        state, project, source = self._state, self._state.project, self._state.source
        if source is None:
            self._documents.messageRaised.emit("open footage first")
            return None
        try:
            check_segmentation_input(project)
        except GaitInputError:
            self._documents.asker.error(
                "Segment clip", "Draw a box around the animal (A) on the first frame, or at "
                "least one subject rectangle (Shift+S) and one background rectangle "
                "(Shift+B), then segment again.")
            return None
        if self._running is not None:
            return self._running

        def work(progress):
            session = RotoSession.start(source, project, progress)
            return session, session.silhouettes()

        job = Job(work, "Segmenting the clip", unit=None)  # passes over frames: per cent
        return self._start(job, project, lambda sil: state.undo_stack.push(
            SetSilhouettesCommand(state, sil, "segment clip")))

    # -- brush corrections ------------------------------------------------------------------
    def paint(self, scribble: Scribble) -> Job | None:
        """A brush stroke: re-propagates the segmentation when the clip is segmented (one
        undo step), otherwise it is kept for the next segmentation (and the first frame's
        cut-out is shown again)."""
        return self.add_scribbles([scribble], "paint")

    def add_scribbles(self, scribbles: list[Scribble], verb: str) -> Job | None:
        """Add brush strokes as one undo step, re-propagating when the clip is segmented."""
        state, project, source = self._state, self._state.project, self._state.source
        if not scribbles:
            return None
        labels = {sc.label for sc in scribbles}
        what = labels.pop() if len(labels) == 1 else "brush"
        text = f"{verb} {what} stroke" + ("s" if len(scribbles) > 1 else "")
        sil = project.silhouettes
        if source is None or sil is None or sil.origin != "segmented":
            state.undo_stack.push(AddScribblesCommand(state, scribbles, text))
            return None
        if self._running is not None:  # one correction at a time; these go next
            self._pending += scribbles
            self._view.set_pending(tuple(self._pending))
            self._documents.messageRaised.emit("re-propagating: the stroke follows when the "
                                               "running correction ends")
            return self._running
        frames = sorted({sc.frame for sc in scribbles})
        return self._repropagate(
            f"Re-propagating the correction of frame {frames[0]}",
            lambda use, progress: corrected(use, source, project, scribbles, progress),
            lambda new: state.undo_stack.push(
                AddScribblesCommand(state, scribbles, text, silhouettes=new)))

    def erase(self, indices: set[int], strokes: tuple[Stroke, ...] = ()) -> Job | None:
        """Erase brush strokes (positions in the project's scribbles), and the sketch
        ``strokes`` the same eraser drag went over, as one undo step, re-propagating without
        them when the clip is segmented; refused while a correction runs (the strokes'
        positions would change under it)."""
        state, project, source = self._state, self._state.project, self._state.source
        if not indices:
            return None
        sil = project.silhouettes
        if source is None or sil is None or sil.origin != "segmented":
            state.undo_stack.push(EraseScribblesCommand(state, indices, strokes=strokes))
            return None
        if self._running is not None:
            self._documents.messageRaised.emit("re-propagating: erase the stroke again when "
                                               "the running correction ends")
            return None
        plural = "s" if len(indices) > 1 else ""
        self._view.set_erasing(tuple(project.scribbles[i] for i in sorted(indices)), strokes)
        return self._repropagate(
            f"Re-propagating without the erased stroke{plural}",
            lambda use, progress: erased(use, source, project, indices, progress),
            lambda new: state.undo_stack.push(
                EraseScribblesCommand(state, indices, silhouettes=new, strokes=strokes)))

    def _repropagate(self, title: str, change, push) -> Job:
        """Re-propagate the project's segmentation in a job: ``change(session, progress)``
        edits the engine of the project (this session's, or the one saved beside the file
        it was opened from; None when there is neither) and returns it; ``push(silhouettes)``
        lands the result as one undo step."""
        source, project = self._state.source, self._state.project
        session, saved = self._session, self._opened_from

        def work(progress):
            done = change(resumed(session, source, project, saved=saved), progress)
            return done, done.silhouettes()

        return self._start(Job(work, title, unit=None), project, push)

    def _start(self, job: Job, project, push) -> Job:
        """Run a segmentation job; its result lands only on the project it was made for."""
        key = segmentation_key(project)

        def land(result) -> None:
            session, silhouettes = result
            self._session, self._landed, self._checked = session, True, (None, ())
            if segmentation_key(self._state.project) != key:
                self._documents.messageRaised.emit(
                    "the project changed while segmenting: the result was dropped, try again")
                return
            push(silhouettes)
            self._say_how_many_to_check()

        self._running, self._landed = job, False
        job.finished.connect(self._finished)
        return self._documents.run(job, land)

    def _finished(self) -> None:
        """Run the strokes painted meanwhile; after a cancel or a failure they are dropped."""
        self._running = None
        pending, self._pending = self._pending, []
        self._view.set_pending(())
        self._view.set_erasing(())
        if pending and self._landed:
            self.add_scribbles(pending, "paint")
        elif pending:
            self._documents.messageRaised.emit(f"{len(pending)} stroke(s) painted during the "
                                               "correction were dropped with it")

    def propagate_sketch(self) -> Job | None:
        """The strokes sketched on the current frame, through the segmentation engine in one
        action: they become subject brush strokes there and re-propagate (one undo step); on
        a clip not segmented yet, sketched on the first frame, a box around them is drawn
        with them (one undo step) and the clip is segmented."""
        state, project, source = self._state, self._state.project, self._state.source
        if source is None:
            self._documents.messageRaised.emit("open footage first")
            return None
        try:
            scribbles, box = sketch_as_scribbles(project.strokes_on(state.frame),
                                                 source.shape[:2])
        except GaitInputError as exc:
            self._documents.messageRaised.emit(str(exc))
            return None
        if project.silhouettes is not None and project.silhouettes.origin == "segmented":
            return self.add_scribbles(scribbles, "propagate sketched")
        try:
            check_segmentation_input(project)
        except GaitInputError:
            if state.frame != 0:
                self._documents.asker.error(
                    "Propagate the sketch", "sketch the animal on the first frame, or draw a "
                    "box around it there (A), then propagate")
                return None
            project = replace(project, box=box)
        state.undo_stack.push(ProjectCommand(state, project.with_scribbles(tuple(scribbles)),
                                             "sketch as subject strokes", frame=state.frame))
        return self.segment()

    # -- first frame ------------------------------------------------------------------------
    def _refresh_preview(self, project) -> None:
        """Cut the first frame again when its inputs changed and the clip is not segmented."""
        source = self._state.source
        if project.silhouettes is not None or source is None:
            return
        key = segmentation_key(replace(project, scribbles=project.scribbles_on(0)))
        if key == self._preview_key:
            return
        self._preview_key = key
        try:
            check_segmentation_input(project)
        except GaitInputError:
            self._view.set_preview(None)
            return
        self.preview(project)

    def preview(self, project) -> Job:
        """The first frame's cut-out from the box (or rectangles) and frame 0's strokes."""
        source, key = self._state.source, self._preview_key

        def show(mask: np.ndarray) -> None:
            if key == self._preview_key:
                self._view.set_preview(mask)

        job = Job(lambda progress: preview_first_frame(source, project, progress),
                  "Cutting out the first frame")
        self.previewing = job
        return self._documents.run(job, show)

    # -- files ------------------------------------------------------------------------------
    def export_masks(self, folder: Path | None = None) -> Job | None:
        """Write ``masks/00000.png``... and ``segmentation.json`` into a folder, as
        ``gaitcore segment`` does (the clip is segmented again when the session was lost)."""
        state, project, source = self._state, self._state.project, self._state.source
        title = "Export masks"
        if (source is None or project.silhouettes is None
                or project.silhouettes.origin != "segmented"):
            self._documents.asker.error(title, "segment the clip first (Tools > Segment clip); "
                                        "nothing was exported")
            return None
        if self._running is not None:
            self._documents.messageRaised.emit("wait for the segmentation to finish, then "
                                               "export the masks")
            return None  # the job running uses the engine
        if folder is None:
            base = state.path or project.footage
            folder = self._documents.asker.export_folder(
                title, Path(base).with_name(Path(base).stem + "_segmentation"))
            if folder is None:
                return None
        session, name, saved = self._session, str(project.footage), self._opened_from

        def work(progress):
            use = resumed(session, source, project, saved=saved) or \
                RotoSession.start(source, project, progress)
            return export_masks(use, folder, source_name=name, progress=progress)

        job = Job(work, title)
        self._running, self._landed = job, True  # strokes painted meanwhile go next
        job.finished.connect(self._finished)
        return self._documents.run(job, lambda n: self._documents.messageRaised.emit(
            f"exported {n} masks and segmentation.json to {folder}"), tied=False)

    def export_scribbles(self, path: Path | None = None) -> bool:
        """Write the project's brush strokes as a scribbles file."""
        project, asker = self._state.project, self._documents.asker
        if not project.scribbles:
            asker.error("Export scribbles", "the project has no brush strokes; nothing was "
                        "exported")
            return False
        if path is None:
            base = self._state.path or project.footage or Path.cwd() / "untitled"
            path = asker.export_path("Export scribbles",
                                     Path(base).with_name(Path(base).stem + "_scribbles.json"),
                                     SCRIBBLES_FILTER)
            if path is None:
                return False
        try:
            write_scribbles(path, project.scribbles)
        except OSError as exc:
            asker.error("Export scribbles", f"cannot write {path}: {exc.strerror or exc}")
            return False
        self._documents.messageRaised.emit(f"exported {len(project.scribbles)} strokes to {path}")
        return True

    def import_scribbles(self, path: Path | None = None) -> Job | None:
        """Add the strokes of a scribbles file (one undo step; a bad file changes nothing)."""
        state, asker = self._state, self._documents.asker
        if state.source is None:
            asker.error("Import scribbles", "open the footage the strokes were painted on first")
            return None
        if path is None:
            path = asker.open_file("Import scribbles", SCRIBBLES_FILTER)
            if path is None:
                return None
        try:
            scribbles = read_scribbles(path, n_frames=state.n_frames)
            check_scribbles(scribbles, state.n_frames, state.source.shape[:2])
        except GaitInputError as exc:
            asker.error("Import scribbles", f"{exc}; nothing was imported")
            return None
        if not scribbles:
            self._documents.messageRaised.emit(f"{path} holds no strokes")
            return None
        return self.add_scribbles(scribbles, "import")
