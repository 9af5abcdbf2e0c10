"""Erasing brush strokes: highlighted under the eraser, re-propagated as one undo step."""

from __future__ import annotations

from app.widgets.frame_canvas import Tool
from app.widgets.frame_view import ERASE_COLOUR
from tests.app.conftest import wait_ready
from tests.app.test_main_window import choose_tool, drag
from tests.app.test_roto_brush import BOX_DRAG, HEAD_0, HEAD_30, _paint, _segment_from_box

ACROSS_HEAD_30 = [(250, 80), (262, 70), (272, 60)]
"""An eraser drag across the head stroke of frame 30, through its middle point."""


def _red_paths(window) -> int:
    """How many strokes the frame view draws in the eraser's colour."""
    return sum(1 for item in window.frame_view._overlays
               if hasattr(item, "path") and item.pen().color() == ERASE_COLOUR)


def _erase_showing(qtbot, window, points_xy, shot=None) -> int:
    """Drag the eraser through ``points_xy``; before the release, count the red strokes
    (and save a screenshot to ``shot``)."""
    red = []

    def look() -> None:
        red.append(_red_paths(window))
        if shot is not None:
            window.grab().save(str(shot))

    drag(qtbot, window, points_xy, before_release=look)
    return red[0]


def test_erasing_a_brush_stroke_repropagates_without_it_as_one_undo_step(
        qtbot, window, canter_clip, artifacts_dir):
    segmented = _segment_from_box(qtbot, window, canter_clip)
    stack = window.state.undo_stack
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 30, HEAD_30)
    painted = window.state.project
    assert painted.silhouettes != segmented.silhouettes
    steps = stack.count()
    job = window.tools.roto.erase({0})  # cancelled: nothing changes, the stroke stays
    job.progressed.connect(lambda done, total: job.cancel())
    with qtbot.waitSignal(job.cancelled, timeout=60_000):
        pass
    qtbot.waitUntil(lambda: not window.tools.roto.busy)
    assert window.state.project == painted and stack.count() == steps
    assert _red_paths(window) == 0
    for name, dock in window.docks.items():  # the footage large for the screenshot
        if name != "timeline":
            dock.close()
    window.viewport.hide()
    qtbot.wait(200)
    wait_ready(qtbot, window)
    choose_tool(window, Tool.DRAW)
    drag(qtbot, window, [(262, 50), (262, 95)])  # a sketch stroke the eraser will cross too
    sketched = window.state.project
    assert len(sketched.strokes) == 1 and stack.count() == steps + 1
    choose_tool(window, Tool.ERASE)
    red = _erase_showing(qtbot, window, ACROSS_HEAD_30, artifacts_dir / "app_erase_brush.png")
    assert red == 2  # the brush stroke and the sketch stroke under the eraser, highlighted
    assert window.tools.roto.busy and _red_paths(window) == 2  # and until the job lands
    assert window.state.project.strokes == sketched.strokes  # erased when the job lands
    assert window.tools.roto.erase({0}) is None  # one correction at a time
    qtbot.waitUntil(lambda: not window.tools.roto.busy, timeout=60_000)
    wait_ready(qtbot, window)
    erased = window.state.project
    assert erased.scribbles == () and erased.strokes == ()
    assert stack.count() == steps + 2  # the sketch stroke, then the drag that erased both
    assert stack.undoText() == "erase brush stroke and a sketch stroke"
    # The re-propagation without the stroke gives back the segmentation before it.
    assert erased.silhouettes == segmented.silhouettes
    first, stop = window.tools.roto.session.changed
    assert first <= 30 < stop and _red_paths(window) == 0
    stack.undo()  # the strokes and the silhouettes together
    assert window.state.project == sketched
    stack.redo()
    assert window.state.project == erased
    stack.undo()
    # A correction after the undo runs on the painted segmentation.
    _paint(qtbot, window, Tool.SUBJECT_BRUSH, 60, [(232, 52), (250, 62), (268, 72)])
    assert window.state.project.corrected_frames() == (30, 60)


def test_erasing_before_segmenting_takes_back_the_stroke_and_the_sketch(qtbot, window,
                                                                         canter_clip):
    """On a clip not segmented yet the eraser removes brush strokes at once (the first
    frame's cut-out follows); one drag over a sketch stroke and a brush stroke is one undo
    step."""
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, BOX_DRAG)
    qtbot.waitUntil(lambda: window.frame_view.preview is not None, timeout=20_000)
    cut = window.frame_view.preview.copy()
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 0, HEAD_0)
    qtbot.waitUntil(lambda: window.frame_view.preview.sum() < cut.sum(), timeout=20_000)
    choose_tool(window, Tool.DRAW)
    drag(qtbot, window, [(262, 60), (262, 100)])  # a sketch stroke across the brush stroke
    assert len(window.state.project.strokes) == 1
    steps = window.state.undo_stack.count()
    choose_tool(window, Tool.ERASE)
    assert _erase_showing(qtbot, window, [(250, 72), (262, 72), (274, 72)]) == 2
    project = window.state.project
    assert project.scribbles == () and project.strokes == ()
    assert window.state.undo_stack.count() == steps + 1
    assert window.state.undo_stack.undoText() == "erase brush stroke and a sketch stroke"
    qtbot.waitUntil(lambda: window.frame_view.preview.sum() == cut.sum(), timeout=20_000)
    window.state.undo_stack.undo()
    project = window.state.project
    assert len(project.scribbles) == 1 and len(project.strokes) == 1
    qtbot.waitUntil(lambda: window.frame_view.preview.sum() < cut.sum(), timeout=20_000)
