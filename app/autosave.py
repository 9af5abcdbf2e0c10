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
import re
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

    Every project copy is offered, with or without its info file: a session killed between
    the copy and its info (or whose info is damaged) is offered as an unsaved project from the
    time of the copy. What a gone session leaves that is no copy (an info file without its
    project, a temporary file of a write cut short) is deleted.
    """
    if not directory.is_dir():
        return []
    found = []
    for entry in sorted(directory.iterdir()):
        session = _session_of(entry)
        if session is None or _alive(directory / f"{session}.lock"):
            continue  # not ours, or another running Gait Studio owns it
        project_file = directory / f"{session}{SUFFIX}"
        if entry == project_file and entry.is_file():
            original, saved_at = _read_info(directory / f"{session}.json")
            found.append(RecoveryCopy(project_file, original,
                                      saved_at if saved_at is not None
                                      else project_file.stat().st_mtime))
        elif entry.name.endswith(".tmp") or (entry.suffix == ".json"
                                             and not project_file.is_file()):
            entry.unlink(missing_ok=True)
    return sorted(found, key=lambda c: -c.saved_at)


def _session_of(entry: Path) -> str | None:
    """The autosave session a file of the recovery folder belongs to (None: not one of its
    files): ``session-<pid>-<ms>`` of its copy, info file, lock, or temporary file."""
    match = re.match(r"^\.?(session-\d+-\d+)[.]", entry.name)
    return match.group(1) if match else None


def _alive(lock_path: Path) -> bool:
    """True while the session of ``lock_path`` runs (its lock is held)."""
    lock = QLockFile(str(lock_path))
    if not lock.tryLock(0):
        return True
    lock.unlock()
    return False


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
