"""Fixtures of the GUI tests: the Qt platform, sandboxed settings, a rendered clip, a window.

The platform: with an X display (``make test`` runs under ``xvfb-run``) the whole suite uses
Qt's ``xcb`` platform with EGL, so the 3D viewport gets an OpenGL context; without one it
uses ``offscreen``, where the tests marked ``gl`` are skipped (every other widget works the
same on both). ``QT_QPA_PLATFORM`` set by the caller always wins.
"""

from __future__ import annotations

import os
import subprocess
import sys
from functools import lru_cache
from pathlib import Path


@lru_cache(maxsize=1)
def xcb_works() -> bool:
    """True when Qt's xcb platform starts on $DISPLAY (checked in a child process, since a
    platform that fails to load aborts the process)."""
    if not os.environ.get("DISPLAY"):
        return False
    probe = "from PySide6.QtGui import QGuiApplication; QGuiApplication(['probe'])"
    env = dict(os.environ, QT_QPA_PLATFORM="xcb")
    try:
        return subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True,
                              timeout=30).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


if "QT_QPA_PLATFORM" not in os.environ:
    os.environ["QT_QPA_PLATFORM"] = "xcb" if xcb_works() else "offscreen"
os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
if os.environ["PYOPENGL_PLATFORM"] == "egl":
    os.environ.setdefault("QT_XCB_GL_INTEGRATION", "xcb_egl")  # as app.main does

import pytest  # noqa: E402
from PySide6.QtCore import QCoreApplication, QPointF, QSettings, QStandardPaths  # noqa: E402

from app.dialogs import Asker  # noqa: E402
from app.widgets.skeleton_gl import share_gl_resources  # noqa: E402

share_gl_resources()  # before pytest-qt creates the QApplication

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
        self.next_open_file: Path | None = None
        self.next_export_path: Path | None = None
        self.export_answer = "keep"  # or an AnimationOptions, or None to cancel
        self.confirm_answer = True
        self.chosen_frame: int | None = None
        self.frame_rate_answer: float | None = None
        self.suggested: int | None = None
        self.asked: list[str] = []

    def error(self, title: str, message: str) -> None:
        self.errors.append(f"{title}: {message}")

    def save_changes(self, name: str) -> str:
        self.asked.append(f"save changes to {name}")
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

    def open_file(self, title: str, file_filter: str) -> Path | None:
        self.asked.append(title)
        return self.next_open_file

    def export_path(self, title: str, suggested: Path, file_filter: str) -> Path | None:
        self.asked.append(title)
        return self.next_export_path

    def export_folder(self, title: str, suggested: Path) -> Path | None:
        self.asked.append(title)
        return self.next_export_path

    def export_options(self, title: str, options, footage=None):
        self.asked.append(f"{title}: options")
        self.footage_speed = footage
        return options if self.export_answer == "keep" else self.export_answer

    def confirm(self, title: str, message: str) -> bool:
        self.asked.append(f"{title}: {message}")
        return self.confirm_answer

    def frame_rate(self, current: float | None) -> float | None:
        self.asked.append(f"frame rate ({current:g} offered)")
        return self.frame_rate_answer

    def choose_frame(self, title: str, frames: list[int], *,
                     suggested: int | None = None) -> int | None:
        self.asked.append(title)
        self.suggested = suggested
        return self.chosen_frame


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


@pytest.fixture(autouse=True)
def _skip_without_opengl(request):
    """Tests marked ``gl`` need an OpenGL context: skipped on the offscreen platform."""
    if request.node.get_closest_marker("gl") is None:
        return
    request.getfixturevalue("qapp")
    from app.widgets.skeleton_gl import opengl_available

    if not opengl_available():
        pytest.skip("no OpenGL context on this Qt platform: run under an X display "
                    "(xvfb-run) so that the tests use the xcb platform")


@pytest.fixture
def asker() -> ScriptedAsker:
    return ScriptedAsker()


@pytest.fixture
def make_window(qtbot, tmp_path, asker):
    """Factory of shown main windows sharing ``asker`` and a recovery folder in tmp_path.

    The windows are closed and deleted at the end of the test, while the QApplication is
    alive: a GL viewport destroyed during interpreter shutdown can crash the process.
    """
    from PySide6.QtCore import QEvent

    from app.main_window import MainWindow

    made = []

    def make(**kwargs):
        kwargs.setdefault("asker", asker)
        kwargs.setdefault("recovery_dir", tmp_path / "recovery")
        kwargs.setdefault("remember_layout", False)
        w = MainWindow(**kwargs)
        made.append(w)
        w.resize(1400, 900)
        w.show()
        return w

    yield make
    for w in made:
        w.close()
        w.deleteLater()
    QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)


@pytest.fixture
def window(make_window):
    return make_window()


def wait_ready(qtbot, window, timeout_ms: int = 30_000) -> None:
    """Wait until the window shows its frame and has finished every job."""
    qtbot.waitUntil(lambda: window.state.n_frames > 0 and window.is_ready(), timeout=timeout_ms)


def wait_jobs(qtbot, window, timeout_ms: int = 30_000) -> None:
    """Wait until every background job of the window (file reads, analyses) has finished."""
    qtbot.waitUntil(lambda: not window.runner.busy, timeout=timeout_ms)


def viewport_pos(view, scene_item, xy):
    """Viewport position (QPoint) of point ``xy`` in the coordinates of a pyqtgraph view box."""
    scene = scene_item.mapViewToScene(QPointF(*xy))
    return view.mapFromScene(scene)

