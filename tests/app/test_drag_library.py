"""End drags in the app fold the chain as the gait library and the other keys do."""

from __future__ import annotations

import numpy as np

from gaitcore.project.steps import drag_library
from gaitcore.rig.posing import drag_end
from tests.app.posing_helpers import open_demo, true_poses


def _drag(window, joint: int, base: np.ndarray, targets) -> None:
    """What the viewport does for one drag: press, a few moves, release."""
    window.posing.begin_drag()
    for target in targets:
        window.posing.drag_end(joint, base, target)


def test_a_hoof_drag_folds_the_leg_as_the_library_in_one_undo_step(qtbot, window, canter_clip):
    open_demo(qtbot, window, canter_clip)
    state = window.state
    skeleton = state.skeleton
    keys = state.analysis.key_frames
    truth = true_poses(skeleton)
    window.state.set_frame(keys[0])
    window.posing.set_pose(truth[keys[0]], "set pose")  # another key, posed: it joins the library
    key = keys[1]
    state.set_frame(key)
    toe = skeleton.joint_index("L_hind_toe")
    base = skeleton.rest_pose()
    base[:3] = truth[key][:3]  # the root where the footage puts it
    goal = skeleton.joint_positions(truth[key])[toe]
    start = skeleton.joint_positions(base)[toe]
    targets = [start + f * (goal - start) * [1, 1, 0] for f in (0.3, 0.7, 1.0)]
    count = state.undo_stack.count()

    assert window.library_action.isChecked()
    _drag(window, toe, base, targets)
    assert state.undo_stack.count() == count + 1  # one drag, one undo step
    library = drag_library(state.project, skeleton, key)
    assert "1 other key" in library.source
    folded = np.array(state.project.key_poses[key])
    np.testing.assert_allclose(folded, drag_end(skeleton, base, toe, targets[-1], library=library))
    assert np.linalg.norm(skeleton.joint_positions(folded)[toe] - targets[-1]) < 1e-3

    window.library_action.setChecked(False)  # Pose > Drags fold ... as the gait library
    _drag(window, toe, base, targets)
    assert state.undo_stack.count() == count + 2
    plain = np.array(state.project.key_poses[key])
    np.testing.assert_allclose(plain, drag_end(skeleton, base, toe, targets[-1]))
    idx = skeleton.sagittal_angle_indices
    leg = [i for i in idx if skeleton.channel_names[i].startswith("L_") and "hip" not in
           skeleton.channel_names[i] and skeleton.channel_names[i][2:6] != "scap"]
    assert np.abs(plain[leg] - folded[leg]).max() > 5  # the library folds the leg otherwise

    state.undo_stack.undo()
    np.testing.assert_allclose(state.project.key_poses[key], folded)
    state.undo_stack.undo()
    assert key not in state.project.key_poses
