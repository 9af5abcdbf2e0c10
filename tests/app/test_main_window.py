"""The real window driven like an artist would: open, draw, segment, sketch, click, save."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt, QTimer
from PySide6.QtWidgets import QApplication, QPushButton

import gaitcore.analysis.image_pca as image_pca
from app.widgets.frame_canvas import Tool
from app.workers import ProgressDialog
from gaitcore.project.document import Silhouettes
from gaitcore.project.storage import load_project
from gaitcore.silhouettes.tracking import crop_rois
from tests.app.conftest import viewport_pos, wait_ready
from tests.gaitcore.walker import walker_clip

MOVE_MS = 15
"""Milliseconds between the mouse moves of :func:`drag`."""


def drag(qtbot, window, points_xy, before_release=None):
    """Press, move through and release at image points ``points_xy`` of the frame view
    (calling ``before_release()``, when given, just before the release).

    Waits a double-click interval first, so that two drags in a row are not a double click,
    and :data:`MOVE_MS` between moves, as a hand does: pyqtgraph drops mouse moves that come
    sooner than its ``mouseRateLimit`` allows (10 ms). Sent all at once, a drag kept only its
    first move and its release, and 20 points 4 pixels apart became a single dot.
    """
    qtbot.wait(QApplication.doubleClickInterval() + 20)
    fv = window.frame_view
    viewport = fv._view.viewport()
    pos = [viewport_pos(fv._view, fv.canvas, p) for p in points_xy]
    qtbot.mousePress(viewport, Qt.MouseButton.LeftButton, pos=pos[0])
    for p in pos[1:]:
        qtbot.wait(MOVE_MS)
        qtbot.mouseMove(viewport, p)
    if before_release is not None:
        before_release()
    qtbot.mouseRelease(viewport, Qt.MouseButton.LeftButton, pos=pos[-1])


def choose_tool(window, tool):
    window.tools.tool_actions[tool].trigger()


def test_open_a_clip_and_scrub(qtbot, window, canter_clip):
    assert window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    assert window.state.n_frames == 100
    assert window.frame_view.image_item().image.shape == (240, 320, 3)
    window.state.set_frame(42)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == 42)
    window.player.step(1)
    assert window.state.frame == 43
    window.player.go_to(-1)
    assert window.state.frame == 99


def test_draw_rectangles_then_segment_with_cancel_then_for_real(qtbot, window, canter_clip,
                                                                artifacts_dir):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    choose_tool(window, Tool.SUBJECT)
    drag(qtbot, window, [(140, 100), (160, 110), (180, 125)])
    choose_tool(window, Tool.BACKGROUND)
    drag(qtbot, window, [(5, 5), (200, 20), (310, 35)])
    project = window.state.project
    assert len(project.subject_rects) == 1 and len(project.background_rects) == 1
    sx, sy, sw, sh = project.subject_rects[0].as_tuple()
    assert abs(sx - 140) <= 2 and abs(sy - 100) <= 2 and abs(sw - 40) <= 3 and abs(sh - 25) <= 3

    ticks = []
    heartbeat = QTimer(window, interval=20)
    heartbeat.timeout.connect(lambda: ticks.append(1))
    heartbeat.start()
    job = window.tools.segment()
    with qtbot.waitSignal(job.cancelled, timeout=20_000):
        job.progressed.connect(lambda done, total: job.cancel())
    assert window.state.project.silhouettes is None
    qtbot.waitUntil(lambda: not window.runner.busy)

    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    heartbeat.stop()
    assert len(ticks) > 10, "the event loop must keep running while segmenting"
    wait_ready(qtbot, window)
    silhouettes = window.state.project.silhouettes
    assert silhouettes.origin == "segmented" and silhouettes.roi.lost.sum() <= 2
    assert window.state.analysis.diagnosis.correlations[0] > 0.6
    window.state.undo_stack.undo()
    assert window.state.project.silhouettes is None
    window.state.undo_stack.redo()
    window.state.set_frame(10)
    wait_ready(qtbot, window)
    window.grab().save(str(artifacts_dir / "app_segmented.png"))


def test_draw_a_stroke_undo_it_and_erase(qtbot, window, canter_clip, artifacts_dir):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    window.state.set_frame(5)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == 5)
    choose_tool(window, Tool.DRAW)
    drag(qtbot, window, [(60, 120), (120, 110), (200, 105), (250, 90)])
    stack = window.state.undo_stack
    assert stack.count() == 1
    (stroke,) = window.state.project.strokes
    assert stroke.frame == 5 and len(stroke.points_xy) >= 3
    assert abs(stroke.points_xy[0, 0] - 60) < 2 and abs(stroke.points_xy[-1, 0] - 250) < 2
    window.tools.propagate_action.trigger()  # frame 4 has no stroke: only a message
    window.state.set_frame(6)
    job = window.tools.propagate()
    assert job is not None
    qtbot.waitUntil(lambda: len(window.state.project.strokes) == 2, timeout=10_000)
    assert window.state.project.strokes[1].frame == 6
    window.state.set_frame(7)  # frame 6's stroke shows as the onion skin of frame 7
    wait_ready(qtbot, window)
    window.grab().save(str(artifacts_dir / "app_strokes_onion.png"))
    stack.undo()
    stack.undo()
    assert window.state.project.strokes == ()
    stack.redo()
    window.state.set_frame(5)
    choose_tool(window, Tool.ERASE)
    drag(qtbot, window, [(120, 110), (121, 111)])
    assert window.state.project.strokes == ()
    assert stack.undoText() == "erase stroke"


def test_click_a_pc_point_to_jump_to_its_frame(qtbot, window, canter_clip):
    window.open_path(canter_clip / "masks")
    wait_ready(qtbot, window)
    plot = window.pc_plot
    target = 37
    xy = plot.point_xy(target)
    vb = plot.plot.getPlotItem().getViewBox()
    pos = viewport_pos(plot.plot, vb, xy)
    qtbot.mouseClick(plot.plot.viewport(), Qt.MouseButton.LeftButton, pos=pos)
    frame = window.state.frame
    assert frame != 0
    assert np.hypot(*np.subtract(plot.point_xy(frame), xy)) < 0.15
    assert plot.cursor_xy() == plot.point_xy(frame)
    key = window.state.analysis.key_frames[1]
    qtbot.wait(QApplication.doubleClickInterval() + 20)  # two clicks, not a double click
    qtbot.mouseClick(plot.plot.viewport(), Qt.MouseButton.LeftButton,
                     pos=viewport_pos(plot.plot, vb, plot.point_xy(key)))
    clicked = window.state.frame
    expected = clicked if clicked in window.state.analysis.key_frames else -1
    assert window.state.selected_key == expected
    assert np.hypot(*np.subtract(plot.point_xy(clicked), plot.point_xy(key))) < 0.15

    plot.keys.setValue(5)
    qtbot.waitUntil(lambda: len(window.state.analysis.key_frames) == 5, timeout=10_000)
    window.state.set_frame(50)
    plot.pin.click()
    qtbot.waitUntil(lambda: 50 in window.state.analysis.key_frames, timeout=10_000)
    window.state.set_frame(window.state.analysis.key_frames[0])
    dropped = window.state.frame
    plot.drop.click()
    qtbot.waitUntil(lambda: dropped not in window.state.analysis.key_frames, timeout=10_000)


def test_save_reopen_gives_the_same_project(qtbot, make_window, asker, canter_clip, tmp_path):
    first = make_window()
    first.open_path(canter_clip / "masks")
    wait_ready(qtbot, first)
    choose_tool(first, Tool.DRAW)
    first.state.set_frame(3)
    qtbot.waitUntil(lambda: first.frame_view.shown_frame == 3)
    drag(qtbot, first, [(50, 50), (90, 80)])
    first.pc_plot.pcs.setValue(3)
    first.state.set_frame(20)
    first.pc_plot.pin.click()
    first.animation_view.loop.setChecked(True)
    first.animation_view.clamp.setChecked(True)
    asker.next_save_path = tmp_path / "horse.gaitproj"
    assert first.documents.save()
    assert first.state.undo_stack.isClean() and not first.isWindowModified()
    saved = first.state.project
    assert load_project(tmp_path / "horse.gaitproj") == saved

    second = make_window()
    assert second.open_path(tmp_path / "horse.gaitproj")
    wait_ready(qtbot, second)
    assert second.state.project == saved
    assert second.state.analysis.settings.pcs == 3 and 20 in second.state.analysis.key_frames
    view = second.animation_view
    assert view.loop.isChecked() and view.clamp.isChecked() and not view.filtered.isChecked()
    assert second.animator.options.loop
    assert str(tmp_path / "horse.gaitproj") in second.documents.recent_files()[0]
    # The unsaved-changes question names the project, or the footage of a new one.
    second.pc_plot.pcs.setValue(2)
    assert second.documents.may_close() and asker.asked[-1] == "save changes to horse.gaitproj"
    third = make_window()
    third.open_path(canter_clip / "masks")
    wait_ready(qtbot, third)
    third.pc_plot.pcs.setValue(3)
    assert third.documents.may_close()
    assert asker.asked[-1] == "save changes to the new project on masks"


def test_corrupt_and_newer_projects_give_a_message_and_stay_untouched(qtbot, window, asker,
                                                                      tmp_path):
    corrupt = tmp_path / "corrupt.gaitproj"
    corrupt.write_text('{"format": "gaitstudio-project", "version": 1, "footage": ')
    newer = tmp_path / "newer.gaitproj"
    newer.write_text('{"format": "gaitstudio-project", "version": 7}')
    before = window.state.project
    assert not window.open_path(corrupt)
    assert not window.open_path(newer)
    assert "damaged" in asker.errors[0] and "newer Gait Studio" in asker.errors[1]
    assert window.state.project is before and window.state.path is None
    assert corrupt.read_text().endswith('"footage": ') and '"version": 7' in newer.read_text()


def test_moved_footage_asks_where_it_went(qtbot, make_window, asker, canter_clip, tmp_path):
    import shutil

    clip = tmp_path / "clip"
    shutil.copytree(canter_clip / "images", clip)
    first = make_window()
    first.open_path(clip)
    wait_ready(qtbot, first)
    asker.next_save_path = tmp_path / "p.gaitproj"
    first.documents.save()
    shutil.move(str(clip), str(tmp_path / "elsewhere"))
    asker.relocate_to = tmp_path / "elsewhere"
    second = make_window()
    assert second.open_path(tmp_path / "p.gaitproj")
    assert asker.relocate_asked == [clip]
    assert second.state.source is not None and second.state.n_frames == 100
    assert not second.state.undo_stack.isClean()


def test_space_plays_and_arrows_step(qtbot, window, canter_clip):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    window.activateWindow()
    qtbot.waitUntil(window.isActiveWindow)  # asynchronous on a real display (xcb)
    window.frame_view.setFocus()
    qtbot.keyClick(window.frame_view, Qt.Key.Key_Right)
    assert window.state.frame == 1
    qtbot.keyClick(window.frame_view, Qt.Key.Key_End)
    assert window.state.frame == 99
    qtbot.keyClick(window.frame_view, Qt.Key.Key_Space)
    assert window.player.playing
    qtbot.waitUntil(lambda: window.state.frame < 99, timeout=2000)
    qtbot.keyClick(window.frame_view, Qt.Key.Key_Space)
    assert not window.player.playing


def test_timeline_click_moves_the_frame(qtbot, window, canter_clip):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    timeline = window.timeline
    x = int(timeline.x_of(64))
    qtbot.mouseClick(timeline, Qt.MouseButton.LeftButton, pos=QPoint(x, 25))
    assert window.state.frame == 64


def test_a_long_analysis_shows_its_progress_and_cancel_stops_it(qtbot, window, monkeypatch):
    slow_chunks = image_pca._chunks
    taken = [0]  # chunks of frames the analysis has read
    per_pass: list[int] = []

    def chunks(flat, scale):  # a long clip's PCA, made slow enough to watch
        blocks = list(slow_chunks(flat, scale))
        per_pass.append(len(blocks))
        for rows in blocks:
            time.sleep(0.05)
            taken[0] += 1
            yield rows

    monkeypatch.setattr(image_pca, "DENSE_LIMIT", 1000)
    monkeypatch.setattr(image_pca, "_chunks", chunks)
    silhouettes = Silhouettes(crop_rois(walker_clip(600)), "masks")
    window.state.set_project(replace(window.state.project, silhouettes=silhouettes))
    qtbot.waitUntil(lambda: any(d.isVisible() for d in window.findChildren(ProgressDialog)),
                    timeout=10_000)
    dialog = next(d for d in window.findChildren(ProgressDialog) if d.isVisible())
    qtbot.waitUntil(lambda: dialog.labelText().endswith("%"), timeout=5000)
    assert dialog.labelText().startswith("Analysing the clip: ")
    at_click = taken[0]
    qtbot.mouseClick(dialog.findChild(QPushButton), Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not window.analysis.running, timeout=5000)
    # Stopped at the next chunk, with more than that still to read.
    whole = image_pca._STREAM_PASSES * per_pass[0]
    assert taken[0] - at_click <= 2 < whole - at_click
    assert window.state.analysis is None


def test_the_footage_fit_is_one_undo_step_per_control_and_kept_in_the_project(qtbot, window,
                                                                                 canter_clip):
    assert window.open_path(canter_clip / "masks")
    wait_ready(qtbot, window)
    viewport, stack = window.viewport, window.state.undo_stack
    before = stack.count()
    viewport.fit_scale.stepUp()
    viewport.fit_scale.stepUp()
    viewport.fit_x.setValue(12)
    viewport.flip.setChecked(True)
    fit = window.state.project.footage_fit
    assert (fit.scale, fit.offset_x_m, fit.offset_y_m, fit.flip) == (pytest.approx(1.1),
                                                                      pytest.approx(0.12), 0, True)
    assert stack.count() == before + 3  # the two size steps merged
    stack.undo()
    stack.undo()
    assert window.state.project.footage_fit.offset_x_m == 0 and viewport.fit_x.value() == 0
    assert not viewport.flip.isChecked() and viewport.fit_scale.value() == 110
    viewport.fit_auto.click()
    assert window.state.project.footage_fit.scale == 1.0 and viewport.fit_scale.value() == 100


def test_a_segmentation_started_on_one_clip_never_lands_in_the_next(qtbot, window, canter_clip):
    """Open another file while a clip segments: the old clip's silhouettes are dropped."""
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    choose_tool(window, Tool.SUBJECT)
    drag(qtbot, window, [(140, 100), (180, 125)])
    choose_tool(window, Tool.BACKGROUND)
    drag(qtbot, window, [(5, 5), (310, 35)])
    job = window.tools.segment()
    finished = []
    job.finished.connect(lambda: finished.append(1))
    qtbot.waitSignal(job.progressed, timeout=20_000).wait()
    assert not finished, "the job must still be running when the other file opens"
    window.open_path(canter_clip / "masks")  # another project, opened mid-segmentation
    qtbot.waitUntil(lambda: not window.runner.busy, timeout=60_000)
    assert finished
    opened = window.state.project
    assert opened.footage.name == "masks"
    assert not opened.subject_rects and opened.silhouettes is not None
    assert opened.silhouettes.origin == "masks"  # the tracked masks, not the old clip's cut-out
    assert window.state.undo_stack.count() == 0


def test_one_box_around_the_animal_is_enough_to_segment(qtbot, window, canter_clip, tmp_path,
                                                        artifacts_dir):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, [(6, 36), (200, 150), (312, 232)])
    box = window.state.project.box
    assert box is not None and not window.state.project.subject_rects
    assert abs(box.x - 6) <= 2 and abs(box.w - 306) <= 3
    job = window.tools.segment()
    assert job.unit is None  # its progress counts passes over the frames: shown in per cent
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    wait_ready(qtbot, window)
    silhouettes = window.state.project.silhouettes
    assert silhouettes.origin == "segmented" and silhouettes.roi.lost.sum() <= 2
    assert window.state.analysis.diagnosis.correlations[0] > 0.6
    window.grab().save(str(artifacts_dir / "app_segmented_from_box.png"))
    path = tmp_path / "boxed.gaitproj"
    assert window.documents._save_to(path)
    assert load_project(path).box == box
    stack = window.state.undo_stack
    stack.undo()  # the segmentation
    stack.undo()  # the box
    assert window.state.project.box is None


def test_large_footage_gives_the_footage_the_window_then_the_layout_back(qtbot, window,
                                                                        canter_clip,
                                                                        artifacts_dir):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    shown = {name: dock.isVisible() for name, dock in window.docks.items()}
    sizes, width = window.views.sizes(), window.frame_view.width()
    window.large_footage_action.trigger()
    qtbot.waitUntil(lambda: window.frame_view.width() > 2 * width)
    assert [name for name, dock in window.docks.items() if dock.isVisible()] == ["timeline"]
    assert not window.viewport.isVisible() and window.large_footage_action.isChecked()
    assert window.frame_view.width() >= 0.95 * window.width()
    window.grab().save(str(artifacts_dir / "app_large_footage.png"))
    window.large_footage_action.trigger()
    qtbot.waitUntil(lambda: window.viewport.isVisible())
    assert {name: dock.isVisible() for name, dock in window.docks.items()} == shown
    assert not window.large_footage_action.isChecked()
    assert np.allclose(window.views.sizes(), sizes, atol=4)  # the splitter's share, as before


def test_closed_with_the_footage_large_the_next_start_has_its_panels(qtbot, make_window):
    from PySide6.QtCore import QSettings

    first = make_window(remember_layout=True)
    first.set_large_footage(True)
    assert not first.docks["pcs"].isVisible()
    first.close()
    try:
        again = make_window(remember_layout=True)
        qtbot.waitUntil(lambda: again.docks["pcs"].isVisible())
        assert again.docks["posing"].isVisible() and not again.large_footage_action.isChecked()
    finally:
        settings = QSettings()
        settings.remove("window/geometry")
        settings.remove("window/state")
