"""Work off the GUI thread: cancellable jobs with progress, and the latest-wins frame loader.

A :class:`Job` runs a gaitcore callable that takes the ``progress(done, total) -> bool``
protocol on a thread pool; results, one-line errors and cancellation come back as signals
(queued to the GUI thread). :class:`ProgressDialog` shows a job with a Cancel button.
:class:`FrameLoader` decodes frames on its own thread and always the newest request only.
"""

from __future__ import annotations

import sys
import threading
import time
import traceback
from collections.abc import Callable

from PySide6.QtCore import QCoreApplication, QEvent, QObject, Qt, QThread, QThreadPool, Signal
from PySide6.QtWidgets import QProgressDialog, QWidget

from gaitcore.errors import GaitInputError
from gaitcore.footage.sources import FrameSource
from gaitcore.progress import Cancelled, Progress

_PROGRESS_INTERVAL_S = 0.03


class Job(QObject):
    """One background computation, ``fn(progress)``.

    ``unit`` names what ``progress`` counts (shown as "done of total unit"); None when the
    counts are only a scale (shown as a percentage).

    Signals
    -------
    progressed(int, int)
        ``done`` and ``total`` (total 0: unknown), at most every 30 ms.
    succeeded(object)
        The value ``fn`` returned.
    failed(str)
        A one-line message for the artist (``GaitInputError``, or an unexpected error whose
        traceback goes to stderr).
    cancelled()
        ``fn`` stopped because :meth:`cancel` was called.
    finished()
        After any of the three above.
    """

    progressed = Signal(int, int)
    succeeded = Signal(object)
    failed = Signal(str)
    cancelled = Signal()
    finished = Signal()

    def __init__(self, fn: Callable[[Progress], object], title: str, *,
                 unit: str | None = "frames") -> None:
        super().__init__()
        self.title = title
        self.unit = unit
        self._fn = fn
        self._cancel = threading.Event()
        self._last_emit = 0.0

    def cancel(self) -> None:
        """Ask the job to stop at its next progress report."""
        self._cancel.set()

    def _progress(self, done: int, total: int) -> bool:
        now = time.monotonic()
        if now - self._last_emit >= _PROGRESS_INTERVAL_S or (total and done >= total):
            self._last_emit = now
            self.progressed.emit(int(done), int(total))
        return not self._cancel.is_set()

    def run(self) -> None:
        """Run ``fn`` in the calling thread (the pool calls this) and report by signals."""
        try:
            result = self._fn(self._progress)
        except Cancelled:
            self.cancelled.emit()
        except GaitInputError as exc:
            self.failed.emit(str(exc))
        except Exception as exc:  # noqa: BLE001 - any bug must reach the artist, not kill Qt
            traceback.print_exc(file=sys.stderr)
            self.failed.emit(f"{self.title} failed unexpectedly ({type(exc).__name__}: {exc})")
        else:
            if self._cancel.is_set():
                self.cancelled.emit()
            else:
                self.succeeded.emit(result)
        finally:
            self.finished.emit()


class JobRunner(QObject):
    """Start jobs on a private thread pool and keep them alive until they finish.

    Notes
    -----
    No signal of this module carries a Python bool: with PySide6 6.12 on CPython 3.11, each
    emission of ``True`` or ``False`` through a Python-defined signal loses a reference to it,
    until the interpreter aborts (``bool_dealloc``). Qt's own bool signals are not affected.
    """

    def __init__(self, parent: QObject | None = None, max_threads: int = 2) -> None:
        super().__init__(parent)
        self._pool = QThreadPool(self)
        self._pool.setMaxThreadCount(max_threads)
        self._jobs: set[Job] = set()

    @property
    def busy(self) -> bool:
        return bool(self._jobs)

    def start(self, job: Job) -> Job:
        """Run ``job`` on the pool; returns it (connect its signals before or right after)."""
        self._jobs.add(job)
        job.finished.connect(lambda j=job: self._jobs.discard(j))
        self._pool.start(job.run)
        return job

    def shutdown(self) -> None:
        """Cancel every job, wait for the threads and deliver their last signals (at window close).

        A job's signals are queued to the GUI thread. Those its thread emitted while this
        waited are delivered here, while their receivers still live, not after the caller has
        deleted them.
        """
        for job in list(self._jobs):
            job.cancel()
        self._pool.waitForDone()
        QCoreApplication.sendPostedEvents(None, QEvent.Type.MetaCall)


class ProgressDialog(QProgressDialog):
    """A non-modal progress bar with Cancel for one job; closes itself when the job ends.

    Non-modal on purpose: a modal QProgressDialog spins the event loop inside ``setValue``.
    """

    def __init__(self, job: Job, parent: QWidget | None = None) -> None:
        super().__init__(job.title + "...", "Cancel", 0, 0, parent)
        self.setWindowTitle(job.title)
        self.setWindowModality(Qt.WindowModality.NonModal)
        self.setMinimumDuration(300)
        self.setAutoClose(False)
        self.setAutoReset(False)
        self._job = job
        job.progressed.connect(self._on_progress)
        job.finished.connect(self._on_finished)
        self.canceled.connect(job.cancel)

    def _on_progress(self, done: int, total: int) -> None:
        if self.maximum() != total:
            self.setMaximum(max(total, 0))
        self.setValue(min(done, total) if total else 0)
        self.setLabelText(self._label(done, total))

    def _label(self, done: int, total: int) -> str:
        if not total:
            return self._job.title + "..."
        if self._job.unit is None:
            return f"{self._job.title}: {100 * min(done, total) // total} %"
        return f"{self._job.title}: {done} of {total} {self._job.unit}"

    def _on_finished(self) -> None:
        self.canceled.disconnect(self._job.cancel)
        self.reset()
        self.hide()
        self.deleteLater()


class FrameLoader(QThread):
    """Decode frames on a thread of their own; only the newest request is ever decoded.

    Signals
    -------
    frameLoaded(int, object)
        Frame index and BGR array (read-only) of a finished request.
    loadFailed(int, str)
        Frame index and a one-line message when decoding failed.
    """

    frameLoaded = Signal(int, object)
    loadFailed = Signal(int, str)

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._cond = threading.Condition()
        self._source: FrameSource | None = None
        self._pending: int | None = None
        self._stopping = False

    def set_source(self, source: FrameSource | None) -> None:
        """Decode from ``source`` from now on; a pending request is dropped."""
        with self._cond:
            self._source = source
            self._pending = None

    def request(self, index: int) -> None:
        """Ask for frame ``index``; an older request not yet started is forgotten."""
        with self._cond:
            self._pending = int(index)
            self._cond.notify()
        if not self.isRunning():
            self.start()

    def stop(self) -> None:
        """End the thread (waits for the frame being decoded)."""
        with self._cond:
            self._stopping = True
            self._cond.notify()
        self.wait()

    def run(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._stopping:
                    self._cond.wait()
                if self._stopping:
                    return
                index, source, self._pending = self._pending, self._source, None
            if source is None:
                continue
            try:
                image = source.frame(index)
            except (GaitInputError, IndexError) as exc:
                self.loadFailed.emit(index, str(exc))
                continue
            with self._cond:
                stale = source is not self._source
            if not stale:
                self.frameLoaded.emit(index, image)
