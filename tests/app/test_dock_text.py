"""Every dock's text can be read: labels get the height their wrapped text needs (a dock too
small for them scrolls instead of cutting them off)."""

from __future__ import annotations

from PySide6.QtWidgets import QLabel, QScrollArea

from tests.app.posing_helpers import open_demo


def cut_labels(window) -> list[str]:
    cut = []
    for name, dock in window.docks.items():
        if not dock.isVisible():
            continue
        for label in dock.findChildren(QLabel):
            if not label.isVisible() or not label.text() or not label.wordWrap():
                continue
            need = label.heightForWidth(label.width())
            if label.height() < need - 1:
                cut.append(f"{name}: {label.text()[:40]!r} ({label.height()} < {need} px)")
    return cut


def test_no_dock_cuts_its_text_off(qtbot, window, canter_clip, artifacts_dir):
    open_demo(qtbot, window, canter_clip)
    window.resize(1200, 760)  # a laptop screen: the docks get small
    qtbot.wait(200)
    assert not cut_labels(window), cut_labels(window)
    diagnosis = window.docks["diagnosis"].widget()
    assert isinstance(diagnosis, QScrollArea)
    window.snapshot().save(str(artifacts_dir / "app_docks_small_window.png"))


def test_the_verdict_is_read_above_the_spectrum_without_scrolling(qtbot, window, canter_clip):
    open_demo(qtbot, window, canter_clip)
    window.resize(1500, 950)
    qtbot.wait(200)
    area = window.docks["diagnosis"].widget()
    panel = area.widget()
    verdict = panel.verdict
    assert "Usable" in verdict.text() and "PC1 × PC2" in verdict.text()
    top = verdict.mapTo(area.viewport(), verdict.rect().topLeft()).y()
    bottom = verdict.mapTo(area.viewport(), verdict.rect().bottomLeft()).y()
    assert 0 <= top and bottom <= area.viewport().height()  # in view as the dock opens
    assert verdict.geometry().bottom() <= panel.plot.geometry().top()


def test_the_weights_legend_stands_under_the_curves(qtbot, window, canter_clip, artifacts_dir):
    from tests.app.posing_helpers import pose_keys_truly

    view = window.animation_view
    assert "x0.001" not in view.plot.getAxis("bottom").labelString()  # empty: no SI prefix
    open_demo(qtbot, window, canter_clip)
    pose_keys_truly(window)
    qtbot.waitUntil(lambda: window.animator.animation is not None, timeout=30_000)
    window.resize(1500, 950)
    qtbot.wait(200)
    names = [label.text for _, label in view.legend.items]
    assert len(names) == 5 and "Σ w_i" in names  # 4 keys and the sum
    curves = view.plot.plotItem.vb.sceneBoundingRect()
    assert view.legend.sceneBoundingRect().top() >= curves.bottom() - 1  # under, not over
    view.grab().save(str(artifacts_dir / "app_weights_plot.png"))
