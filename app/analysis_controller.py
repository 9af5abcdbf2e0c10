"""Keep the analysis in step with the project, off the GUI thread, latest request wins.

The computations are :mod:`gaitcore.project.steps`' ``analyze`` and ``rekey``. A change of
the silhouettes (or of the working size, the crops' framing, the frames brought back) reruns
the whole analysis (PCA, diagnosis, keys); a
change of the number of PCs or keys, of pinned or dropped keys or of switching only reruns
the key search on the projections already computed. Requests are coalesced for 80 ms (spin
boxes) and a newer one cancels the running one; a long one (a long clip's PCA) shows its
progress with Cancel.
"""

from __future__ import annotations

from PySide6.QtCore import QObject, QTimer

from app.state import AppState
from app.workers import Job, JobRunner, ProgressDialog
from gaitcore.analysis.analyze import Analysis, AnalysisSettings
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.steps import analyze, rekey

_COALESCE_MS = 80


class AnalysisController(QObject):
    """Recompute ``state.analysis`` whenever the silhouettes or the settings change."""

    def __init__(self, state: AppState, runner: JobRunner, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._runner = runner
        self._job: Job | None = None
        self._asked: tuple[Silhouettes | None, AnalysisSettings, tuple] | None = None
        self._analysed: tuple | None = None  # silhouettes and trim of state.analysis
        self._timer = QTimer(self, singleShot=True, interval=_COALESCE_MS)
        self._timer.timeout.connect(self._start)
        state.projectChanged.connect(self._on_project)
        state.projectOpened.connect(self._cancel)

    @property
    def running(self) -> bool:
        """True while a computation is pending or running."""
        return self._timer.isActive() or self._job is not None

    def _on_project(self, project: Project) -> None:
        wanted = (project.silhouettes, project.settings, project.trim)
        if (self._asked is not None and wanted[0] is self._asked[0]
                and wanted[1:] == self._asked[1:]):
            return
        self._asked = wanted
        if project.silhouettes is None:
            self._cancel()
            if self._state.analysis is not None:
                self._state.set_analysis(None)
            return
        self._timer.start()

    def _cancel(self, *_opened) -> None:
        self._timer.stop()
        if self._job is not None:
            self._job.cancel()
            self._job = None
        self._asked = None

    def _start(self) -> None:
        if self._asked is None:  # cancelled since the timer was started
            return
        if self._job is not None:
            self._job.cancel()
        silhouettes, settings, trim = self._asked
        current = self._state.analysis
        if current is not None and self._analysed is not None and (
                self._analysed[0] is silhouettes and self._analysed[1] == trim
                and current.settings.framing_key == settings.framing_key):
            job = Job(lambda progress: rekey(current, settings, progress=progress),
                      "Choosing key-images", unit=None)
        else:
            job = Job(lambda progress: analyze(silhouettes, settings, progress, trim=trim),
                      "Analysing the clip", unit=None)
        job.succeeded.connect(lambda result, j=job, s=(silhouettes, trim): self._done(j, s, result))
        job.failed.connect(lambda message, j=job: self._failed(j, message))
        job.cancelled.connect(lambda j=job: self._finished(j))
        self._job = job
        ProgressDialog(job, self.parent())  # shows itself only past 300 ms
        self._runner.start(job)

    def _done(self, job: Job, analysed: tuple, analysis: Analysis) -> None:
        if job is self._job:
            self._job = None
            self._analysed = analysed
            self._state.set_analysis(analysis)

    def _failed(self, job: Job, message: str) -> None:
        if job is self._job:
            self._job = None
            self._state.analysisFailed.emit(message)

    def _finished(self, job: Job) -> None:
        if job is self._job:
            self._job = None
