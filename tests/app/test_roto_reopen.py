"""A segmented project saved, closed and reopened: the first brush correction re-propagates
only around its frame, with the engine saved beside the project, as if it had stayed open."""

from __future__ import annotations

from app.widgets.frame_canvas import Tool
from gaitcore.project.engine_file import ENGINE_FILE
from gaitcore.project.roto_session import RotoSession
from gaitcore.project.storage import sidecar_dir
from tests.app.conftest import wait_ready
from tests.app.test_roto_brush import HEAD_30, HEAD_60, _paint, _segment_from_box


def test_the_first_correction_after_reopening_needs_no_new_segmentation(
        qtbot, window, canter_clip, asker, tmp_path, monkeypatch, artifacts_dir):
    _segment_from_box(qtbot, window, canter_clip)
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 30, HEAD_30)  # a key frame on 30
    saved = window.state.project
    path = tmp_path / "canter.gaitproj"
    asker.next_save_path = path
    assert window.documents.save_as()
    assert (sidecar_dir(path) / ENGINE_FILE).is_file()
    # What the correction on frame 60 gives in the session that stays open.
    _paint(qtbot, window, Tool.SUBJECT_BRUSH, 60, HEAD_60)
    expected, expected_range = window.state.project, window.tools.roto.session.changed
    window.state.undo_stack.undo()
    assert window.state.undo_stack.isClean()

    assert window.open_path(path)
    wait_ready(qtbot, window)
    assert window.tools.roto.session is None and window.state.project == saved

    def refuse(*_args, **_kwargs):
        raise AssertionError("the whole clip was segmented again")

    monkeypatch.setattr(RotoSession, "start", refuse)
    # The very stroke the brush gave above, handed to the controller as the brush hands it:
    # a drag maps to image points through the view, whose size follows the window's layout
    # (it changed between frames 30 and 60 above), and this test is about the saved engine,
    # not that mapping (tests/app/test_roto_brush.py drives the brush).
    window.state.set_frame(60)
    wait_ready(qtbot, window)
    window.tools.roto.paint(expected.scribbles[-1])
    qtbot.waitUntil(lambda: not window.tools.roto.busy, timeout=60_000)
    wait_ready(qtbot, window)
    assert not asker.errors
    assert window.state.project.scribbles == expected.scribbles
    assert window.state.project.silhouettes == expected.silhouettes
    assert window.tools.roto.session.changed == expected_range == (31, 100)
    window.state.set_frame(60)
    wait_ready(qtbot, window)
    window.grab().save(str(artifacts_dir / "app_correction_after_reopening.png"))
    # Undo goes back to the project as it was opened, and a correction from there works.
    window.state.undo_stack.undo()
    assert window.state.project == saved
    # Erasing the opened project's stroke needs no new segmentation either.
    assert window.open_path(path)
    wait_ready(qtbot, window)
    job = window.tools.roto.erase({0})
    qtbot.waitUntil(lambda: not window.tools.roto.busy, timeout=60_000)
    assert job is not None and not asker.errors
    assert window.state.project.scribbles == ()
    assert window.tools.roto.session.changed == (1, 100)
    window.state.undo_stack.undo()
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 80, [(232, 52), (250, 62)])
    assert window.state.project.corrected_frames() == (30, 80)
    assert window.tools.roto.session.changed == (31, 100)
