"""Brush corrections on any frame, re-propagated as one undo step; scribbles and masks files."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from app.commands import AddStrokesCommand, SetBoxCommand
from app.widgets.frame_canvas import Tool
from app.widgets.timeline import CORRECTED_COLOUR
from gaitcore.project.roto_session import RotoSession
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke
from tests.app.conftest import wait_ready
from tests.app.test_main_window import choose_tool, drag

BOX_DRAG = [(1, 36), (150, 120), (296, 220)]
"""The canter's box on frame 0: its reference mask's bounding box padded 4% (as the scripted
user of the segmentation bench draws it)."""
HEAD_0 = [(242, 48), (262, 72), (284, 96)]
"""Along the horse's head on frame 0."""
HEAD_30 = [(240, 50), (262, 70), (282, 90)]
"""Along the horse's head on frame 30."""
HEAD_60 = [(232, 52), (250, 62), (268, 72), (284, 84)]
"""Along the horse's head on frame 60."""


def _segment_from_box(qtbot, window, canter_clip):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, BOX_DRAG)
    qtbot.waitUntil(lambda: window.frame_view.preview is not None, timeout=20_000)
    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    wait_ready(qtbot, window)
    return window.state.project


def _paint(qtbot, window, tool, frame, points):
    window.state.set_frame(frame)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == frame)
    choose_tool(window, tool)
    drag(qtbot, window, points)
    qtbot.waitUntil(lambda: not window.tools.roto.busy, timeout=60_000)
    wait_ready(qtbot, window)


def _assert_no_frame_lost_and_legs(sil):
    """No frame lost, and the legs: the lower third of each silhouette's window is not
    empty."""
    assert not sil.roi.lost.any()
    rows = sil.roi.crops.shape[1]
    lower = sil.roi.crops[:, 2 * rows // 3 :, :].sum(axis=(1, 2))
    assert (lower > 0.02 * sil.roi.crops[:, :2 * rows // 3, :].sum(axis=(1, 2))).all(), lower


def _screenshot_of_the_footage(qtbot, window, path):
    """The window with the footage large (the docks of posing away) saved to ``path``."""
    for name, dock in window.docks.items():
        if name != "timeline":
            dock.close()
    window.viewport.hide()
    qtbot.wait(200)
    wait_ready(qtbot, window)
    window.grab().save(str(path))


def _same_outside(a, b, first, stop):
    """Silhouettes ``a`` and ``b`` agree on every frame outside ``first <= t < stop``."""
    outside = np.r_[0:first, stop:a.n_frames]
    assert np.array_equal(a.roi.lost[outside], b.roi.lost[outside])
    assert np.array_equal(a.roi.centers_xy[outside], b.roi.centers_xy[outside], equal_nan=True)
    if a.roi.crops.shape == b.roi.crops.shape and a.roi.scale == b.roi.scale:  # same window
        assert np.array_equal(a.roi.crops[outside], b.roi.crops[outside])


def test_a_brush_correction_repropagates_as_one_undo_step(qtbot, window, canter_clip,
                                                         artifacts_dir):
    segmented = _segment_from_box(qtbot, window, canter_clip)
    stack = window.state.undo_stack
    steps = stack.count()
    # "The head is not the subject" on frame 30 (the mask loses it there and after), then
    # "it is" on frame 60: the second changes only the frames between the key frames around
    # it (30 and the end of the clip).
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 30, HEAD_30)
    first_fix = window.state.project
    assert first_fix.corrected_frames() == (30,) and stack.count() == steps + 1
    assert first_fix.silhouettes.roi.crops[30].sum() < segmented.silhouettes.roi.crops[30].sum()
    _paint(qtbot, window, Tool.SUBJECT_BRUSH, 60, HEAD_60)
    second_fix = window.state.project
    assert [sc.label for sc in second_fix.scribbles] == ["background", "subject"]
    assert stack.count() == steps + 2 and stack.undoText() == "paint subject stroke"
    first, stop = window.tools.roto.session.changed
    assert 30 < first <= 60 < stop
    _same_outside(first_fix.silhouettes, second_fix.silhouettes, first, stop)
    assert not np.array_equal(first_fix.silhouettes.roi.crops[60],
                              second_fix.silhouettes.roi.crops[60])
    window.state.set_frame(60)
    wait_ready(qtbot, window)
    window.grab().save(str(artifacts_dir / "app_brush_correction.png"))
    shot = window.timeline.grab().toImage()
    shot.save(str(artifacts_dir / "app_timeline_corrected.png"))
    track = window.timeline._track()
    for frame, corrected in ((30, True), (45, False), (60, True)):
        x = round(window.timeline.x_of(frame) + (2 if frame == 60 else 0))  # beside the cursor
        colour = shot.pixelColor(x, round(track.center().y())).name()
        assert (colour == CORRECTED_COLOUR.name()) == corrected, (frame, colour)

    stack.undo()  # strokes and silhouettes together, exactly
    assert window.state.project == first_fix
    stack.redo()
    assert window.state.project == second_fix
    stack.undo()
    stack.undo()
    assert window.state.project.scribbles == () and window.state.project == segmented
    # A correction after the undo starts from the segmentation without the undone strokes.
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 60, HEAD_60)
    again = window.state.project
    assert again.corrected_frames() == (60,)
    _same_outside(segmented.silhouettes, again.silhouettes, *window.tools.roto.session.changed)


def test_a_cancelled_correction_changes_nothing_and_the_next_one_is_right(qtbot, window,
                                                                          canter_clip):
    segmented = _segment_from_box(qtbot, window, canter_clip)
    window.state.set_frame(60)
    job = window.tools.roto.paint(Scribble(HEAD_60, 8, 60, "background"))
    job.progressed.connect(lambda done, total: job.cancel())
    with qtbot.waitSignal(job.cancelled, timeout=60_000):
        pass
    qtbot.waitUntil(lambda: not window.tools.roto.busy)
    assert window.state.project == segmented and window.state.undo_stack.count() == 2
    stroke = Scribble(HEAD_30, 8, 30, "background")
    job = window.tools.roto.paint(stroke)
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    # The same as that one correction on a fresh segmentation: nothing of the cancelled
    # correction is left in the engine.
    fresh = RotoSession.start(window.state.source, segmented)
    fresh.correct(segmented, [stroke])
    assert window.state.project.silhouettes == fresh.silhouettes()


def test_strokes_before_segmenting_refine_the_first_frame_and_are_used(qtbot, window,
                                                                        canter_clip,
                                                                        artifacts_dir):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, BOX_DRAG)
    qtbot.waitUntil(lambda: window.frame_view.preview is not None, timeout=20_000)
    wait_ready(qtbot, window)
    cut = window.frame_view.preview.copy()
    assert cut.shape == (240, 320) and 0.05 < cut.mean() < 0.6
    window.grab().save(str(artifacts_dir / "app_first_frame_cutout.png"))
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 0, HEAD_0)
    qtbot.waitUntil(lambda: not np.array_equal(window.frame_view.preview, cut), timeout=20_000)
    assert window.frame_view.preview.sum() < cut.sum()
    window.grab().save(str(artifacts_dir / "app_first_frame_cutout_refined.png"))
    assert window.state.project.silhouettes is None and window.state.undo_stack.count() == 2
    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    assert window.tools.roto.session.states()[0].corrected


def test_scribbles_and_masks_round_trip(qtbot, window, canter_clip, asker, tmp_path):
    _segment_from_box(qtbot, window, canter_clip)
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 30, HEAD_30)
    painted = window.state.project
    path = tmp_path / "strokes.json"
    assert window.tools.roto.export_scribbles(path)
    asker.next_export_path = tmp_path / "out"
    job = window.tools.roto.export_masks()
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    # The export holds the engine until its `finished` lands, after `succeeded`: strokes
    # imported before then wait for it (and come with the next job, not this one).
    qtbot.waitUntil(lambda: not window.tools.roto.busy, timeout=60_000)
    masks = sorted((tmp_path / "out" / "masks").glob("*.png"))
    assert len(masks) == 100
    mask = cv2.imread(str(masks[30]), cv2.IMREAD_UNCHANGED)
    assert mask.shape == (240, 320) and set(np.unique(mask)) == {0, 255}
    states = json.loads((tmp_path / "out" / "segmentation.json").read_text())["frames"]
    assert [s["frame"] for s in states if s["corrected"]] == [30]

    window.state.undo_stack.undo()
    assert window.state.project.scribbles == ()
    job = window.tools.roto.import_scribbles(path)  # one undo step, re-propagated
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    qtbot.waitUntil(lambda: not window.tools.roto.busy)
    assert window.state.project.scribbles == painted.scribbles
    assert window.state.project.silhouettes == painted.silhouettes
    assert window.state.undo_stack.undoText() == "import background stroke"


@pytest.mark.parametrize("content", [
    "{not json",
    '{"scribbles": [{"frame": 3, "label": "sky", "width": 8, "points": [[1, 2]]}]}',
    '{"scribbles": [{"frame": 500, "label": "subject", "width": 8, "points": [[1, 2]]}]}',
    '{"scribbles": [{"frame": 3, "label": "subject", "width": 8, "points": [[900, 900]]}]}',
])
def test_a_bad_scribbles_file_says_why_and_changes_nothing(qtbot, window, canter_clip, asker,
                                                         tmp_path, content):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    before = window.state.project
    path = tmp_path / "bad.json"
    path.write_text(content)
    assert window.tools.roto.import_scribbles(path) is None
    assert len(asker.errors) == 1 and "nothing was imported" in asker.errors[0]
    assert "\n" not in asker.errors[0] and "Traceback" not in asker.errors[0]
    assert window.state.project is before and window.state.undo_stack.count() == 0


def test_real_footage_box_and_a_correction_keep_the_legs(qtbot, window, shared_data,
                                                         artifacts_dir):
    """Muybridge's race horse (15 photographs, 960x540) from the issue's box; on frame 7 a
    background stroke along the ground the mask took re-propagates; the screenshot shows the
    overlay."""
    frames = shared_data / "muybridge-race-horse" / "frames"
    window.open_path(frames)
    wait_ready(qtbot, window, timeout_ms=60_000)
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, [(110, 30), (500, 250), (870, 450)])
    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=120_000):
        pass
    wait_ready(qtbot, window, timeout_ms=60_000)
    _assert_no_frame_lost_and_legs(window.state.project.silhouettes)
    before = window.state.project.silhouettes
    window.tools.pen.setValue(14)
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 7, [(10, 528), (250, 528), (480, 528)])
    after = window.state.project.silhouettes
    assert window.state.project.corrected_frames() == (7,)
    assert after.roi.crops[7].sum() <= before.roi.crops[7].sum()
    _screenshot_of_the_footage(qtbot, window, artifacts_dir / "app_real_footage_legs.png")


SKETCH_0 = [  # rough strokes over the canter's frame 0: spine to head, ear, tail, four legs
    [(60, 110), (130, 105), (200, 100), (232, 80), (258, 70), (280, 92)],
    [(247, 58), (250, 70)],
    [(20, 138), (40, 125)],
    [(112, 140), (118, 170), (124, 185)],
    [(128, 150), (132, 170), (138, 185), (142, 200)],
    [(168, 140), (155, 170), (147, 185)],
    [(222, 140), (224, 170), (209, 185)],
]


def test_a_sketch_on_one_frame_propagates_with_the_engine_in_one_action(qtbot, window,
                                                                        canter_clip):
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    for points in SKETCH_0:  # as the draw tool makes them (mouse strokes: test_main_window)
        window.state.undo_stack.push(AddStrokesCommand(window.state, [Stroke(points, 5, 0)]))
    assert len(window.state.project.strokes) == len(SKETCH_0)
    window.tools.sketch_engine_action.trigger()
    qtbot.waitUntil(lambda: window.state.project.silhouettes is not None, timeout=60_000)
    project = window.state.project
    assert project.box is not None and project.corrected_frames() == (0,)
    assert all(sc.label == "subject" for sc in project.scribbles)
    assert window.state.undo_stack.count() == len(SKETCH_0) + 2  # + sketch as strokes, segment
    session = window.tools.roto.session
    scores = []
    for t in range(0, 100, 9):
        truth = cv2.imread(str(canter_clip / "masks" / f"{t:05d}.png"), cv2.IMREAD_GRAYSCALE) > 0
        mask = session.mask(t) > 0
        scores.append((mask & truth).sum() / (mask | truth).sum())
    assert min(scores) > 0.8, np.round(scores, 2)



def test_a_box_over_the_whole_frame_says_why_and_keeps_the_box(qtbot, window, canter_clip,
                                                               asker, without_saliency):
    """The canvas cannot draw it (its corners are pixel centres), a project file can hold it."""
    window.open_path(canter_clip / "images")
    wait_ready(qtbot, window)
    window.state.undo_stack.push(SetBoxCommand(window.state, Rect(0, 0, 320, 240)))
    qtbot.waitUntil(lambda: bool(asker.errors), timeout=20_000)
    assert len(asker.errors) == 1 and "fills the whole box" in asker.errors[0]
    assert window.state.project.box == Rect(0, 0, 320, 240) and window.frame_view.preview is None
    window.tools.segment()
    qtbot.waitUntil(lambda: len(asker.errors) == 2, timeout=60_000)
    assert "fills the whole box" in asker.errors[1] and window.state.project.silhouettes is None


def test_real_footage_from_brush_strokes_alone_keeps_the_legs(qtbot, window, shared_data,
                                                              artifacts_dir):
    """Muybridge's race horse with no box: a subject stroke along the neck and background
    strokes on the sky and the ground are enough to segment the clip; the screenshot shows
    the overlay."""
    window.open_path(shared_data / "muybridge-race-horse" / "frames")
    wait_ready(qtbot, window, timeout_ms=60_000)
    window.tools.pen.setValue(8)
    for tool, points in ((Tool.SUBJECT_BRUSH, [(565, 175), (620, 174), (675, 172)]),
                         (Tool.BACKGROUND_BRUSH, [(20, 45), (480, 45), (940, 45)]),
                         (Tool.BACKGROUND_BRUSH, [(660, 400), (800, 400), (940, 400)])):
        _paint(qtbot, window, tool, 0, points)
    assert window.state.project.box is None
    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=120_000):
        pass
    wait_ready(qtbot, window, timeout_ms=60_000)
    _assert_no_frame_lost_and_legs(window.state.project.silhouettes)
    window.state.set_frame(5)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == 5)
    _screenshot_of_the_footage(qtbot, window, artifacts_dir / "app_real_footage_from_strokes.png")


def test_the_timeline_marks_the_frames_to_check_and_k_goes_to_them(qtbot, window, tmp_path,
                                                                    asker, artifacts_dir,
                                                                    without_saliency):
    """A body that fades in a shade on frames 5-7 (see ``shaded_scene``): after segmenting,
    the timeline shows frame 5 (kept, at a low confidence) faint red and the lost frames 6
    and 7 red; K goes from frame 0 to 5, then 6; a background stroke on frame 6 takes it off
    (a subject stroke there finds the body, and no frame is left to check);
    saved and reopened, the project shows the same marks before any correction."""
    from PySide6.QtGui import QAction, QKeySequence

    from app.widgets.timeline import CHECK_COLOUR, LOST_COLOUR
    from tests.gaitcore.test_roto_session import shaded_scene

    box = shaded_scene(tmp_path / "shade")
    window.open_path(tmp_path / "shade")
    wait_ready(qtbot, window)
    (go,) = [a for a in window.findChildren(QAction) if a.shortcut() == QKeySequence("K")]
    go.trigger()  # nothing segmented yet: says so, stays
    assert window.state.frame == 0 and "yet" in window.statusBar().currentMessage()
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, [(box.x, box.y), (box.x + box.w // 2, box.y + box.h // 2),
                         (box.x + box.w, box.y + box.h)])
    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=60_000):
        pass
    assert "4 frames to check" in window.statusBar().currentMessage()
    wait_ready(qtbot, window)
    timeline = window.timeline
    assert timeline.frames_to_check() == (5, 6, 7, 8)
    window.state.set_frame(0)
    shot = timeline.grab().toImage()
    shot.save(str(artifacts_dir / "app_timeline_to_check.png"))
    y = round(timeline._track().center().y())
    colour = {f: shot.pixelColor(round(timeline.x_of(f)), y) for f in (3, 5, 6, 10)}
    assert colour[6].name() == LOST_COLOUR.name()
    assert colour[3] == colour[10] and colour[3].red() == colour[3].green()  # the bare track
    faint = colour[5]
    assert faint.red() > faint.green() + 40 and faint.name() != LOST_COLOUR.name()
    assert CHECK_COLOUR.alpha() < 255
    go.trigger()
    assert window.state.frame == 5
    go.trigger()
    assert window.state.frame == 6 and "4 frames to check" in window.statusBar().currentMessage()
    _paint(qtbot, window, Tool.BACKGROUND_BRUSH, 6, [(20, 100), (40, 100), (60, 100)])
    assert window.state.project.corrected_frames() == (6,)
    marked = timeline.frames_to_check()
    assert marked == (5, 7, 8)  # as before the stroke, less frame 6: 8 still found again
    # Saved and reopened: the marks are back at once, before the engine is.
    asker.next_save_path = tmp_path / "shade.gaitproj"
    assert window.documents.save_as()
    assert window.open_path(tmp_path / "shade.gaitproj")
    wait_ready(qtbot, window)
    assert window.tools.roto.session is None and timeline.frames_to_check() == marked
    assert f"{len(marked)} frames to check" in window.statusBar().currentMessage()
    window.state.set_frame(0)
    go.trigger()
    assert window.state.frame == marked[0]
    timeline.grab().save(str(artifacts_dir / "app_timeline_to_check_reopened.png"))
    # Other inputs than those saved (the box moved): no marks, and K says why.
    window.state.undo_stack.push(SetBoxCommand(window.state, Rect(10, 30, 80, 50)))
    assert timeline.frames_to_check() == ()
    go.trigger()
    assert "yet" in window.statusBar().currentMessage()
