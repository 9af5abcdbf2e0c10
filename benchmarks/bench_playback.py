"""Gait Studio playback: the demo animation in the 3D viewport (800x600) beside the footage.

The demo canter is opened, its key-images are posed with the true poses (so the whole clip
animates), and two things are measured for two set-ups in the same process:

- baseline: the footage alone (the 3D viewport hidden), as in part 1 of the application;
- the footage beside the 3D viewport at 800x600, which draws the predicted skeleton of every
  frame over the key-image plane.

"Throughput" steps through the clip as fast as it goes: set the frame, wait until the footage
is decoded and shown, repaint the frame view, and (with 3D) wait until the 3D view has
presented its frame. "Real-time playback" runs the application's own Player at the clip's 25
frames/s for a few seconds and counts the frames the 3D view drew (paintGL) and those the
frame view showed. Target: at least 24 frames/s with the viewport.

A GL viewport needs an X display (Xvfb) with the xcb platform; the measurement runs in a
child process so that the Qt platform and OpenGL set-up of other benchmarks does not matter.
Without a display the section says so and measures nothing.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import Section

TARGET_FPS = 24.0
VIEWPORT = (800, 600)
PASSES = 2
REALTIME_S = 4.0
TITLE = ("Playback of the demo animation beside the footage, 3D viewport "
         f"{VIEWPORT[0]}x{VIEWPORT[1]}")
HEADERS = ["set-up", "throughput frames/s", "median ms per frame", "p90 ms",
           "real-time playback frames/s (Player at 25)", "3D frames drawn/s"]


def run() -> list[Section]:
    """All sections of this benchmark (measured in a child process under the X display)."""
    if not os.environ.get("DISPLAY"):
        return [Section(TITLE, HEADERS, [], notes=[
            "skipped: no X display. The 3D viewport needs OpenGL through Qt's xcb platform; run "
            "`xvfb-run -a -s \"-screen 0 1600x1000x24\" .venv/bin/python -m benchmarks playback`"])]
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, QT_QPA_PLATFORM="xcb", PYQTGRAPH_QT_LIB="PySide6",
               PYOPENGL_PLATFORM=os.environ.get("PYOPENGL_PLATFORM", "egl"))
    child = subprocess.run([sys.executable, "-m", "benchmarks.bench_playback"], cwd=root, env=env,
                           capture_output=True, text=True, timeout=900)
    if child.returncode != 0:
        raise RuntimeError(f"playback benchmark failed:\n{child.stderr[-3000:]}")
    result = json.loads(child.stdout.strip().splitlines()[-1])
    return [Section(TITLE, HEADERS, result["rows"], notes=result["notes"])]


# -- the child process -------------------------------------------------------------------------
def _measure() -> dict:
    app = _gl_application()
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        window = _posed_demo(app, Path(tmp))
        gl_view = window.viewport.gl_view
        from OpenGL import GL

        gl_view.makeCurrent()
        renderer = GL.glGetString(GL.GL_RENDERER).decode()
        gl_view.doneCurrent()

        window.viewport.hide()
        base = _throughput(window, with_3d=False), _realtime(window, with_3d=False)
        window.viewport.show()
        _wait(app, lambda: window.is_ready())
        size = (gl_view.width(), gl_view.height())
        full = _throughput(window, with_3d=True), _realtime(window, with_3d=True)
        window.close()
    rows = []
    for name, ((ms, errors), (shown, presented)) in (
            ("footage only (baseline)", base), ("footage + 3D skeleton viewport", full)):
        a = np.asarray(ms)
        rows.append([name, f"{1000 / np.median(a):.0f}", f"{np.median(a):.1f}",
                     f"{np.percentile(a, 90):.1f}", f"{shown:.1f}",
                     "-" if presented is None else f"{presented:.1f}"])
    verdict = "meets" if full[1][1] >= TARGET_FPS and full[1][0] >= TARGET_FPS else "misses"
    notes = [
        f"target: >= {TARGET_FPS:.0f} frames/s in real-time playback with the viewport; measured "
        f"{full[1][1]:.1f} drawn 3D frames/s and {full[1][0]:.1f} footage frames/s ({verdict} it)",
        f"viewport {size[0]}x{size[1]} widget pixels; Qt platform {app.platformName()}; OpenGL "
        f"renderer {renderer}; {window.state.n_frames} frames of 320x240 footage at 25 frames/s",
        f"throughput: {PASSES} passes over the clip, each frame decoded on the loader thread, "
        "shown, the frame view repainted and (with 3D) the 3D view presented",
        f"real-time: the application's Player for {REALTIME_S:.0f} s; frames/s counted from the "
        "frame view's frameShown signal and the 3D view's paintGL calls",
        f"every 3D frame checked: the viewport showed the predicted pose of its frame "
        f"({full[0][1]} mismatches)",
    ]
    return {"rows": rows, "notes": notes}


def _gl_application():
    """The QApplication, with OpenGL set up as app.main sets it up (RuntimeError without)."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")  # as app.main: pyrender and the viewport
    if os.environ["PYOPENGL_PLATFORM"] == "egl":
        os.environ.setdefault("QT_XCB_GL_INTEGRATION", "xcb_egl")
    from PySide6.QtCore import QCoreApplication
    from PySide6.QtWidgets import QApplication

    from app.widgets.skeleton_gl import opengl_available, share_gl_resources

    share_gl_resources()
    app = QApplication([])
    QCoreApplication.setOrganizationName("GaitStudio")
    QCoreApplication.setApplicationName("Gait Studio")
    if not opengl_available():
        raise RuntimeError(f"no OpenGL widget on Qt platform {app.platformName()!r}")
    return app


def _posed_demo(app, recovery_dir: Path):
    """The main window on the demo, its keys posed from the true gait and animated, showing
    the footage and the viewport side by side and nothing else."""
    from app.demo import DEMO_GAIT, demo_folder, demo_project
    from app.dialogs import HeadlessAsker
    from app.main_window import MainWindow
    from gaitcore.bench import generate_gait

    project = demo_project(demo_folder())
    window = MainWindow(asker=HeadlessAsker(), recovery_dir=recovery_dir, remember_layout=False)
    for key in ("posing", "eigen", "pcs", "diagnosis"):
        window.docks[key].hide()
    window.viewport.gl_container.setFixedSize(*VIEWPORT)
    window.resize(1500, 980)
    window.show()
    window.documents.open_demo(project)
    _wait(app, lambda: window.is_ready() and window.state.analysis is not None)
    truth = generate_gait(window.state.skeleton, DEMO_GAIT, window.state.n_frames)
    for k in window.state.analysis.key_frames:
        window.state.set_frame(k)
        window.posing.set_pose(truth[k], "pose key")
    window.animator.recompute()
    if window.animator.animation is None:
        raise RuntimeError(window.animator.status)
    _wait(app, lambda: window.is_ready())
    return window


def _throughput(window, *, with_3d: bool) -> tuple[list[float], int]:
    """Milliseconds per frame stepping through the clip as fast as possible; pose mismatches."""
    from benchmarks.bench_gui import _wait_shown

    animation = window.animator.animation
    ms, errors = [], 0
    keys = set(window.posing.frames())
    for _ in range(PASSES):
        for f in range(window.state.n_frames):
            t0 = time.perf_counter()
            window.state.set_frame(f)
            _wait_shown(window.frame_view, f)
            window.frame_view.repaint()
            if with_3d:
                _wait_swapped(window.viewport.gl_view)
                if f not in keys and not np.array_equal(window.viewport.shown_pose,
                                                        animation.pose_at(f)):
                    errors += 1
            ms.append((time.perf_counter() - t0) * 1000)
    return ms, errors


def _wait_swapped(gl_view, timeout_ms: int = 2000) -> None:
    """Ask the 3D view for a frame and block in a local event loop until it is presented."""
    from PySide6.QtCore import QEventLoop, QTimer

    loop = QEventLoop()
    gl_view.frameSwapped.connect(loop.quit)
    QTimer.singleShot(timeout_ms, loop.quit)
    gl_view.update()
    loop.exec()
    gl_view.frameSwapped.disconnect(loop.quit)


def _realtime(window, *, with_3d: bool) -> tuple[float, float | None]:
    """Frames shown per second (and 3D frames drawn) while the Player plays at 25 fps."""
    from PySide6.QtCore import QEventLoop, QTimer

    shown = []
    window.frame_view.frameShown.connect(shown.append)
    gl_view = window.viewport.gl_view
    window.player.go_to(0)
    drawn = gl_view.frames_drawn
    loop = QEventLoop()
    QTimer.singleShot(int(REALTIME_S * 1000), loop.quit)
    t0 = time.perf_counter()
    window.player.toggle()
    loop.exec()
    elapsed = time.perf_counter() - t0
    window.player.stop()
    window.frame_view.frameShown.disconnect(shown.append)
    presented = gl_view.frames_drawn - drawn
    return len(shown) / elapsed, (presented / elapsed if with_3d else None)


def _wait(app, condition, timeout_s: float = 180.0) -> None:
    from benchmarks.bench_gui import _wait as wait

    wait(app, condition, timeout_s)


if __name__ == "__main__":
    print(json.dumps(_measure()))
