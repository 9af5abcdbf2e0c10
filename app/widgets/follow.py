"""Controls that follow the project: show a value without reporting it as the artist's edit.

A control's change signal is an edit (an undo command). When the state changes under it (an
undo, a project opened) the control must only show the new value, so it is set with its
signals blocked.
"""

from __future__ import annotations

from PySide6.QtCore import QSignalBlocker
from PySide6.QtWidgets import QAbstractButton, QWidget


def show_value(control: QWidget, value: float | bool) -> None:
    """Set a spin box's value or a check box's state silently, if it differs."""
    if isinstance(control, QAbstractButton):
        if control.isChecked() != bool(value):
            with QSignalBlocker(control):
                control.setChecked(bool(value))
    elif control.value() != value:
        with QSignalBlocker(control):
            control.setValue(value)
