"""Every keyboard shortcut of the main window is listed and bound once (Qt otherwise logs
"Ambiguous shortcut overload" and does nothing)."""

from __future__ import annotations

from collections import defaultdict

from PySide6.QtGui import QAction, QKeySequence, QShortcut


def bound_shortcuts(window) -> dict[str, list[str]]:
    """Key sequence (portable text) -> what it triggers, over every QAction and QShortcut."""
    bound: dict[str, list[str]] = defaultdict(list)
    for action in window.findChildren(QAction):
        for seq in action.shortcuts():
            if not seq.isEmpty():
                bound[seq.toString(QKeySequence.SequenceFormat.PortableText)].append(
                    action.text().replace("&", "") or action.objectName())
    for shortcut in window.findChildren(QShortcut):
        seq = shortcut.key()
        if not seq.isEmpty():
            owner = shortcut.parent()
            bound[seq.toString(QKeySequence.SequenceFormat.PortableText)].append(
                f"shortcut of {type(owner).__name__}")
    return dict(bound)


def test_every_shortcut_is_bound_once(window, artifacts_dir):
    bound = bound_shortcuts(window)
    listing = "\n".join(f"{key:16} {', '.join(what)}" for key, what in sorted(bound.items()))
    (artifacts_dir / "shortcuts.txt").write_text(listing + "\n", encoding="utf-8")
    assert len(bound) >= 15, listing  # the listing found the menus, toolbar and viewport
    for key in ("Ctrl+Z", "Space", "Ctrl+Alt+C", "Ctrl+Shift+C", "F"):
        assert key in bound, listing
    duplicates = {key: what for key, what in bound.items() if len(what) > 1}
    assert not duplicates, f"bound more than once: {duplicates}"
