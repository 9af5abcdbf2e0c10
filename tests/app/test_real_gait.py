"""A ridden horse walking past a fixed camera, in the window: box, segment, analyse, usable.

Skipped where ``../shared/data/horse-walks`` is absent (the footage is not kept in the repo).
"""

from __future__ import annotations

import cv2
import pytest

from app.widgets.frame_canvas import Tool
from gaitcore.bench.real_gaits import Keypoints
from tests.app.conftest import wait_ready
from tests.app.test_main_window import choose_tool, drag


def usable_from_box(qtbot, window, box_xywh: tuple[int, int, int, int]):
    """Draw the box, segment, wait for the analysis; it is usable and the rig faces the way
    the horse walks (to the left). Returns the analysis."""
    x, y, w, h = box_xywh
    choose_tool(window, Tool.BOX)
    drag(qtbot, window, [(x, y), (x + w // 2, y + h // 2), (x + w, y + h)])
    job = window.tools.segment()
    with qtbot.waitSignal(job.succeeded, timeout=300_000):
        pass
    qtbot.waitUntil(lambda: window.state.analysis is not None, timeout=120_000)
    wait_ready(qtbot, window, 120_000)
    analysis = window.state.analysis
    assert analysis.diagnosis.verdict.value == "usable", analysis.diagnosis.reason
    assert window.state.project.footage_fit.flip  # walking left: faced without a Flip click
    return analysis


@pytest.mark.slow
def test_a_horse_walk_from_one_box_is_usable_and_shows_what_was_left_out(
        qtbot, window, shared_data, artifacts_dir):
    clip = shared_data / "horse-walks" / "tula"
    if not (clip / "source.avi").is_file():
        pytest.skip(f"the horse walks are not at {clip.parent}")
    video = clip / "source.avi"
    cap = cv2.VideoCapture(str(video))
    size = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    box_xywh = Keypoints.read(clip / "joints.csv").box(size)
    assert window.open_path(video)
    wait_ready(qtbot, window)
    analysis = usable_from_box(qtbot, window, box_xywh)
    box = window.state.project.box
    assert box is not None and abs(box.w - box_xywh[2]) <= 0.02 * box_xywh[2]
    # The horse enters and leaves the view: those frames are left out, and marked.
    left_out = window.timeline.left_out()
    assert left_out and left_out[0] < 5 and left_out[-1] > 50
    start, stop = analysis.frame_range
    assert all(f < start or f >= stop for f in left_out)
    # The PC plot names the pair it shows, which is not blindly PC1 x PC2.
    axis = window.pc_plot.plot.getAxis("bottom").labelText
    assert axis == analysis.component_names[0] and axis.startswith("PC")
    assert analysis.pair_name in window.pc_plot.plot.plotItem.titleLabel.text
    notes = " ".join(analysis.advice.notes)
    assert "only partly in view" in notes and "steady size" in notes
    window.state.set_frame(2)
    wait_ready(qtbot, window)
    window.grab().save(str(artifacts_dir / "app_horse_walk_usable.png"))
    window.timeline.grab().save(str(artifacts_dir / "app_horse_walk_timeline.png"))
    # An artist brings the frames where the horse leaves the view back: one undo step, and
    # the analysis runs over them.
    last = left_out[-1]
    menu = window.timeline.context_menu(window.timeline.x_of(last))
    back = next(a for a in menu.actions() if a.text().startswith("Analyse frames"))
    back.trigger()
    brought = window.state.project.settings.bring_back
    assert brought[-1] == last and len(brought) > 1
    qtbot.waitUntil(lambda: window.state.analysis is not None
                    and window.state.analysis.frame_range[1] > last, timeout=60_000)
    window.state.undo_stack.undo()
    assert window.state.project.settings.bring_back == ()
