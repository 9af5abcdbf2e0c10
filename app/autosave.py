"""Autosave to a recovery folder, and offer the copy after a crash.

While the project has unsaved changes, it is saved every ``interval_ms`` to
``<recovery dir>/<session>.gaitproj`` (plus ``<session>.json`` naming the real project file).
A lock file marks the session as alive; at start-up, copies whose lock is stale (their
process is gone) are offered for recovery. A clean save or a normal exit deletes the copy.
Both files are written atomically; an autosaved project is never deleted because its info
file is damaged.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QLockFile, QObject, QTimer

from app.state import AppState
from gaitcore.errors import GaitInputError
from gaitcore.project.document import Project
from gaitcore.project.storage import SUFFIX, load_project, save_project, sidecar_dir, write_atomic
from gaitcore.schema import read_json

DEFAULT_INTERVAL_MS = 60_000
MAX_INFO_BYTES = 1 << 20
MAX_TIME_S = 1e11


@dataclass(frozen=True)
class RecoveryCopy:
    """An autosaved project left by a session that did not exit normally.

    Attributes
    ----------
    project_file : Path
        The autosaved project (in the recovery folder).
    original : Path or None
        The project file the work belongs to (None: never saved).
    saved_at : float
        Seconds since the epoch.
    """

    project_file: Path
    original: Path | None
    saved_at: float

    def describe(self) -> str:
        name = self.original.name if self.original else "an unsaved project"
        return f"{name} from {time.strftime('%Y-%m-%d %H:%M', time.localtime(self.saved_at))}"

    def load(self) -> Project:
        """Read the copy (GaitInputError when it is damaged)."""
        return load_project(self.project_file)

    def discard(self) -> None:
        """Delete the copy and its files."""
        _remove(self.project_file)


def find_recovery_copies(directory: Path) -> list[RecoveryCopy]:
    """Copies in ``directory`` whose session is gone, newest first.

    A copy whose info file is empty or damaged (a crash while it was written by an older
    version) is still offered, as an unsaved project from the time of the copy: only an
    info file without its project is deleted.
    """
    if not directory.is_dir():
        return []
    found = []
    for meta in directory.glob("*.json"):
        lock = QLockFile(str(meta.with_suffix(".lock")))
        if not lock.tryLock(0):
            continue  # another running Gait Studio owns it
        lock.unlock()
        project_file = meta.with_suffix(SUFFIX)
        if not project_file.is_file():
            meta.unlink(missing_ok=True)
            continue
        original, saved_at = _read_info(meta)
        found.append(RecoveryCopy(project_file, original,
                                  saved_at if saved_at is not None
                                  else project_file.stat().st_mtime))
    return sorted(found, key=lambda c: -c.saved_at)


def _read_info(meta: Path) -> tuple[Path | None, float | None]:
    """The original project file and the time of a copy; (None, None) when the info file
    cannot be read."""
    try:
        info = read_json(meta, what="autosave info", max_bytes=MAX_INFO_BYTES)
        original = info.key("original", None).text(optional=True)
        saved_at = info.key("saved_at").number(lo=0, hi=MAX_TIME_S)
    except GaitInputError:
        return None, None
    return (Path(original) if original else None), saved_at


class Autosaver(QObject):
    """Save the project to the recovery folder while it has unsaved changes.

    Parameters
    ----------
    state : AppState
    directory : Path
        The recovery folder (created when needed).
    interval_ms : int
        Time between autosaves.
    """

    def __init__(self, state: AppState, directory: Path, interval_ms: int = DEFAULT_INTERVAL_MS,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self.directory = Path(directory)
        stem = f"session-{os.getpid()}-{int(time.time() * 1000)}"
        self.project_file = self.directory / (stem + SUFFIX)
        self._lock: QLockFile | None = None
        self._saved: Project | None = None
        self.last_error = ""
        self._timer = QTimer(self, interval=interval_ms)
        self._timer.timeout.connect(self.save_now)
        self._timer.start()
        state.undo_stack.cleanChanged.connect(self._on_clean)

    def save_now(self) -> bool:
        """Autosave if there are unsaved changes not yet autosaved; True when it wrote."""
        state = self._state
        if state.undo_stack.isClean() or state.project is self._saved:
            return False
        try:
            if self._lock is None:
                self.directory.mkdir(parents=True, exist_ok=True)
                self._lock = QLockFile(str(self.project_file.with_suffix(".lock")))
                self._lock.setStaleLockTime(0)
                self._lock.tryLock(0)
            save_project(state.project, self.project_file)
            meta = {"original": str(state.path) if state.path else None, "saved_at": time.time()}
            write_atomic(self.project_file.with_suffix(".json"), json.dumps(meta).encode("utf-8"))
        except (GaitInputError, OSError) as exc:
            self.last_error = str(exc)
            return False
        self._saved = state.project
        return True

    def discard(self) -> None:
        """Delete this session's copy (after a save, or at a normal exit)."""
        self._saved = None
        _remove(self.project_file)
        if self._lock is not None:
            self._lock.unlock()
            self._lock = None
            Path(self.project_file.with_suffix(".lock")).unlink(missing_ok=True)

    def _on_clean(self, clean: bool) -> None:
        if clean:
            self.discard()


def _remove(project_file: Path) -> None:
    for f in (project_file, project_file.with_suffix(".json")):
        f.unlink(missing_ok=True)
    shutil.rmtree(sidecar_dir(project_file), ignore_errors=True)
