"""Undo commands on AppState: every edit is one step that undo and redo swap exactly."""

from __future__ import annotations

from dataclasses import replace

import pytest

from app.commands import (
    AddRectCommand,
    AddStrokesCommand,
    ChangeSettingsCommand,
    EraseStrokesCommand,
    ForbidKeyCommand,
    PinKeyCommand,
    RemoveRectCommand,
)
from app.state import AppState
from gaitcore.silhouettes.annotations import Rect, Stroke


@pytest.fixture
def state(qapp):
    s = AppState()
    yield s
    s.deleteLater()


def test_rectangles_add_remove_undo_redo(state):
    stack = state.undo_stack
    start = state.project
    stack.push(AddRectCommand(state, Rect(1, 2, 3, 4), subject=True))
    stack.push(AddRectCommand(state, Rect(5, 5, 9, 9), subject=False))
    assert state.project.subject_rects == (Rect(1, 2, 3, 4),)
    assert state.project.background_rects == (Rect(5, 5, 9, 9),)
    stack.push(RemoveRectCommand(state, Rect(1, 2, 3, 4)))
    assert state.project.subject_rects == ()
    for _ in range(3):
        stack.undo()
    assert state.project == start
    stack.redo()
    assert state.project.subject_rects == (Rect(1, 2, 3, 4),)


def test_one_stroke_is_one_step_and_erase_is_one_step(state, qtbot):
    stack = state.undo_stack
    stroke = Stroke([[0, 0], [5, 5], [9, 1]], 4, 0)
    with qtbot.waitSignal(state.projectChanged):
        stack.push(AddStrokesCommand(state, [stroke]))
    assert stack.count() == 1 and state.project.strokes == (stroke,)
    stack.push(EraseStrokesCommand(state, {0}))
    assert state.project.strokes == ()
    stack.undo()
    assert state.project.strokes == (stroke,)
    assert stack.undoText() == "draw stroke"


def test_settings_changes_of_one_field_merge(state):
    stack = state.undo_stack
    for keys in (5, 6, 7):
        settings = replace(state.project.settings, keys=keys)
        stack.push(ChangeSettingsCommand(state, settings, "keys"))
    assert stack.count() == 1 and state.project.settings.keys == 7
    stack.push(ChangeSettingsCommand(state, replace(state.project.settings, pcs=3), "pcs"))
    assert stack.count() == 2
    stack.undo()
    stack.undo()
    assert state.project.settings.keys == 4


def test_pin_and_drop_keys(state):
    stack = state.undo_stack
    stack.push(PinKeyCommand(state, 7))
    stack.push(ForbidKeyCommand(state, 9))
    assert state.project.settings.pinned == (7,) and state.project.settings.forbidden == (9,)
    stack.push(ForbidKeyCommand(state, 7))
    assert state.project.settings.pinned == () and state.project.settings.forbidden == (7, 9)
    stack.undo()
    assert state.project.settings.pinned == (7,)
