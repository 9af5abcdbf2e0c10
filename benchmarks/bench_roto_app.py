"""One brush correction in the app, and its erasing: from the stroke to its undo step, over a
100-frame clip.

The window (offscreen Qt) opens a 100-frame clip, segments it from a box, then a background
brush stroke is painted on frame 50 (``RotoController.paint``, what releasing the mouse
does); the figure is the wall time until the correction (strokes and silhouettes) is on the
undo stack, job, crops and the window's update included; then the stroke is erased
(``RotoController.erase``, what the eraser's release does), timed the same way. Baseline in
the same run: the whole clip segmented in the same window. Clips: the demo canter (320x240,
rendered) and, where the real footage is present, the first 100 frames of Muybridge's race
horse video (960x540). Target (issue #11): at most 5 s.

Second section: the first correction after saving, closing and reopening the project. The
clip is segmented from the box, corrected on frames n/4 and 3n/4 (key frames), saved (the
segmentation engine beside it, :mod:`gaitcore.project.engine_file`); then a correction on
frame n/2 is timed in the same session, undone, the project reopened and the same correction
timed again (the engine put back from the file included), and once more with the engine file
deleted (what reopening cost before: the whole clip segmented again). Clips: the demo canter
and the whole Muybridge race horse video (540 frames, 960x540).

Run ``python -m benchmarks roto_app``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")
if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from benchmarks import Section

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
TARGET_S = 5.0
FRAMES = 100


def run() -> list[Section]:
    """All sections of this benchmark."""
    from PySide6.QtWidgets import QApplication

    from app.demo import ensure_demo_clip

    QApplication.instance() or QApplication([])
    rows, reopened = [], []
    with tempfile.TemporaryDirectory() as tmp:
        canter = ensure_demo_clip(Path(tmp) / "canter") / "images"
        rows.append(_measure("demo canter, 320x240", canter, (1, 36, 295, 184),
                             [(232, 52), (250, 62), (268, 72), (284, 84)]))
        reopened.append(_measure_reopened("demo canter, 320x240", canter, (1, 36, 295, 184),
                                          [(4, 6), (60, 6), (120, 6)], Path(tmp)))
        video = DATA / "muybridge-race-horse" / "race_horse_loop.mp4"
        if video.exists():
            folder = _first_frames(video, Path(tmp) / "horse")
            rows.append(_measure("Muybridge race horse, 960x540", folder, (110, 30, 760, 420),
                                 [(10, 528), (250, 528), (480, 528)]))
            reopened.append(_measure_reopened("Muybridge race horse, 960x540", video,
                                              (110, 30, 760, 420),
                                              [(10, 528), (250, 528), (480, 528)], Path(tmp)))
    headers = ["clip (100 frames)", "segment from the box (s)", "one correction on frame 50 (s)",
               "frames re-propagated", "correction / segmentation", "erasing it (s)"]
    notes = [f"target: one correction re-propagated over a 100-frame clip in <= {TARGET_S:g} s",
             "wall time from the brush stroke to the undo step on the stack (job, engine, crops "
             "rebuilt, window updated); offscreen Qt, one run each"]
    reopened_headers = ["clip", "frames", "segment from the box (s)", "engine file (MB)",
                        "correction, same session (s)", "first correction after reopening (s)",
                        "same, engine file deleted (s)", "frames re-propagated",
                        "reopened / same session"]
    reopened_notes = [
        "key frames on n/4 and 3n/4, the correction on n/2; wall time from the brush stroke "
        "to the undo step (after reopening: the engine read and its crops rebuilt, in the "
        "job); with the engine file deleted the whole clip is segmented again, as before "
        "the engine was saved; offscreen Qt, one run each"]
    return [Section("A brush correction in the app (issue #11)", headers, rows, notes),
            Section("The first correction after reopening the project (issue #11)",
                    reopened_headers, reopened, reopened_notes)]


def _first_frames(video: Path, folder: Path) -> Path:
    """The first :data:`FRAMES` frames of ``video`` as PNG files."""
    import cv2

    folder.mkdir(parents=True)
    cap = cv2.VideoCapture(str(video))
    for t in range(FRAMES):
        ok, frame = cap.read()
        if not ok:
            break
        cv2.imwrite(str(folder / f"{t:05d}.png"), frame)
    cap.release()
    return folder


def _measure(name: str, folder: Path, box: tuple, stroke: list) -> list:
    from dataclasses import replace

    from app.main_window import MainWindow
    from gaitcore.silhouettes.annotations import Rect, Scribble

    window = MainWindow(remember_layout=False)
    window.show()
    try:
        window.open_path(folder)
        _wait(lambda: window.frame_view.shown_frame == 0)
        window.state.set_project(replace(window.state.project, box=Rect(*box)))
        _wait(lambda: not window.runner.busy)
        t0 = time.perf_counter()
        window.tools.segment()
        _wait(lambda: window.state.project.silhouettes is not None)
        segment_s = time.perf_counter() - t0
        _wait(lambda: not window.runner.busy)
        steps = window.state.undo_stack.count()
        window.state.set_frame(50)
        t0 = time.perf_counter()
        window.tools.roto.paint(Scribble(stroke, 14, 50, "background"))
        _wait(lambda: window.state.undo_stack.count() > steps)
        correct_s = time.perf_counter() - t0
        first, stop = window.tools.roto._session.changed
        _wait(lambda: not window.runner.busy)
        t0 = time.perf_counter()
        window.tools.roto.erase({0})
        _wait(lambda: window.state.undo_stack.count() > steps + 1)
        erase_s = time.perf_counter() - t0
        _wait(lambda: not window.runner.busy)
    finally:
        window.state.undo_stack.setClean()
        window.close()
    return [name, round(segment_s, 2), round(correct_s, 2), stop - first,
            f"{correct_s / segment_s:.2f}", round(erase_s, 2)]


def _measure_reopened(name: str, footage: Path, box: tuple, stroke: list, tmp: Path) -> list:
    from dataclasses import replace

    from app.main_window import MainWindow
    from gaitcore.project.storage import sidecar_dir
    from gaitcore.silhouettes.annotations import Rect

    path = tmp / f"{footage.stem}.gaitproj"
    window = MainWindow(remember_layout=False)
    window.show()
    try:
        window.open_path(footage)
        _wait(lambda: window.frame_view.shown_frame == 0)
        n = window.state.n_frames
        window.state.set_project(replace(window.state.project, box=Rect(*box)))
        _wait(lambda: not window.runner.busy)
        segment_s = _timed(window, window.tools.segment)
        for frame in (n // 4, 3 * n // 4):
            _timed(window, lambda frame=frame: _paint(window, stroke, frame))
        window.state.set_path(path)
        window.documents.save()
        engine_mb = sum(f.stat().st_size for f in sidecar_dir(path).glob("engine*")) / 1e6
        same_s = _timed(window, lambda: _paint(window, stroke, n // 2))
        window.state.undo_stack.undo()
        window.open_path(path)
        _wait(lambda: window.frame_view.shown_frame == 0 and not window.runner.busy)
        reopened_s = _timed(window, lambda: _paint(window, stroke, n // 2))
        first, stop = window.tools.roto.session.changed
        window.state.undo_stack.undo()
        for f in sidecar_dir(path).glob("engine*"):
            f.unlink()
        window.open_path(path)
        _wait(lambda: window.frame_view.shown_frame == 0 and not window.runner.busy)
        deleted_s = _timed(window, lambda: _paint(window, stroke, n // 2))
    finally:
        window.state.undo_stack.setClean()
        window.close()
        shutil.rmtree(sidecar_dir(path), ignore_errors=True)
    return [name, n, round(segment_s, 2), round(engine_mb, 2), round(same_s, 2),
            round(reopened_s, 2), round(deleted_s, 2), stop - first,
            f"{reopened_s / same_s:.2f}"]


def _paint(window, stroke: list, frame: int) -> None:
    from gaitcore.silhouettes.annotations import Scribble

    window.state.set_frame(frame)
    window.tools.roto.paint(Scribble(stroke, 14, frame, "background"))


def _timed(window, action) -> float:
    """Seconds from ``action`` (which starts a job pushing one undo step) to its step."""
    steps = window.state.undo_stack.count()
    t0 = time.perf_counter()
    action()
    _wait(lambda: window.state.undo_stack.count() > steps)
    elapsed = time.perf_counter() - t0
    _wait(lambda: not window.runner.busy)
    return elapsed


def _wait(condition, timeout_s: float = 600.0) -> None:
    from PySide6.QtCore import QCoreApplication, QThread

    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            raise TimeoutError("the window did not finish in time")
        QCoreApplication.processEvents()
        QThread.msleep(5)
