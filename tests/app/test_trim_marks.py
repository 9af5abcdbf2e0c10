"""In and out marks, the stretches of steady gait on the timeline, and the frame rate."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from tests.app.conftest import wait_ready
from tests.gaitcore.walker import walker_frame, write_mask_folder


def stand_walk_stand(folder):
    """40 still frames, 4 strides of the walker (96 frames), 40 still frames."""
    walking = [walker_frame(float(t)) for t in range(96)]
    clip = np.stack([walker_frame(0.0)] * 40 + walking + [walker_frame(96.0)] * 40)
    return write_mask_folder(folder, clip)


def action(window, text):
    return next(a for m in window.menuBar().actions() for a in m.menu().actions()
                if a.text().replace("&", "") == text)


def test_in_and_out_marks_undo_and_trim_to_a_stretch(qtbot, window, tmp_path, artifacts_dir):
    assert window.open_path(stand_walk_stand(tmp_path / "masks"))
    qtbot.waitUntil(lambda: window.state.analysis is not None, timeout=60_000)
    wait_ready(qtbot, window, 60_000)
    state, timeline = window.state, window.timeline
    cycles = timeline.cycles()
    assert len(cycles) == 1
    start, stop = cycles[0][:2]
    assert abs(start - 40) <= 5 and abs(stop - 136) <= 5

    state.set_frame(20)
    action(window, "Set in mark").trigger()
    state.set_frame(100)
    action(window, "Set out mark").trigger()
    assert state.project.trim == (20, 101)
    qtbot.waitUntil(lambda: state.analysis is not None and state.analysis.frame_range == (20, 101),
                    timeout=60_000)
    assert all(20 <= f < 101 for f in state.analysis.key_frames)
    state.undo_stack.undo()
    state.undo_stack.undo()
    assert state.project.trim == (0, None)

    x = timeline.x_of((start + stop) // 2)
    menu = timeline.context_menu(x)
    trim = next(a for a in menu.actions() if a.text().startswith("Trim to this stretch"))
    trim.trigger()
    assert state.project.trim == (start, stop)
    assert state.undo_stack.undoText() == "trim to a stretch"
    qtbot.waitUntil(lambda: state.analysis is not None
                    and state.analysis.frame_range == (start, stop),
                    timeout=60_000)

    # drag the in mark ten frames right: one undo step
    y = int(timeline._track().center().y())
    qtbot.mousePress(timeline, Qt.MouseButton.LeftButton,
                     pos=QPoint(int(timeline._edge_x(start)), y))
    qtbot.mouseMove(timeline, QPoint(int(timeline.x_of(start + 10)), y))
    qtbot.mouseRelease(timeline, Qt.MouseButton.LeftButton,
                       pos=QPoint(int(timeline.x_of(start + 10)), y))
    assert state.project.trim == (start + 10, stop)
    state.undo_stack.undo()
    assert state.project.trim == (start, stop)
    wait_ready(qtbot, window, 60_000)
    window.snapshot().save(str(artifacts_dir / "timeline_cycles_and_trim.png"))
    timeline.grab().save(str(artifacts_dir / "timeline_cycles_and_trim_close.png"))


def test_frame_rate_of_an_image_folder_is_set_undone_and_drives_playback(qtbot, window, asker,
                                                                          tmp_path):
    assert window.open_path(stand_walk_stand(tmp_path / "masks"))
    qtbot.waitUntil(lambda: window.state.analysis is not None, timeout=60_000)
    wait_ready(qtbot, window, 60_000)
    state = window.state
    assert state.fps is None and asker.asked == ["frame rate (24 offered)"]  # asked on opening
    assert "24 fps assumed" in window.statusBar().currentMessage()  # the artist said nothing
    asker.frame_rate_answer = 30.0
    action(window, "Set frame rate...").trigger()
    assert asker.asked[-1] == "frame rate (24 offered)"  # what playback uses, not another
    assert state.fps == 30.0 and state.project.fps == 30.0
    window.player.toggle()
    assert window.player._timer.interval() == 33
    window.player.stop()
    state.undo_stack.undo()
    assert state.fps is None


def test_alternates_beside_their_keys_earn_a_warning(qtbot, window, tmp_path):
    from dataclasses import replace

    from app.animation import swap_warning_for

    assert window.open_path(stand_walk_stand(tmp_path / "masks"))
    qtbot.waitUntil(lambda: window.state.analysis is not None, timeout=60_000)
    wait_ready(qtbot, window, 60_000)
    state = window.state
    project = replace(state.project, settings=replace(state.project.settings, switching=True))
    analysis = state.analysis
    beside = tuple(k + 1 for k in analysis.key_frames)
    assert "swaps left and right" in swap_warning_for(replace(project, alternates=beside), analysis)
    assert swap_warning_for(project, analysis) is None  # no alternates accepted: nothing to say


def test_a_video_whose_header_disagrees_opens_whole_with_a_note(qtbot, window, tmp_path):
    from tests.gaitcore.test_frames import _claim_frames, _write_30

    path = _claim_frames(_write_30(tmp_path / "clip.avi"), 40)
    assert window.open_path(path)
    assert window.state.n_frames == 30
    assert "header says 40 frames but 30 decode" in window.statusBar().currentMessage()
    window.state.set_frame(29)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == 29)


def test_a_trimmed_animation_exports_source_frames_at_the_clip_rate(qtbot, window, asker,
                                                                   canter_clip, tmp_path):
    from app.commands import TrimCommand
    from gaitcore.io.pose_table import read_pose_table
    from tests.app.posing_helpers import open_demo, true_poses

    open_demo(qtbot, window, canter_clip)
    state = window.state
    state.undo_stack.push(TrimCommand(state, 20, 80))
    qtbot.waitUntil(lambda: state.analysis is not None and state.analysis.frame_range == (20, 80),
                    timeout=60_000)
    truth = true_poses(state.skeleton)
    for k in state.analysis.key_frames:
        state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")
    qtbot.waitUntil(lambda: window.animator.animation is not None, timeout=20_000)
    animation = window.animator.animation
    np.testing.assert_allclose(animation.pose_at(state.analysis.key_frames[0]),
                               truth[state.analysis.key_frames[0]], atol=1e-9)
    asker.next_export_path = tmp_path / "curves.csv"
    job = window.exporter.export(".csv")
    with qtbot.waitSignal(job.finished, timeout=60_000):
        pass
    table = read_pose_table(tmp_path / "curves.csv")
    np.testing.assert_array_equal(table.frames, np.arange(20, 80))
    second = (tmp_path / "curves.csv").read_text().splitlines()[1].split(",")
    assert second[0] == "20" and float(second[1]) == pytest.approx(20 / state.fps)


def test_an_image_folder_asks_its_frame_rate_on_opening_and_keeps_it(qtbot, window, asker,
                                                                      tmp_path):
    asker.frame_rate_answer = 15.0
    assert window.open_path(stand_walk_stand(tmp_path / "masks"))
    wait_ready(qtbot, window, 60_000)
    state = window.state
    assert state.fps == 15.0 and state.project.fps == 15.0
    assert state.undo_stack.count() == 0  # the clip opened at its rate: not an edit to undo
    window.player.toggle()
    assert window.player._timer.interval() == 67
    window.player.stop()
