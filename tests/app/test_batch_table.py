"""File > Open batch summary: a sortable table of the clips, each opening as its project."""

from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtCore import Qt

from gaitcore.project.batch import analyze_clip, pending, write_summary
from gaitcore.project.manifest import ClipSpec
from tests.app.conftest import wait_ready
from tests.gaitcore.walker import walker_clip, write_mask_folder


@pytest.fixture(scope="module")
def batch_dir(tmp_path_factory) -> Path:
    """A batch output: two analysed walkers (one trimmed), a failed clip, a pending one."""
    root = tmp_path_factory.mktemp("batch")
    out = root / "out"
    out.mkdir()
    good = write_mask_folder(root / "good", walker_clip(100, 24.0))
    noisy = write_mask_folder(root / "short", walker_clip(100, 24.0)[::3])
    junk = root / "junk.mp4"
    junk.write_bytes(b"junk" * 100)
    rows = [analyze_clip(ClipSpec("short", noisy.absolute()), out),
            analyze_clip(ClipSpec("good", good.absolute(), start=10, stop=90), out),
            analyze_clip(ClipSpec("junk", junk.absolute()), out),
            pending(ClipSpec("later", good.absolute()))]
    write_summary(out, rows, manifest=root / "manifest.csv")
    return out


def _shown(dialog) -> list[str]:
    return [dialog.row_at(r).clip for r in range(dialog.table.model().rowCount())]


def test_summary_ranks_usable_first_sorts_and_opens_a_clip_with_its_trim(
        qtbot, window, asker, batch_dir, artifacts_dir):
    asker.next_open_file = batch_dir / "summary.csv"
    window.open_batch_dialog()
    dialog = window.batch_table
    assert dialog is not None and asker.errors == []
    qtbot.waitExposed(dialog)
    shown = _shown(dialog)
    assert shown[0] == "good"  # usable, best r
    assert shown.index("junk") > shown.index("short") and len(shown) == 4
    dialog.table.sortByColumn(0, Qt.SortOrder.AscendingOrder)
    assert _shown(dialog) == sorted(shown)
    dialog.grab().save(str(artifacts_dir / "batch_table.png"))

    messages = []
    dialog.messageRaised.connect(messages.append)
    dialog.open_row(_shown(dialog).index("later"))
    assert messages and "not been analysed" in messages[0]

    dialog.open_row(_shown(dialog).index("good"))
    wait_ready(qtbot, window)
    project = window.state.project
    assert (project.frame_start, project.frame_stop) == (10, 90)
    # The footage and its silhouettes are whole; the trim limits the analysis to 10..90.
    assert project.silhouettes is not None and project.silhouettes.n_frames == 100
    assert window.state.n_frames == 100
    qtbot.waitUntil(lambda: window.state.analysis is not None, timeout=30_000)
    assert window.state.analysis.frame_range == (10, 90)
    assert window.state.path == batch_dir / "good" / "clip.gaitproj"


def test_a_file_that_is_not_a_summary_is_one_error(window, asker, tmp_path):
    bad = tmp_path / "summary.json"
    bad.write_text("{}")
    assert window.open_batch_summary(bad) is None
    assert len(asker.errors) == 1 and "cannot read the batch summary" in asker.errors[0]


@pytest.mark.parametrize("text", [
    '{"format": "gaitstudio-batch", "clips": [[1]]}',
    '{"format": "gaitstudio-batch", "clips": [{"clip": "a", "status": "done", "box": -1}]}',
    '{"format": "gaitstudio-batch", "clips": ' + "[" * 50_000 + "]" * 50_000 + "}",
])
def test_a_summary_of_the_wrong_types_or_nesting_is_one_error(window, asker, tmp_path, text):
    bad = tmp_path / "summary.json"
    bad.write_text(text)
    assert window.open_batch_summary(bad) is None
    assert len(asker.errors) == 1 and "\n" not in asker.errors[0]
