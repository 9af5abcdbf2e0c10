"""Importing a pose from a CSV row or a BVH frame, and changing the rig; bad files change
nothing."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.io.bvh.writer import write_bvh
from gaitcore.io.pose_table import PoseTable, write_pose_table
from tests.app.conftest import wait_jobs
from tests.app.posing_helpers import open_demo, true_poses

CHAIN_BVH = """HIERARCHY
ROOT hips
{
  OFFSET 0 1 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT shin
  {
    OFFSET 0 -0.5 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -0.5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 1 0 0 0 0 10 0 0
0 1 0 0 0 0 20 0 0
"""


@pytest.fixture
def posed_window(qtbot, window, canter_clip):
    """The demo with its first key posed (the pose to lose if an import went wrong)."""
    open_demo(qtbot, window, canter_clip)
    key = window.state.analysis.key_frames[0]
    window.state.set_frame(key)
    window.posing.set_pose(true_poses(window.state.skeleton)[key], "set pose")
    return window


def assert_nothing_changed(window, project, count):
    assert window.state.project is project
    assert window.state.undo_stack.count() == count


def test_import_a_pose_from_a_csv_row_and_a_bvh_frame(qtbot, posed_window, asker, tmp_path):
    window = posed_window
    skeleton = window.state.skeleton
    key2 = window.state.analysis.key_frames[1]
    wanted = true_poses(skeleton)[[key2, key2 + 1]]
    columns = ("time_s",) + skeleton.channel_names + ("tail5.rz",)
    values = np.column_stack([[0.1, 0.2], wanted, [1.0, 2.0]])
    write_pose_table(tmp_path / "p.csv", PoseTable(np.array([40, 41]), columns, values))
    window.state.set_frame(key2)
    asker.chosen_frame = 41  # frame key2 is not a row: the artist picks row 41
    assert window.posing.import_csv(tmp_path / "p.csv")
    wait_jobs(qtbot, window)
    np.testing.assert_array_equal(window.state.project.key_poses[key2], wanted[1])
    assert "ignored 1 channel(s)" in window.statusBar().currentMessage()
    assert "tail5" in window.statusBar().currentMessage()

    write_bvh(tmp_path / "horse.bvh", skeleton,
              PoseTable(np.arange(2), skeleton.channel_names, wanted))
    window.state.set_frame(window.state.analysis.key_frames[2])
    asker.chosen_frame = 0
    assert window.posing.import_bvh(tmp_path / "horse.bvh")
    wait_jobs(qtbot, window)
    np.testing.assert_allclose(window.state.project.key_poses[window.state.frame], wanted[0],
                               atol=1e-4)
    assert not asker.errors


BAD_FILES = {
    "unknown.csv": ("frame,hoof.rq,wing.rz\n0,1,2\n", "lacks 117 of the 117 channels"),
    "missing.csv": (None, "on joints R_elbow, L_hip"),
    "text.csv": ("frame,root.tx\n0,abc\n", "'abc' is not a number"),
    "broken.bvh": (CHAIN_BVH.replace("  }\n}\nMOTION", "MOTION"), "line"),
    "other_rig.bvh": (CHAIN_BVH, "on joints root, spine1, spine2"),
    "frames_nan.bvh": (CHAIN_BVH.replace("Frames: 2", "Frames: nan"), "'Frames:' must be"),
    "huge_cell.csv": ("frame,root.tx\n0," + "1" * 131_073 + "\n", "field larger than"),
    "deep.bvh": ("HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n"
                 + "JOINT j\n{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\n" * 1500 + "}\n" * 1501
                 + "MOTION\nFrames: 1\nFrame Time: 0.04\n" + "0 " * 1501 + "\n",
                 "lacks 117 of the 117 channels"),
}


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_a_bad_pose_file_gives_a_message_and_changes_nothing(qtbot, posed_window, asker, tmp_path,
                                                            name):
    window = posed_window
    text, message = BAD_FILES[name]
    path = tmp_path / name
    if text is None:  # every channel but those of two joints
        skeleton = window.state.skeleton
        keep = [c for c in skeleton.channel_names if not c.startswith(("R_elbow.", "L_hip."))]
        write_pose_table(path, PoseTable(np.array([0]), tuple(keep), np.zeros((1, len(keep)))))
    else:
        path.write_text(text)
    project, count = window.state.project, window.state.undo_stack.count()
    asker.chosen_frame = 0
    window.posing.import_bvh(path) if name.endswith(".bvh") else window.posing.import_csv(path)
    wait_jobs(qtbot, window)
    assert len(asker.errors) == 1 and message in asker.errors[0], asker.errors
    assert name in asker.errors[0]
    assert_nothing_changed(window, project, count)


def test_importing_away_from_a_key_only_says_where_to_go(posed_window, asker, tmp_path):
    window = posed_window
    frame = next(f for f in range(100) if f not in window.posing.frames())
    window.state.set_frame(frame)
    project, count = window.state.project, window.state.undo_stack.count()
    assert not window.posing.import_csv(tmp_path / "never_read.csv")
    assert "is not a key-image" in window.statusBar().currentMessage()
    assert not asker.errors
    assert_nothing_changed(window, project, count)


def test_load_a_rig_from_bvh_asks_before_dropping_poses(qtbot, posed_window, asker, tmp_path):
    window = posed_window
    (tmp_path / "chain.bvh").write_text(CHAIN_BVH)
    project, count = window.state.project, window.state.undo_stack.count()
    asker.confirm_answer = False
    assert window.posing.load_rig(tmp_path / "chain.bvh")
    wait_jobs(qtbot, window)
    assert "1 pose(s) made so far will be dropped" in asker.asked[-1]
    assert_nothing_changed(window, project, count)

    asker.confirm_answer = True
    assert window.posing.load_rig(tmp_path / "chain.bvh")
    wait_jobs(qtbot, window)
    assert window.state.skeleton.name == "chain" and window.state.project.key_poses == {}
    assert window.posing.missing() == window.posing.frames()
    window.pose_panel.select_joint("shin")
    assert window.state.selected_joint == "shin"
    window.state.undo_stack.undo()
    assert window.state.project is project and window.state.skeleton.name == "horse"

    (tmp_path / "broken.bvh").write_text("HIERARCHY\nROOT a\n{\n OFFSET 0 0\n")
    window.posing.load_rig(tmp_path / "broken.bvh")
    wait_jobs(qtbot, window)
    assert "broken.bvh" in asker.errors[-1]
    assert window.state.project is project


def test_a_rig_with_the_same_channels_keeps_the_poses(qtbot, posed_window, asker, tmp_path):
    window = posed_window
    skeleton = window.state.skeleton
    write_bvh(tmp_path / "horse.bvh", skeleton,
              PoseTable(np.arange(1), skeleton.channel_names, np.zeros((1, skeleton.n_channels))))
    poses = dict(window.state.project.key_poses)
    asker.confirm_answer = False  # must not even be asked
    assert window.posing.load_rig(tmp_path / "horse.bvh")
    wait_jobs(qtbot, window)
    assert window.state.skeleton.name == "horse" and window.state.project.skeleton is not None
    assert window.state.project.key_poses.keys() == poses.keys()
    assert not asker.asked
    skeleton_bvh = window.state.skeleton
    key = window.state.analysis.key_frames[0]
    for name in skeleton.channel_names:  # the BVH lists joints in another order
        assert (window.state.project.key_poses[key][skeleton_bvh.channel_index(name)]
                == poses[key][skeleton.channel_index(name)])


def test_a_table_of_several_rows_always_asks_which_one(qtbot, posed_window, asker, tmp_path):
    """Even with a row numbered like the current frame: its numbers need not be the clip's."""
    window = posed_window
    skeleton = window.state.skeleton
    key = window.state.analysis.key_frames[1]
    wanted = true_poses(skeleton)[[key, key + 5]]
    write_pose_table(tmp_path / "p.csv", PoseTable(np.array([key, key + 5]),
                                                   skeleton.channel_names, wanted))
    window.state.set_frame(key)
    asker.chosen_frame = key + 5  # the artist means the other row
    assert window.posing.import_csv(tmp_path / "p.csv")  # read as a job
    wait_jobs(qtbot, window)
    assert f"poses frame {key}" in asker.asked[-1] and asker.suggested == key
    np.testing.assert_array_equal(window.state.project.key_poses[key], wanted[1])
    asker.chosen_frame = None  # cancelled: nothing changes
    project = window.state.project
    window.posing.import_csv(tmp_path / "p.csv")
    wait_jobs(qtbot, window)
    assert window.state.project is project
