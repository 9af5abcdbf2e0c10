"""Fixtures of the GUI tests: offscreen Qt, sandboxed settings, a rendered clip, a window."""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import pytest  # noqa: E402
from PySide6.QtCore import QCoreApplication, QPointF, QSettings, QStandardPaths  # noqa: E402

from app.dialogs import Asker  # noqa: E402

QCoreApplication.setOrganizationName("GaitStudioTests")
QCoreApplication.setApplicationName("Gait Studio Tests")
QStandardPaths.setTestModeEnabled(True)


class ScriptedAsker(Asker):
    """Answers the window's questions from attributes and records every error shown."""

    def __init__(self) -> None:
        super().__init__(None)
        self.errors: list[str] = []
        self.save_answer = "discard"
        self.next_save_path: Path | None = None
        self.relocate_to: Path | None = None
        self.relocate_asked: list[Path] = []
        self.recover_answer = True

    def error(self, title: str, message: str) -> None:
        self.errors.append(f"{title}: {message}")

    def save_changes(self, name: str) -> str:
        return self.save_answer

    def open_path(self, start):
        return None

    def open_folder(self, start):
        return None

    def save_path(self, suggested: Path) -> Path | None:
        return self.next_save_path

    def locate_footage(self, missing: Path) -> Path | None:
        self.relocate_asked.append(missing)
        return self.relocate_to

    def recover(self, description: str) -> bool:
        return self.recover_answer


@pytest.fixture(scope="session", autouse=True)
def sandboxed_settings(tmp_path_factory):
    """QSettings of the tests go to a temporary INI file, never the user's."""
    folder = tmp_path_factory.mktemp("qsettings")
    QSettings.setDefaultFormat(QSettings.Format.IniFormat)
    QSettings.setPath(QSettings.Format.IniFormat, QSettings.Scope.UserScope, str(folder))
    return folder


@pytest.fixture(scope="session")
def canter_clip(tmp_path_factory) -> Path:
    """The demo's synthetic canter (100 frames, 320x240): images/ and masks/."""
    from app.demo import ensure_demo_clip

    return ensure_demo_clip(tmp_path_factory.mktemp("clips") / "canter")


@pytest.fixture
def asker() -> ScriptedAsker:
    return ScriptedAsker()


@pytest.fixture
def make_window(qtbot, tmp_path, asker):
    """Factory of shown main windows sharing ``asker`` and a recovery folder in tmp_path."""
    from app.main_window import MainWindow

    def make(**kwargs):
        kwargs.setdefault("asker", asker)
        kwargs.setdefault("recovery_dir", tmp_path / "recovery")
        kwargs.setdefault("remember_layout", False)
        w = MainWindow(**kwargs)
        qtbot.addWidget(w)
        w.resize(1400, 900)
        w.show()
        return w

    return make


@pytest.fixture
def window(make_window):
    return make_window()


def wait_ready(qtbot, window, timeout_ms: int = 30_000) -> None:
    """Wait until the window shows its frame and has finished every job."""
    qtbot.waitUntil(lambda: window.state.n_frames > 0 and window.is_ready(), timeout=timeout_ms)


def viewport_pos(view, scene_item, xy):
    """Viewport position (QPoint) of point ``xy`` in the coordinates of a pyqtgraph view box."""
    scene = scene_item.mapViewToScene(QPointF(*xy))
    return view.mapFromScene(scene)

