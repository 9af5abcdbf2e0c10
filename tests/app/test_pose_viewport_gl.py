"""The 3D viewport on a real GL context (xcb under Xvfb): drawing, picking, drag to rotate.

Skipped on the offscreen platform, which has no OpenGL (see conftest).
"""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtGui import QImage

from tests.app.posing_helpers import open_demo, true_poses

pytestmark = pytest.mark.gl
from app.widgets.skeleton_gl import BACKGROUND_RGB as BACKGROUND  # noqa: E402


def framebuffer(view) -> np.ndarray:
    """The GL view rendered now, as an (h, w, 3) RGB array."""
    image = view.render_image().convertToFormat(QImage.Format.Format_RGB888)
    w, h = image.width(), image.height()
    data = np.frombuffer(image.constBits(), np.uint8, count=image.bytesPerLine() * h)
    return data.reshape(h, image.bytesPerLine())[:, : 3 * w].reshape(h, w, 3).copy()


def pixel_at(view, rgb: np.ndarray, xy) -> np.ndarray:
    scale = rgb.shape[1] / view.width()  # device pixels per widget pixel
    return rgb[int(xy[1] * scale), int(xy[0] * scale)].astype(int)


@pytest.fixture
def posed_key(qtbot, window, canter_clip):
    """The demo on its second key, posed with the true pose, the footage loaded."""
    open_demo(qtbot, window, canter_clip)
    key = window.state.analysis.key_frames[1]
    window.state.set_frame(key)
    window.posing.set_pose(true_poses(window.state.skeleton)[key], "set pose")
    qtbot.waitExposed(window)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == key and window.viewport._ref is not None)
    return key


def test_the_skeleton_is_drawn_over_the_key_image(qtbot, window, posed_key, artifacts_dir):
    view = window.viewport.gl_view
    assert view is not None and view.isValid()
    qtbot.wait(100)
    with_footage = framebuffer(view)
    window.viewport.footage.setChecked(False)
    bare = framebuffer(view)
    window.viewport.footage.setChecked(True)
    window.snapshot().save(str(artifacts_dir / "app_pose_viewport_window.png"))
    view.render_image().save(str(artifacts_dir / "app_pose_viewport.png"))

    skeleton = window.state.skeleton
    screen = view.project(view.joint_positions())
    h, w = bare.shape[:2]
    assert np.all((screen[:, 0] > 0) & (screen[:, 0] < view.width()))  # all in view
    assert np.all((screen[:, 1] > 0) & (screen[:, 1] < view.height()))
    for name in ("spine2", "neck2", "R_stifle"):  # bones are drawn where the joints project
        on_bone = pixel_at(view, bare, screen[skeleton.joint_index(name)])
        assert np.abs(on_bone - BACKGROUND).sum() > 60, name
    changed = np.abs(with_footage.astype(int) - bare).sum(axis=2) > 30
    assert changed.mean() > 0.15  # the key-image shows behind the skeleton
    # ... and the skeleton stays in front of it.
    spine = screen[skeleton.joint_index("spine2")]
    np.testing.assert_array_equal(pixel_at(view, with_footage, spine), pixel_at(view, bare, spine))
    # The artist's fit reaches the plane: half again as big, same anchor.
    auto = window.viewport._ref.transform.copy()
    window.viewport.fit_scale.setValue(150)
    np.testing.assert_allclose(window.viewport._ref.transform[:2, :2], 1.5 * auto[:2, :2])
    assert np.abs(framebuffer(view).astype(int) - with_footage).sum(axis=2).max() > 30


def test_click_a_joint_to_select_it_and_drag_to_rotate_it(qtbot, window, posed_key):
    view = window.viewport.gl_view
    state, skeleton = window.state, window.state.skeleton
    qtbot.wait(50)
    for name in ("R_carpus", "head", "L_hock"):
        index = skeleton.joint_index(name)
        x, y = view.project(view.joint_positions())[index]
        # Nearest joint on screen (legs cross in a side view): pick whatever is the nearest.
        assert view.pick((x, y)) == index or np.linalg.norm(
            view.project(view.joint_positions())[view.pick((x, y))] - (x, y)) < 1.0
        qtbot.wait(300)  # no double clicks
        qtbot.mouseClick(view, Qt.MouseButton.LeftButton, pos=QPoint(round(x), round(y)))
        assert state.selected_joint == skeleton.joint_names[view.pick((x, y))]
        assert window.pose_panel.joints.currentItem().text(0) == state.selected_joint
    qtbot.wait(300)
    qtbot.mouseClick(view, Qt.MouseButton.LeftButton, pos=QPoint(5, 5))  # empty space: orbit
    assert state.selected_joint == "L_hock"

    name = "head"
    i = skeleton.channel_index(f"{name}.rz")
    x, y = view.project(view.joint_positions())[skeleton.joint_index(name)]
    before, count = state.project.key_poses[posed_key][i], state.undo_stack.count()
    qtbot.wait(300)
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(round(x), round(y)))
    assert state.selected_joint == name
    for dx, dy in ((20, 0), (20, -3), (20, -8)):  # counterclockwise on screen about the head
        qtbot.mouseMove(view, QPoint(round(x + dx), round(y + dy)))
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=QPoint(round(x + 20), round(y - 8)))
    after = state.project.key_poses[posed_key][i]
    turned = np.degrees(np.arctan2(8, 20))
    assert after - before == pytest.approx(turned, abs=1.0)  # side view: about Z, i.e. rz
    assert state.undo_stack.count() == count + 1  # one drag, one undo step
    state.undo_stack.undo()
    assert state.project.key_poses[posed_key][i] == before


def test_animation_preview_over_the_footage(qtbot, window, posed_key, artifacts_dir):
    truth = true_poses(window.state.skeleton)
    for k in window.state.analysis.key_frames:
        window.state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")
    qtbot.waitUntil(lambda: window.animator.animation is not None)
    window.state.set_frame(40)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == 40 and window.viewport._image[0] == 40)
    assert window.viewport.shown_kind == "predicted"
    qtbot.wait(100)
    window.snapshot().save(str(artifacts_dir / "app_animation_preview.png"))
    view = window.viewport.gl_view
    screen = view.project(view.joint_positions())
    assert np.all((screen > 0) & (screen < (view.width(), view.height())))


def test_view_presets_frame_the_whole_skeleton(qtbot, window, posed_key, artifacts_dir):
    view = window.viewport.gl_view
    for name, button in window.viewport.view_buttons.items():
        button.click()
        screen = view.project(view.joint_positions())
        assert np.all((screen > 0) & (screen < (view.width(), view.height()))), name
        view.render_image().save(str(artifacts_dir / f"app_pose_viewport_{name}.png"))
    window.viewport.view_buttons["side"].click()
