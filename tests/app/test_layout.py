"""The window at its first-start layout, 1500x950: the footage big enough to work on, every
name and verdict whole, the verdict read without scrolling."""

from __future__ import annotations

from PySide6.QtCore import QPoint

from app.main_window import LOOP_WIDTH
from tests.app.posing_helpers import open_demo

WIDTH, HEIGHT = 1500, 950


def test_the_first_start_layout_shows_footage_names_and_verdict_whole(qtbot, window, canter_clip,
                                                                       artifacts_dir):
    open_demo(qtbot, window, canter_clip)
    window.resize(WIDTH, HEIGHT)
    qtbot.wait(50)
    window.reset_layout()
    qtbot.wait(100)
    window.grab().save(str(artifacts_dir / "app_layout_1500x950.png"))
    assert window.frame_view.width() >= 500
    assert window.frame_view.width() + window.viewport.width() >= WIDTH // 2
    # the rig's viewport keeps its bars whole
    assert window.viewport.width() >= window.viewport.minimumSizeHint().width()
    assert abs(window.docks["pcs"].width() - LOOP_WIDTH) <= 20
    # Every joint's name whole in the tree: its column fits the tree without scrolling.
    tree = window.pose_panel.joints
    tree.expandAll()
    qtbot.wait(50)
    assert tree.header().sectionSize(0) <= tree.viewport().width()
    assert not tree.horizontalScrollBar().isVisible()
    # The verdict is in view in its dock, not scrolled to, and its text is not cut.
    verdict = window.diagnosis.verdict
    dock = window.docks["diagnosis"]
    top_left = verdict.mapTo(dock, QPoint(0, 0))
    assert 0 <= top_left.y() and top_left.y() + verdict.height() <= dock.height()
    assert verdict.sizeHint().width() <= verdict.width() or verdict.wordWrap()
    assert verdict.text().startswith("Usable") or "usable" in verdict.text().lower()
    # Back where it was after a panel is closed and the layout reset.
    window.docks["diagnosis"].close()
    window.reset_layout()
    assert window.docks["diagnosis"].isVisible()
