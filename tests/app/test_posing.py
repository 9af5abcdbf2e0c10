"""Posing keys in the window and exporting: the app writes what ``gaitcore animate`` writes."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from app.dialogs import ExportOptionsDialog
from app.export import export_fps
from gaitcore import cli
from gaitcore.io.analysis_file import write_analysis_json
from gaitcore.io.bvh.reader import read_bvh
from gaitcore.io.pose_table import PoseTable, read_pose_table, write_pose_table
from gaitcore.project.document import AnimationOptions
from gaitcore.project.steps import FootageSpeed
from tests.app.posing_helpers import open_demo, pose_keys_truly, pose_with_spin_boxes, true_poses

ARTIFACTS = Path(__file__).resolve().parents[1] / "_artifacts"


def run_gaitcore_animate(window, folder, *, extra=()):
    """Write analysis.json and keys.csv from the window's project with gaitcore's own
    functions and run ``gaitcore animate`` in-process; returns the curves file."""
    state = window.state
    analysis = state.analysis
    alternates = window.posing.alternates()
    if alternates:
        from dataclasses import replace

        analysis = replace(analysis, alternate_frames=alternates)
    write_analysis_json(folder / "analysis.json", analysis)
    frames = window.posing.frames()
    table = PoseTable(np.array(frames), state.skeleton.channel_names,
                      np.array([state.project.key_poses[f] for f in frames]))
    write_pose_table(folder / "keys.csv", table)
    out = folder / "cli.csv"
    state.skeleton.to_json(folder / "skeleton.json")  # for the ground contact clean-up
    args = ["animate", str(folder / "analysis.json"), "--key-poses", str(folder / "keys.csv"),
            "--out", str(out), "--csv-time", "--fps", repr(export_fps(state)),
            "--skeleton", str(folder / "skeleton.json"), *extra]
    assert cli.main(args) == 0
    return out


def export_from_app(qtbot, window, asker, path, suffix=".csv"):
    asker.next_export_path = path
    job = window.exporter.export(suffix)
    assert job is not None, asker.errors
    qtbot.waitUntil(lambda: not window.runner.busy, timeout=60_000)
    assert not asker.errors
    return path


def test_pose_every_key_with_spin_boxes_then_export_equals_gaitcore_animate(
        qtbot, window, asker, canter_clip, tmp_path):
    open_demo(qtbot, window, canter_clip)
    skeleton = window.state.skeleton
    truth = true_poses(skeleton)
    keys = window.state.analysis.key_frames
    for k in keys:
        typed = pose_with_spin_boxes(window, k, truth[k])
        np.testing.assert_allclose(typed, truth[k], atol=0.005 + 1e-9)
    assert window.posing.missing() == ()
    window.animator.recompute()
    assert window.animator.animation is not None

    app_csv = export_from_app(qtbot, window, asker, tmp_path / "app.csv")
    cli_csv = run_gaitcore_animate(window, tmp_path)
    ours, theirs = read_pose_table(app_csv), read_pose_table(cli_csv)
    assert ours.columns == theirs.columns == ("time_s",) + skeleton.channel_names
    np.testing.assert_array_equal(ours.frames, np.arange(100))
    np.testing.assert_array_equal(ours.values, theirs.values)  # exactly, not approximately
    assert app_csv.read_bytes() == cli_csv.read_bytes()
    # And the animation is sound: 4 keys give the canter's side-view angles within degrees.
    rz = skeleton.sagittal_angle_indices
    assert np.abs(ours.values[:, 1:][:, rz] - truth[:, rz]).mean() < 10.0

    for suffix in (".bvh", ".glb"):
        export_from_app(qtbot, window, asker, tmp_path / f"app{suffix}", suffix)
    read_skeleton, table, fps = read_bvh(tmp_path / "app.bvh")
    assert len(table.frames) == 100 and fps == pytest.approx(export_fps(window.state))
    assert (tmp_path / "app.glb").read_bytes()[:4] == b"glTF"


def test_filtered_and_clamped_options_match_the_command_line_too(qtbot, window, asker, canter_clip,
                                                                 tmp_path):
    open_demo(qtbot, window, canter_clip)
    pose_keys_truly(window)
    window.animation_view.filtered.setChecked(True)
    window.animation_view.clamp.setChecked(True)
    app_csv = export_from_app(qtbot, window, asker, tmp_path / "app.csv")
    cli_csv = run_gaitcore_animate(window, tmp_path, extra=("--filtered", "--clamp", "0,1"))
    assert app_csv.read_bytes() == cli_csv.read_bytes()
    weights = window.animator.animation.weights.weights
    assert weights.min() >= 0 and weights.max() <= 1

    window.animation_view.loop.setChecked(True)
    animation = window.animator.animation
    period = round(window.state.analysis.diagnosis.period_frames)
    assert animation.cycle.shape == (period, window.state.skeleton.n_channels)
    loop_csv = export_from_app(qtbot, window, asker, tmp_path / "loop.csv")
    loop = read_pose_table(loop_csv)
    assert len(loop.frames) == period + 1  # the closing frame, equal to the first
    np.testing.assert_array_equal(loop.values[-1, 1:], loop.values[0, 1:])

    # each option change is one undo step, and undo unticks its box
    window.state.undo_stack.undo()
    assert not window.animation_view.loop.isChecked() and window.animator.options.clamp
    window.animator.recompute()
    assert window.animator.animation.cycle is None


def test_spin_box_changes_of_one_joint_are_one_undo_step(qtbot, window, canter_clip):
    open_demo(qtbot, window, canter_clip)
    key = window.state.analysis.key_frames[0]
    stack = window.state.undo_stack
    before = stack.count()
    pose_with_spin_boxes(window, key, np.full(117, 10.0), ["R_elbow.rz"])
    for v in (12.0, 14.0, 16.5):
        window.pose_panel.spins["rz"].setValue(v)
    assert stack.count() == before + 1
    pose_with_spin_boxes(window, key, np.full(117, 5.0), ["R_stifle.rz"])
    assert stack.count() == before + 2
    skeleton = window.state.skeleton
    pose = window.state.project.key_poses[key]
    assert pose[skeleton.channel_index("R_elbow.rz")] == 16.5
    stack.undo()
    assert window.state.project.key_poses[key][skeleton.channel_index("R_stifle.rz")] == 0.0
    assert window.state.project.key_poses[key][skeleton.channel_index("R_elbow.rz")] == 16.5
    stack.undo()
    assert key not in window.state.project.key_poses
    window.pose_panel.select_joint("R_elbow")
    assert window.pose_panel.spins["rz"].value() == 0.0
    stack.redo()
    assert window.pose_panel.spins["rz"].value() == 16.5
    # Spin boxes are clamped to the joint limits of the rig.
    lo, hi = skeleton.limits_array()[skeleton.channel_index("R_elbow.rz")]
    window.pose_panel.spins["rz"].setValue(hi + 50)
    assert window.state.project.key_poses[key][skeleton.channel_index("R_elbow.rz")] == hi


def test_mirror_copy_paste_and_reset(qtbot, window, canter_clip):
    open_demo(qtbot, window, canter_clip)
    skeleton = window.state.skeleton
    k0, k1 = window.state.analysis.key_frames[:2]
    typed = pose_with_spin_boxes(window, k0, true_poses(skeleton)[k0])
    buttons = window.pose_panel.buttons
    buttons["mirror"].click()
    mirrored = np.array(window.state.project.key_poses[k0])
    np.testing.assert_array_equal(mirrored, skeleton.mirror_pose(typed))
    i, j = skeleton.channel_index("R_elbow.rz"), skeleton.channel_index("L_elbow.rz")
    assert mirrored[i] == typed[j] and mirrored[j] == typed[i]
    buttons["copy"].click()
    window.state.set_frame(k1)
    assert buttons["paste"].isEnabled()
    buttons["paste_mirrored"].click()
    np.testing.assert_array_equal(window.state.project.key_poses[k1], typed)
    window.state.set_selected_joint("R_elbow")
    buttons["reset_joint"].click()
    assert window.state.project.key_poses[k1][i] == 0.0
    buttons["reset_pose"].click()
    assert not any(window.state.project.key_poses[k1])
    for _ in range(3):
        window.state.undo_stack.undo()
    np.testing.assert_array_equal(window.state.project.key_poses[k0], mirrored)
    assert k1 not in window.state.project.key_poses


def test_walk_alternates_are_posed_as_mirrors_and_drive_switching(qtbot, window, asker, canter_clip,
                                                                  tmp_path):
    open_demo(qtbot, window, canter_clip, switching=True)
    keys, alts = window.state.analysis.key_frames, window.posing.alternates()
    assert len(alts) == len(keys) and window.posing.frames() == keys + alts
    truth = true_poses(window.state.skeleton)
    for k in keys:
        window.state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")
    assert window.posing.missing() == alts
    for a, k in zip(alts, keys):
        window.state.set_frame(a)
        assert window.pose_panel.buttons["mirror_key"].isEnabled()
        window.pose_panel.buttons["mirror_key"].click()
        np.testing.assert_array_equal(window.state.project.key_poses[a],
                                      window.state.skeleton.mirror_pose(truth[k]))
    window.animator.recompute()
    weights = window.animator.animation.weights
    assert weights.weights.shape == (100, 2 * len(keys)) and weights.states is not None
    app_csv = export_from_app(qtbot, window, asker, tmp_path / "app.csv")
    assert app_csv.read_bytes() == run_gaitcore_animate(window, tmp_path).read_bytes()


def test_export_options_are_asked_saved_and_undoable(qtbot, window, asker, canter_clip,
                                                       tmp_path):
    open_demo(qtbot, window, canter_clip)
    pose_keys_truly(window)
    chosen = replace(window.animator.options, root_motion="in-place", ground_contact=False,
                     bone_names="rigify")
    asker.export_answer = chosen
    export_from_app(qtbot, window, asker, tmp_path / "still.bvh", ".bvh")
    assert window.state.project.animation == chosen
    assert "Export BVH: options" in asker.asked
    text = (tmp_path / "still.bvh").read_text()
    assert "JOINT hip.L" in text
    _, table, _ = read_bvh(tmp_path / "still.bvh")
    tx = table.values[:, table.columns.index("root.tx")]
    assert np.all(tx == tx[0])
    window.state.undo_stack.undo()
    assert window.state.project.animation.root_motion == "auto"
    asker.export_answer = None  # cancelled: nothing asked after, nothing written
    assert window.exporter.export(".csv", tmp_path / "never.csv") is None
    assert not (tmp_path / "never.csv").exists()


def test_export_options_dialog_shows_and_returns_the_options(qtbot):
    options = AnimationOptions(loop=True, root_motion="forward", bone_names="rigify")
    dialog = ExportOptionsDialog(options, FootageSpeed(1.25, 1.9))
    qtbot.addWidget(dialog)
    dialog.show()
    qtbot.waitExposed(dialog)
    assert dialog.options() == options
    assert "1.25 m/s, a stride of 1.90 m" in dialog.speed_source.text()
    assert dialog.speed.text() == "from the footage"
    dialog.contact.setChecked(False)
    dialog.root.setCurrentIndex(1)
    dialog.speed.setValue(1.5)
    assert dialog.options() == replace(options, ground_contact=False, root_motion="in-place",
                                       root_speed_m_s=1.5)
    panning = ExportOptionsDialog(options)
    qtbot.addWidget(panning)
    assert "no travel" in panning.speed_source.text()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    dialog.grab().save(str(ARTIFACTS / "export_options.png"))


def test_exporting_before_every_key_is_posed_says_which_are_missing(qtbot, window, asker,
                                                                     canter_clip, tmp_path):
    open_demo(qtbot, window, canter_clip)
    keys = window.state.analysis.key_frames
    window.state.set_frame(keys[1])
    window.posing.set_pose(np.ones(window.state.skeleton.n_channels), "set pose")
    project = window.state.project
    asker.next_export_path = tmp_path / "early.csv"
    for suffix in (".csv", ".bvh", ".glb", ".mp4"):
        window.export_actions[suffix].trigger()
    missing = ", ".join(str(k) for k in keys if k != keys[1])
    assert len(asker.errors) == 4
    assert all(f"pose every key first (missing: frames {missing})" in e for e in asker.errors)
    assert not any(tmp_path.iterdir()) and window.state.project is project
    qtbot.waitUntil(lambda: not window.animator.pending)
    assert window.animator.animation is None
    assert f"missing: frames {missing}" in window.animation_view.status.text()


def test_export_a_preview_video_off_the_gui_thread(qtbot, window, asker, canter_clip, tmp_path,
                                                  artifacts_dir):
    open_demo(qtbot, window, canter_clip)
    pose_keys_truly(window)
    window.animation_view.loop.setChecked(True)  # one cycle: a shorter video
    asker.next_export_path = tmp_path / "preview.mp4"
    job = window.exporter.export(".mp4")
    with qtbot.waitSignal(job.finished, timeout=120_000):
        pass
    assert not asker.errors
    written = list(tmp_path.iterdir())
    assert len(written) == 1 and written[0].stat().st_size > 10_000
    assert "exported" in window.statusBar().currentMessage()
    import cv2

    video = cv2.VideoCapture(str(written[0]))
    assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == len(window.animator.animation.cycle)
    ok, frame = video.read()
    video.release()
    assert ok and frame.shape == (240, 320 + 320, 3)  # the footage at its size, the side view
    cv2.imwrite(str(artifacts_dir / "app_preview_video_frame.png"), frame)


def test_the_predicted_skeleton_follows_playback(qtbot, window, canter_clip):
    open_demo(qtbot, window, canter_clip)
    truth = true_poses(window.state.skeleton)
    keys = window.state.analysis.key_frames
    for k in keys:
        window.state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")
    qtbot.waitUntil(lambda: window.animator.animation is not None)
    curves = window.animator.animation.curves
    window.player.go_to(40)
    for _ in range(3):
        window.player.step(1)
        frame = window.state.frame
        assert window.viewport.shown_kind == "predicted"
        np.testing.assert_array_equal(window.viewport.shown_pose, curves[frame])
        assert window.animation_view.frame_line.value() == frame
    window.state.set_frame(keys[0])
    assert window.viewport.shown_kind == "key"
    np.testing.assert_array_equal(window.viewport.shown_pose, truth[keys[0]])
    window.player.toggle()
    qtbot.waitUntil(lambda: window.state.frame != keys[0], timeout=2000)
    window.player.stop()
