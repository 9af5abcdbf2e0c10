"""Run a batch of clips on Dask: a local cluster of worker processes, or any running scheduler.

The clips are independent tasks (:func:`gaitcore.project.batch.analyze_clip`, one per clip)
submitted to a ``dask.distributed`` client. By default the client starts a
``LocalCluster`` of single-threaded worker processes sized to the machine; given a
scheduler's address it connects to that cluster instead, and the rest is the same code.
Workers write each clip's folder themselves (so they need the footage and the output
folder at the same paths: a shared file system on a cluster); the client only keeps the
summary, rewritten atomically as results arrive, so an interrupted batch leaves a
consistent summary and a rerun skips the clips already done.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from gaitcore.analysis.analyze import AnalysisSettings
from gaitcore.errors import GaitInputError
from gaitcore.progress import Progress, report
from gaitcore.project.batch import (
    ClipSummary,
    analyze_clip,
    failed,
    finished_result,
    pending,
    remove_partial_folders,
    write_summary,
)
from gaitcore.project.manifest import LOCK_NAME, ClipSpec, Manifest
from gaitcore.silhouettes.settings import SegmentationSettings

SUMMARY_EVERY_S = 1.0
"""Shortest interval between two rewrites of the summary while results arrive."""
CONNECT_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class BatchResult:
    """What a batch run did.

    Attributes
    ----------
    rows : tuple of ClipSummary
        The summary, in manifest order (bad rows last).
    computed : int
        Clips analysed by this run.
    skipped : int
        Clips whose outputs were already complete.
    """

    rows: tuple[ClipSummary, ...]
    computed: int
    skipped: int


def default_workers() -> int:
    """Worker processes for a local cluster: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def run_batch(manifest: Manifest, out_dir: Path, *, scheduler: str | None = None,
              workers: int | None = None, settings: AnalysisSettings = AnalysisSettings(),
              segmentation: SegmentationSettings = SegmentationSettings(),
              progress: Progress | None = None,
              notify: Callable[[str], None] | None = None) -> BatchResult:
    """Analyse every clip of ``manifest`` into ``out_dir`` on Dask.

    Parameters
    ----------
    manifest : Manifest
    out_dir : Path
        Gets ``<clip>/`` per clip, ``summary.csv`` and ``summary.json``.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); None starts a local
        cluster of ``workers`` processes.
    workers : int, optional
        Worker processes of the local cluster (default: :func:`default_workers`, and never
        more than the clips to run).
    settings : AnalysisSettings
    segmentation : SegmentationSettings
        The profile colour footage is segmented with; a clip done with another runs again.
    progress : callable(done, total) -> bool, optional
        Called as clips finish (skipped ones count as done); False cancels.
    notify : callable(str), optional
        Receives lines worth showing: the dashboard's address, each clip's outcome.

    Raises
    ------
    GaitInputError
        The scheduler cannot be reached, or the output folder cannot be written.
    Cancelled, KeyboardInterrupt
        The summary is written first, with the clips not finished marked ``pending``.
    """
    out_dir = Path(out_dir).absolute()  # a remote worker has a working folder of its own
    say = notify or (lambda line: None)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GaitInputError(f"cannot create the output folder {out_dir}: {exc.strerror}") from None
    with batch_lock(out_dir):
        return _run_locked(manifest, out_dir, scheduler, workers, settings, segmentation,
                           progress, say)


@contextmanager
def batch_lock(out_dir: Path) -> Iterator[None]:
    """Hold ``out_dir``'s lock for one batch (the system lets it go when the process ends,
    however it ends); a second batch into the same folder is refused, saying so."""
    import fcntl

    fd = os.open(out_dir / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise GaitInputError(f"another batch is writing to {out_dir}: wait for it to "
                                 "finish, or choose another --out") from None
        yield
    finally:
        os.close(fd)


def _run_locked(manifest: Manifest, out_dir: Path, scheduler: str | None, workers: int | None,
                settings: AnalysisSettings, segmentation: SegmentationSettings,
                progress: Progress | None, say: Callable[[str], None]) -> BatchResult:
    """:func:`run_batch` once the output folder is locked."""
    remove_partial_folders(out_dir)
    rows = {spec.clip: finished_result(out_dir, spec, segmentation) or pending(spec)
            for spec in manifest.clips}
    todo = [spec for spec in manifest.clips if rows[spec.clip].status == "pending"]
    skipped = len(rows) - len(todo)
    summary = _Summary(out_dir, manifest, rows)
    summary.write()
    if skipped:
        say(f"{skipped} clip(s) already done, skipped")
    report(progress, skipped, len(rows), "batch cancelled")
    if todo:
        n_workers = min(workers or default_workers(), len(todo))
        try:
            with _client(scheduler, n_workers, say) as client:
                _run_tasks(client, todo, out_dir, settings, segmentation, summary, progress,
                           say, skipped)
        finally:  # after the workers stopped: a folder completed meanwhile counts as done
            for spec in todo:
                if summary.status(spec.clip) == "pending":
                    summary.set(finished_result(out_dir, spec, segmentation) or pending(spec),
                                write=False)
            summary.write()
    return BatchResult(summary.rows(), len(todo), skipped)


def _run_tasks(client, todo: list[ClipSpec], out_dir: Path, settings: AnalysisSettings,
               segmentation: SegmentationSettings,
               summary: _Summary, progress: Progress | None, say: Callable[[str], None],
               done: int) -> None:
    """Submit one task per clip and record each result as it arrives."""
    from distributed import as_completed

    futures = {client.submit(_task, spec, out_dir, settings, segmentation, pure=False): spec
               for spec in todo}
    try:
        for future in as_completed(futures):
            spec = futures.pop(future)
            try:
                row = future.result()
            except Exception as exc:  # noqa: BLE001 - a worker lost or a bug: the clip's line
                row = failed(spec, exc)
            summary.set(row)
            say(_outcome(row))
            done += 1
            report(progress, done, done + len(futures), "batch cancelled")
    finally:
        client.cancel(list(futures))


def _task(spec: ClipSpec, out_dir: Path, settings: AnalysisSettings,
          segmentation: SegmentationSettings) -> ClipSummary:
    """What a worker runs: one clip on one core (Dask, not OpenCV, spreads the work)."""
    import cv2

    cv2.setNumThreads(1)
    return analyze_clip(spec, out_dir, settings=settings, segmentation=segmentation)


def _outcome(row: ClipSummary) -> str:
    if row.status != "done":
        return f"{row.clip}: failed: {row.error}"
    return (f"{row.clip}: {row.verdict}, period {row.period_frames:.1f} frames, "
            f"r1 {row.r1 or 0:.2f} r2 {row.r2 or 0:.2f}")


@contextmanager
def _client(scheduler: str | None, n_workers: int, say: Callable[[str], None]) -> Iterator:
    """A Dask client on the given scheduler, or on a local cluster it starts and stops."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise GaitInputError(f"cannot reach the Dask scheduler at {scheduler} ({exc}); "
                                 "start one with 'dask scheduler' or leave out "
                                 "--scheduler") from None
        with client:
            n = len(client.scheduler_info().get("workers", {}))
            say(f"scheduler {scheduler}: {n} worker(s); dashboard: {client.dashboard_link}")
            yield client
        return
    dashboard = importlib.util.find_spec("bokeh") is not None
    with _sigint_ignored():  # the worker processes inherit it: Ctrl+C is the client's to handle
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0",  # a free port: never 8787 taken
                               silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        link = (cluster.dashboard_link if dashboard
                else "off (install bokeh to watch the batch in a browser)")
        say(f"local cluster: {n_workers} worker process(es); dashboard: {link}")
        yield client


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while processes are started (a terminal sends it to the whole group).

    The worker processes inherit the ignored disposition and leave Ctrl+C to the client;
    a Ctrl+C during the few seconds of the start itself is lost.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class _Summary:
    """The batch's rows in manifest order, written to disk at most every SUMMARY_EVERY_S."""

    def __init__(self, out_dir: Path, manifest: Manifest, rows: dict[str, ClipSummary]) -> None:
        self._out_dir, self._manifest, self._rows = out_dir, manifest, rows
        self._bad = [ClipSummary(f"line-{p.line}", "bad row", p.path, error=str(p))
                     for p in manifest.problems]
        self._written = 0.0

    def rows(self) -> tuple[ClipSummary, ...]:
        return tuple(self._rows.values()) + tuple(self._bad)

    def status(self, clip: str) -> str:
        return self._rows[clip].status

    def set(self, row: ClipSummary, *, write: bool = True) -> None:
        self._rows[row.clip] = row
        if write and time.monotonic() - self._written >= SUMMARY_EVERY_S:
            self.write()

    def write(self) -> None:
        write_summary(self._out_dir, list(self.rows()), manifest=self._manifest.path)
        self._written = time.monotonic()
