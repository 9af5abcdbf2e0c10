"""Bad files opened by the application: a dialog that names the file, never a traceback.

``gaitstudio BAD.gaitproj`` runs here in-process (``app.main.main``): the Asker's error
dialog is recorded instead of shown and closes the window, as the artist would; the
command must then exit 0 and leave the file as it was (issue #15).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from PySide6.QtCore import QCoreApplication, QTimer
from PySide6.QtWidgets import QApplication

from app.dialogs import Asker
from app.main import main
from gaitcore.project.document import Project, Silhouettes
from gaitcore.project.storage import save_project, sidecar_dir
from gaitcore.silhouettes.tracking import RoiClip
from tests.app.conftest import wait_jobs

GIVE_UP_MS = 60_000


@pytest.fixture
def gaitstudio(qapp, monkeypatch, capfd):
    """``gaitstudio ARGS`` in this process; returns (exit status, dialogs shown, stderr)."""
    dialogs: list[tuple[str, str]] = []

    def error(self, title: str, message: str) -> None:
        dialogs.append((title, message))
        QTimer.singleShot(0, QApplication.closeAllWindows)  # the artist reads it and quits

    monkeypatch.setattr(Asker, "error", error)
    names = QCoreApplication.organizationName(), QCoreApplication.applicationName()

    def run(*args: str) -> tuple[int, list[tuple[str, str]], str]:
        give_up = QTimer(singleShot=True, interval=GIVE_UP_MS)  # no dialog: fail, not hang
        give_up.timeout.connect(QApplication.closeAllWindows)
        give_up.start()
        try:
            status = main(list(args))
        finally:
            give_up.stop()
        return status, dialogs, capfd.readouterr().err

    yield run
    QCoreApplication.setOrganizationName(names[0])
    QCoreApplication.setApplicationName(names[1])


def _project_with_arrays(tmp_path):
    path = tmp_path / "bad.gaitproj"
    roi = RoiClip(np.ones((3, 4, 4), bool), np.zeros((3, 2)), np.zeros(3, bool), 0.5)
    save_project(Project(silhouettes=Silhouettes(roi, "masks")), path)
    return path, json.loads(path.read_text())


def _empty_sidecar_array(tmp_path):
    path, doc = _project_with_arrays(tmp_path)
    (sidecar_dir(path) / doc["silhouettes"]["arrays"]["centers_xy"]).write_bytes(b"")
    return path


def _edited(tmp_path, field, raw):
    path, doc = _project_with_arrays(tmp_path)
    path.write_text(json.dumps(dict(doc, **{field: "__RAW__"})).replace('"__RAW__"', raw))
    return path


BAD = {
    "empty sidecar .npy": (_empty_sidecar_array, "centers_xy"),
    "wrong-typed footage": (lambda t: _edited(t, "footage", "[1, 2]"), "footage must be an object"),
    "frame_start 1e400": (lambda t: _edited(t, "frame_start", "1e400"), "frame_start must be"),
    "100,000-deep JSON": (lambda t: _edited(t, "strokes", "[" * 100_000 + "]" * 100_000),
                          "too deeply"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_gaitstudio_on_a_bad_project_shows_a_dialog_and_exits_0(gaitstudio, tmp_path, case):
    make, words = BAD[case]
    path = make(tmp_path)
    before = {f: f.read_bytes() for f in [path, *sidecar_dir(path).iterdir()]}
    status, dialogs, err = gaitstudio(str(path))
    assert status == 0
    assert len(dialogs) == 1, dialogs
    title, message = dialogs[0]
    assert title == "Cannot open project" and str(path.name) in message and words in message
    assert "\n" not in message and "Traceback" not in err
    assert {f: f.read_bytes() for f in before} == before, "the file was changed"


def test_load_rig_from_a_bad_bvh_fails_into_a_dialog(qtbot, window, asker, tmp_path):
    bvh = tmp_path / "rig.bvh"
    bvh.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
                   "}\nMOTION\nFrames: nan\nFrame Time: 0.04\n0 0 0\n")
    before = window.state.project
    window.posing.load_rig(bvh)
    wait_jobs(qtbot, window)
    assert len(asker.errors) == 1 and "rig.bvh" in asker.errors[0] and "Frames" in asker.errors[0]
    assert window.state.project is before
