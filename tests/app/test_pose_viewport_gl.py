"""The 3D viewport on a real GL context (xcb under Xvfb): drawing, picking, drag to rotate.

Skipped on the offscreen platform, which has no OpenGL (see conftest).
"""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtGui import QImage

from tests.app.conftest import wait_jobs
from tests.app.posing_helpers import open_demo, pose_keys_truly, true_poses

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
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == key
                    and window.viewport._ref is not None)
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
    pose_keys_truly(window)
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


def _widget_pos(view, name: str) -> np.ndarray:
    skeleton = view._skeleton
    return view.project(view.joint_positions())[skeleton.joint_index(name)]


def test_hovering_highlights_and_names_the_joint(qtbot, window, posed_key):
    view, viewport = window.viewport.gl_view, window.viewport
    qtbot.wait(50)
    for name in ("head", "R_elbow", "L_hind_toe"):
        x, y = _widget_pos(view, name)
        qtbot.mouseMove(view, QPoint(round(x), round(y)))
        qtbot.waitUntil(lambda: view.hovered >= 0)
        shown = view._skeleton.joint_names[view.hovered]  # legs cross: the nearest one
        assert np.linalg.norm(_widget_pos(view, shown) - (x, y)) < 1.5
        assert shown in viewport.hover.text()
        side = {"L": "left", "R": "right", "C": "centre"}[view._skeleton.joints[view.hovered].side]
        assert side in viewport.hover.text()
    assert window.state.selected_joint == ""  # named before any click, nothing selected
    qtbot.mouseMove(view, QPoint(3, 3))
    qtbot.waitUntil(lambda: view.hovered == -1)
    assert viewport.hover.text() == ""


def test_drag_a_hoof_moves_the_leg_by_ik_in_one_undo_step(qtbot, window, posed_key, artifacts_dir):
    from gaitcore.project.steps import drag_library
    from gaitcore.rig.posing import drag_end

    view, state = window.viewport.gl_view, window.state
    skeleton = state.skeleton
    qtbot.wait(50)
    x, y = _widget_pos(view, "L_fore_toe")
    end = view.pick((x, y))
    name = skeleton.joint_names[end]
    assert name.endswith("fore_toe")  # either fore toe: they may overlap on screen
    before, count = np.array(state.project.key_poses[posed_key]), state.undo_stack.count()
    qtbot.wait(300)
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(round(x), round(y)))
    path = [(8, -6), (20, -15), (30, -25)]  # forward and up, as a leg folds in swing
    for dx, dy in path:
        qtbot.mouseMove(view, QPoint(round(x + dx), round(y + dy)))
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=QPoint(round(x + 30), round(y - 25)))
    after = np.array(state.project.key_poses[posed_key])
    assert state.undo_stack.count() == count + 1  # one drag, one undo step
    moved = skeleton.joint_positions(after)[end] - skeleton.joint_positions(before)[end]
    assert moved[0] > 0.05 and moved[1] > 0.05  # forward and up, metres
    assert abs(moved[2]) < 0.02  # in the view's plane
    np.testing.assert_allclose(_widget_pos(view, name), (x + 30, y - 25), atol=3.0)
    changed = {c.rsplit(".", 1)[0] for c, a, b in zip(skeleton.channel_names, after, before)
               if abs(a - b) > 1e-6}
    assert changed and all(j.startswith(name[:2]) for j in changed)  # that leg only
    view.render_image().save(str(artifacts_dir / "app_drag_hoof_gait_library.png"))
    reached = skeleton.joint_positions(after)[end]  # the drag folded the leg as the library
    library = drag_library(state.project, skeleton, posed_key)
    np.testing.assert_allclose(after, drag_end(skeleton, before, end, reached, library=library),
                               atol=0.5)
    limits = skeleton.limits_array()
    assert np.all((after >= limits[:, 0] - 1e-9) & (after <= limits[:, 1] + 1e-9))
    state.undo_stack.undo()
    np.testing.assert_array_equal(state.project.key_poses[posed_key], before)


def _wheel(view, xy, delta: int) -> None:
    from PySide6.QtCore import QPointF
    from PySide6.QtGui import QWheelEvent
    from PySide6.QtWidgets import QApplication

    pos = QPointF(*xy)
    event = QWheelEvent(pos, view.mapToGlobal(pos), QPoint(0, 0), QPoint(0, delta),
                        Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier,
                        Qt.ScrollPhase.NoScrollPhase, False)
    QApplication.sendEvent(view, event)


def test_wheel_zooms_to_the_cursor_and_f_frames_the_rig(qtbot, window, posed_key, artifacts_dir):
    view = window.viewport.gl_view
    qtbot.wait(50)
    head = _widget_pos(view, "head")
    distance = view.opts["distance"]
    _wheel(view, head, 600)  # zoom in a lot, on the head
    assert view.opts["distance"] < 0.6 * distance
    np.testing.assert_allclose(_widget_pos(view, "head"), head, atol=4.0)  # stays put
    screen = view.project(view.joint_positions())
    assert not np.all((screen > 0) & (screen < (view.width(), view.height())))  # cut off
    view.requestActivate()
    qtbot.keyClick(view, Qt.Key.Key_F)
    screen = view.project(view.joint_positions())
    size = np.array([view.width(), view.height()])
    assert np.all((screen > 0) & (screen < size))  # all of it in view ...
    assert (np.ptp(screen, axis=0) / size).max() > 0.7  # ... and filling it
    view.render_image().save(str(artifacts_dir / "app_pose_viewport_framed.png"))


def test_footage_shows_through_bones_left_and_right_in_their_colours(qtbot, window, posed_key,
                                                                     artifacts_dir):
    from app.widgets.sides import SIDE_RGB

    view, viewport, skeleton = window.viewport.gl_view, window.viewport, window.state.skeleton
    qtbot.wait(100)
    # inside the trunk, away from the stick figure's lines and dots
    a, b = _widget_pos(view, "spine1"), _widget_pos(view, "spine2")
    inside = (a + b) / 2 + (0, 10)

    def trunk(footage: bool, opacity: int) -> np.ndarray:
        viewport.footage.setChecked(footage)
        viewport.bones.setValue(opacity)
        return pixel_at(view, framebuffer(view), inside)

    assert np.abs(trunk(True, 35) - trunk(False, 35)).sum() > 40  # seen through the bones
    np.testing.assert_array_equal(trunk(True, 100), trunk(False, 100))  # solid hides it
    viewport.bones.setValue(35)
    viewport.footage.setChecked(True)
    rgb = framebuffer(view)
    view.render_image().save(str(artifacts_dir / "app_pose_viewport_sides.png"))
    window.snapshot().save(str(artifacts_dir / "app_pose_viewport_sides_window.png"))
    screen = view.project(view.joint_positions())
    matches = {"L": 0, "R": 0}
    for j, joint in enumerate(skeleton.joints):
        if joint.side in matches:
            got = pixel_at(view, rgb, screen[j])
            matches[joint.side] += np.abs(got - SIDE_RGB[joint.side]).sum() < 60
    assert min(matches.values()) >= 5, matches  # the joints not hidden by the other leg
    tree = window.pose_panel.joints
    item = tree.findItems("L_elbow", Qt.MatchFlag.MatchExactly | Qt.MatchFlag.MatchRecursive)[0]
    assert item.foreground(0).color().getRgb()[:3] == SIDE_RGB["L"]


def test_a_z_up_centimetre_quadruped_loads_standing_in_view_at_the_footage_scale(
        qtbot, window, posed_key, asker, tmp_path, artifacts_dir):
    from gaitcore.project.footage_fit import skeleton_extent
    from gaitcore.rig.skeleton import Skeleton
    from tests.gaitcore.test_orient import written_as

    doc = window.state.skeleton.to_dict()  # a dog-sized quadruped
    for joint in doc["joints"]:
        joint["offset"] = [0.45 * v for v in joint["offset"]]
    dog = Skeleton.from_json(dict(doc, name="dog"))
    written_as(dog, tmp_path / "dog.bvh", up="+Z", forward="-Y", unit_m=0.01,
               root_at=(470.0, 20.0, 0.0))  # 4.7 m to the side, as a real file had it
    assert window.posing.load_rig(tmp_path / "dog.bvh")  # read as a job
    wait_jobs(qtbot, window)
    assert "centimetres" in window.statusBar().currentMessage()
    state, view, viewport = window.state, window.viewport.gl_view, window.viewport
    rig = state.skeleton
    rest = rig.joint_positions(rig.rest_pose())
    assert rest[:, 1].min() == pytest.approx(0.0, abs=1e-6)  # on the ground ...
    assert np.ptp(rest[:, 1]) == pytest.approx(0.45 * 1.9, rel=0.1)  # ... in metres, upright
    head, root = rest[rig.joint_index("head")], rest[0]
    assert head[0] > root[0] and abs(root[2]) < 1e-9  # facing +X, not off to the side
    qtbot.waitUntil(lambda: viewport._ref is not None and viewport._skeleton is rig)
    qtbot.wait(100)
    screen = view.project(view.joint_positions())
    assert np.all((screen > 0) & (screen < (view.width(), view.height())))  # framed
    outline = np.concatenate(viewport._outline_world)  # the animal in the footage ...
    extent = skeleton_extent(rig)
    assert np.ptp(outline[:, 1]) == pytest.approx(extent.height_m, rel=0.15)  # ... at its size
    view.render_image().save(str(artifacts_dir / "app_pose_viewport_dog_rig.png"))


def test_onion_skin_shows_the_neighbouring_keys_on_the_same_root(qtbot, window, posed_key,
                                                                 artifacts_dir):
    state, view, viewport = window.state, window.viewport.gl_view, window.viewport
    truth = true_poses(state.skeleton)
    keys = state.analysis.key_frames
    for k in keys:
        state.set_frame(k)
        window.posing.set_pose(truth[k], "set pose")
    state.set_frame(posed_key)
    qtbot.waitUntil(lambda: window.frame_view.shown_frame == posed_key)
    qtbot.wait(150)
    shown = [item for item in view.onion if item.visible()]
    assert len(shown) == 2  # the key before and the key after
    root_x = view.joint_positions()[0, 0]
    for item in shown:
        pos = item.pos.reshape(-1, 2, 3)
        first_child = pos[0]  # pairs start with (root, its first child)
        assert first_child[0, 0] == pytest.approx(root_x)
    view.render_image().save(str(artifacts_dir / "app_pose_viewport_onion.png"))
    viewport.onion.setChecked(False)
    assert not any(item.visible() for item in view.onion)
