"""Tools > Load / Save segmentation settings: the project's profile, one undo step, and a
bad file is one dialog (issue #65: the app can change what the command can)."""

from __future__ import annotations

import json

from gaitcore.silhouettes.settings import (
    PropagationSettings,
    SegmentationSettings,
    read_settings,
    write_settings,
)


def test_a_profile_loads_as_one_undo_step_and_saves_back(window, asker, tmp_path):
    profile = SegmentationSettings(propagation=PropagationSettings(saliency_every=2,
                                                                   motion_weight=0.5))
    write_settings(tmp_path / "p.json", profile)
    asker.next_open_file = tmp_path / "p.json"
    window.tools.load_profile_action.trigger()
    assert window.state.project.segmentation == profile
    assert window.state.undo_stack.undoText() == "use segmentation settings p.json"
    asker.next_export_path = tmp_path / "again.json"
    window.tools.save_profile_action.trigger()
    assert read_settings(tmp_path / "again.json") == profile
    window.state.undo_stack.undo()
    assert window.state.project.segmentation == SegmentationSettings()
    assert asker.errors == []


def test_a_bad_profile_is_one_dialog_and_changes_nothing(window, asker, tmp_path):
    (tmp_path / "bad.json").write_text(json.dumps(
        {"format": "gaitstudio-segmentation", "version": 1, "propagation": {"lost_gapp": 1}}))
    asker.next_open_file = tmp_path / "bad.json"
    window.tools.load_profile_action.trigger()
    assert len(asker.errors) == 1 and "unknown setting 'lost_gapp'" in asker.errors[0]
    assert "\n" not in asker.errors[0]
    assert window.state.project.segmentation == SegmentationSettings()
    assert window.state.undo_stack.count() == 0
