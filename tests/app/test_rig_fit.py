"""Fitting the rig to the animal in the window: part scales, the fit job, undo, exports."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.io.bvh.reader import read_bvh
from gaitcore.rig.proportions import RigProportions, proportioned
from tests.app.posing_helpers import open_demo, true_poses
from tests.app.test_posing import export_from_app


def test_part_scales_reach_the_posed_rig_and_the_exported_bvh(qtbot, window, asker, canter_clip,
                                                             tmp_path):
    open_demo(qtbot, window, canter_clip)
    state, viewport = window.state, window.viewport
    template = state.skeleton
    viewport.part_scales["legs"].setValue(115)
    viewport.part_scales["neck"].setValue(85)
    assert state.project.proportions == RigProportions(legs=1.15, neck=0.85)
    rig = state.skeleton
    assert rig is proportioned(template, state.project.proportions)
    i = template.joint_index("L_carpus")
    assert np.linalg.norm(rig.offsets[i]) == pytest.approx(
        1.15 * np.linalg.norm(template.offsets[i]))
    truth = true_poses(template)
    for k in state.analysis.key_frames:
        state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")
    window.animator.recompute()
    bvh = export_from_app(qtbot, window, asker, tmp_path / "scaled.bvh", ".bvh")
    exported, _, _ = read_bvh(bvh)
    j = exported.joint_index("L_carpus")
    assert np.linalg.norm(exported.offsets[j]) == pytest.approx(
        np.linalg.norm(rig.offsets[i]), rel=1e-4)  # the export carries the proportions
    state.undo_stack.setIndex(0)  # every edit undone, the scales too
    assert state.project.proportions == RigProportions()
    assert state.skeleton is template
    assert viewport.part_scales["legs"].value() == 100


def test_fit_rig_sets_proportions_and_footage_in_one_undo_step(qtbot, window, canter_clip):
    open_demo(qtbot, window, canter_clip)
    state = window.state
    key = state.analysis.key_frames[1]
    state.set_frame(key)
    window.posing.set_pose(true_poses(state.skeleton)[key], "set pose")
    before, count = state.project, state.undo_stack.count()
    assert window.posing.fit_rig() is not None  # a background job
    qtbot.waitUntil(lambda: state.undo_stack.count() == count + 1, timeout=60_000)
    props = state.project.proportions
    for part in ("legs", "neck", "head", "tail"):  # the demo horse is the template itself
        assert props.scale_of(part) == pytest.approx(1.0, abs=0.05), part
    assert state.project.footage_fit != before.footage_fit
    assert window.viewport.part_scales["legs"].value() == pytest.approx(100 * props.legs, abs=0.5)
    state.undo_stack.undo()
    assert state.project == before


def test_a_new_rig_starts_from_its_own_proportions_and_turning_keeps_them(qtbot, window,
                                                                         canter_clip):
    open_demo(qtbot, window, canter_clip)
    state = window.state
    window.viewport.part_scales["legs"].setValue(120)
    window.posing.turn_rig("+Y", "-X")  # the same rig turned round keeps its fit
    assert state.project.proportions.legs == pytest.approx(1.2)
    rest = state.skeleton.joint_positions(state.skeleton.rest_pose())
    assert rest[state.skeleton.joint_index("head"), 0] < rest[0, 0]  # now facing -X
    assert window.posing.use_template()  # a new rig: the horse's own proportions
    assert state.project.proportions == RigProportions()
    state.undo_stack.undo()
    assert state.project.proportions.legs == pytest.approx(1.2)
