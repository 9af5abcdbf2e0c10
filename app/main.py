"""Entry point of the ``gaitstudio`` command.

``gaitstudio [VIDEO|FOLDER|PROJECT]`` opens the window (and offers to recover autosaved work
after a crash); ``gaitstudio --demo`` opens the synthetic canter with everything computed;
``--screenshot FILE`` saves the window once loaded and exits (0 when saved).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
if os.environ["PYOPENGL_PLATFORM"] == "egl":
    # PyOpenGL on EGL (which pyrender needs) only sees EGL contexts: make Qt's X11 windows
    # use EGL too, or the 3D viewport would draw nothing under X11/Xvfb.
    os.environ.setdefault("QT_XCB_GL_INTEGRATION", "xcb_egl")

SCREENSHOT_TIMEOUT_MS = 120_000
_POLL_MS = 100


def _parse(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gaitstudio",
                                description="Gait Studio: animal gaits from video")
    p.add_argument("path", nargs="?", type=Path,
                   help="video file, image or mask folder, or .gaitproj")
    p.add_argument("--demo", action="store_true", help="open the synthetic canter demo")
    p.add_argument("--screenshot", type=Path, metavar="FILE",
                   help="save the window as an image once loaded, then exit")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Run Gait Studio; returns the exit status."""
    args = _parse(argv)
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.widgets.skeleton_gl import share_gl_resources

    share_gl_resources()
    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setOrganizationName("GaitStudio")
    app.setApplicationName("Gait Studio")
    from app.dialogs import HeadlessAsker
    from app.main_window import MainWindow

    headless = HeadlessAsker() if args.screenshot is not None else None
    window = MainWindow(asker=headless, remember_layout=headless is None)
    window.show()
    if args.demo:
        _load_demo(window)
    elif args.path is not None:
        if not window.open_path(args.path) and headless is not None:
            return 2
    elif headless is None:
        QTimer.singleShot(0, window.offer_recovery)
    status = {"code": 0}
    if headless is not None:
        _schedule_screenshot(window, args.screenshot, headless, status)
    code = app.exec()
    return status["code"] or code


def _load_demo(window) -> None:
    """Render or reuse the demo clip in a background job, then show it."""
    from app.demo import demo_folder, demo_project
    from app.workers import Job

    job = Job(lambda progress: demo_project(demo_folder(), progress), "Preparing the demo clip")
    window.documents.run(job, window.documents.open_demo)


def _schedule_screenshot(window, path: Path, asker, status: dict) -> None:
    """Save ``window`` to ``path`` once it is ready (checked every 100 ms), then quit.

    Exits with status 1 when an error was reported or the window never became ready.
    """
    from PySide6.QtCore import QElapsedTimer, QTimer
    from PySide6.QtWidgets import QApplication

    clock = QElapsedTimer()
    clock.start()
    timer = QTimer(window, interval=_POLL_MS)
    settle = {"ticks": 0}

    def check() -> None:
        ready = window.state.n_frames > 0 and window.is_ready()
        settle["ticks"] = settle["ticks"] + 1 if ready else 0
        timed_out = clock.elapsed() > SCREENSHOT_TIMEOUT_MS
        if settle["ticks"] < 3 and not timed_out and not asker.errors:
            return  # ready for three polls in a row: every queued repaint has run
        timer.stop()
        path.parent.mkdir(parents=True, exist_ok=True)
        saved = window.snapshot().save(str(path))
        if timed_out or not saved or asker.errors:
            why = (f"cannot write {path}" if not saved else "saved after an error" if asker.errors
                   else "timed out before the window was loaded")
            print(f"gaitstudio: screenshot {why}", file=sys.stderr)
            status["code"] = 1
        window.close()
        QApplication.instance().quit()

    timer.timeout.connect(check)
    timer.start()


if __name__ == "__main__":
    sys.exit(main())
