"""Helpers of the posing tests: open the demo and pose keys through the panel's spin boxes."""

from __future__ import annotations

import numpy as np

from tests.app.conftest import wait_ready


def open_demo(qtbot, window, clip, *, switching: bool = False) -> None:
    """Show the demo canter (footage, silhouettes, analysis) in ``window``."""
    from app.demo import demo_project

    window.documents.open_demo(demo_project(clip))
    wait_ready(qtbot, window)
    if switching:
        window.pc_plot.switching.setChecked(True)
        qtbot.waitUntil(lambda: window.state.analysis is not None
                        and window.state.analysis.alternate_frames is not None, timeout=20_000)
        window.pc_plot.accept_alt.click()
        wait_ready(qtbot, window)
    window.activateWindow()


def true_poses(skeleton, n_frames: int = 100) -> np.ndarray:
    """The poses the demo clip was rendered with."""
    from app.demo import DEMO_GAIT
    from gaitcore.bench import generate_gait

    return generate_gait(skeleton, DEMO_GAIT, n_frames)


def pose_keys_truly(window) -> None:
    """Give every key-image the pose the demo clip was rendered with (one undo step each)."""
    truth = true_poses(window.state.skeleton)
    for k in window.state.analysis.key_frames:
        window.state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")


def pose_with_spin_boxes(window, frame: int, pose: np.ndarray, channels=None) -> np.ndarray:
    """Go to ``frame`` and type ``pose`` (every channel, or ``channels``) into the panel.

    Returns the values the spin boxes hold (rounded to their decimals, clamped to limits).
    """
    state, panel = window.state, window.pose_panel
    state.set_frame(frame)
    skeleton = state.skeleton
    names = skeleton.channel_names if channels is None else channels
    for name in names:
        joint, channel = name.rsplit(".", 1)
        panel.select_joint(joint)
        assert state.selected_joint == joint
        box = panel.spins[channel]
        assert box.isEnabled() and box.isVisibleTo(panel)
        box.setValue(float(pose[skeleton.channel_index(name)]))
    return np.array(state.project.key_poses[frame])
