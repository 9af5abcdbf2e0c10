"""Autosave while there are unsaved changes, and the recovery offer after a crash."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from app.autosave import find_recovery_copies
from app.commands import AddRectCommand
from gaitcore.project.storage import load_project
from gaitcore.silhouettes.annotations import Rect
from tests.app.conftest import wait_ready

ROOT = Path(__file__).resolve().parents[2]

CRASHING_SESSION = textwrap.dedent(
    """
    import os, sys
    from pathlib import Path
    from PySide6.QtCore import QCoreApplication
    from app.autosave import Autosaver
    from app.commands import AddRectCommand
    from app.state import AppState
    from gaitcore.silhouettes.annotations import Rect
    from gaitcore.project.document import Project

    app = QCoreApplication([])
    state = AppState()
    state.open(Project(footage=Path(sys.argv[2])), Path(sys.argv[3]), None)
    saver = Autosaver(state, Path(sys.argv[1]), interval_ms=10_000)
    state.undo_stack.push(AddRectCommand(state, Rect(10, 20, 30, 40), subject=True))
    assert saver.save_now()
    os._exit(3)  # crash: no clean-up of the recovery copy
    """
)


def test_autosave_writes_only_unsaved_changes_and_a_save_deletes_the_copy(
        qtbot, window, asker, canter_clip, tmp_path):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    saver = window.autosaver
    assert not saver.save_now(), "nothing to autosave in a clean project"
    window.state.undo_stack.push(AddRectCommand(window.state, Rect(1, 2, 30, 40), subject=True))
    assert saver.save_now()
    assert load_project(saver.project_file).subject_rects == (Rect(1, 2, 30, 40),)
    assert not saver.save_now(), "unchanged since the last autosave"
    assert find_recovery_copies(saver.directory) == [], "a live session's copy is not offered"
    asker.next_save_path = tmp_path / "p.gaitproj"
    assert window.documents.save()
    assert not saver.project_file.exists()


def test_after_a_crash_the_autosaved_work_is_offered_and_recovered(qtbot, make_window, asker,
                                                                      canter_clip, tmp_path):
    recovery = tmp_path / "recovery"
    original = tmp_path / "horse.gaitproj"
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    run = subprocess.run([sys.executable, "-c", CRASHING_SESSION, str(recovery),
                          str(canter_clip / "images"), str(original)],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    assert run.returncode == 3, run.stderr
    copies = find_recovery_copies(recovery)
    assert len(copies) == 1 and copies[0].original == original

    window = make_window(recovery_dir=recovery)
    assert window.offer_recovery()
    wait_ready(qtbot, window)
    assert window.state.project.subject_rects == (Rect(10, 20, 30, 40),)
    assert window.state.path == original and window.isWindowModified()
    assert window.state.n_frames == 100
    assert find_recovery_copies(recovery) == []


def test_declining_recovery_deletes_the_copy(qtbot, make_window, asker, canter_clip, tmp_path):
    recovery = tmp_path / "recovery"
    run = subprocess.run([sys.executable, "-c", CRASHING_SESSION, str(recovery),
                          str(canter_clip / "images"), str(tmp_path / "x.gaitproj")],
                         cwd=ROOT, env=dict(os.environ, QT_QPA_PLATFORM="offscreen"),
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 3, run.stderr
    asker.recover_answer = False
    window = make_window(recovery_dir=recovery)
    assert not window.offer_recovery()
    assert find_recovery_copies(recovery) == [] and window.state.n_frames == 0


def test_an_empty_autosave_info_file_leaves_the_project_recoverable(qtbot, make_window, asker,
                                                                    canter_clip, tmp_path):
    recovery = tmp_path / "recovery"
    run = subprocess.run([sys.executable, "-c", CRASHING_SESSION, str(recovery),
                          str(canter_clip / "images"), str(tmp_path / "x.gaitproj")],
                         cwd=ROOT, env=dict(os.environ, QT_QPA_PLATFORM="offscreen"),
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 3, run.stderr
    (info,) = recovery.glob("*.json")
    info.write_text("")  # as a crash while an older version wrote it in place left it
    copies = find_recovery_copies(recovery)
    assert len(copies) == 1 and copies[0].original is None
    assert copies[0].project_file.exists()
    window = make_window(recovery_dir=recovery)
    assert window.offer_recovery()
    wait_ready(qtbot, window)
    assert window.state.project.subject_rects == (Rect(10, 20, 30, 40),)
    assert asker.errors == []


def test_an_info_file_without_its_project_is_removed(tmp_path):
    (tmp_path / "session-1-2.json").write_text('{"original": null, "saved_at": 1}')
    assert find_recovery_copies(tmp_path) == []
    assert not (tmp_path / "session-1-2.json").exists()


def test_a_copy_without_its_info_is_offered_and_leftovers_are_cleaned(tmp_path):
    """Killed between the copy and its info: the complete copy is still offered; the
    temporary file of a write cut short goes."""
    from gaitcore.project.document import Project
    from gaitcore.project.storage import save_project

    save_project(Project(), tmp_path / "session-7-9.gaitproj")
    stale = tmp_path / ".session-7-9.json.7.tmp"
    stale.write_text("{")
    (tmp_path / "notes.txt").write_text("not ours")
    copies = find_recovery_copies(tmp_path)
    assert [c.project_file.name for c in copies] == ["session-7-9.gaitproj"]
    assert copies[0].original is None
    assert not stale.exists() and (tmp_path / "notes.txt").exists()
