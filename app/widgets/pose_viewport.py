"""The 3D pose viewport: the skeleton over the current frame, to pose keys and watch the result.

On a frame to pose (a key-image or an accepted alternate) it shows that frame's pose; the
joint under the cursor is highlighted and named before any click, clicking a joint selects
it, dragging an end (a toe, the head's end, the tail's tip) moves it in the view's plane with
IK setting the joints above it, dragging any other joint rotates it about the view axis (one
undo step per drag). The bones are see-through (an opacity, 0 for the stick figure alone) and
coloured by side; the silhouette's outline and an onion skin of the neighbouring keys can be
drawn over the footage. F (or Frame) frames the rig, the wheel zooms towards the cursor. On
any other frame it shows the animation predicted for that frame, so playback
moves the skeleton in step with the footage, which is drawn on a plane behind it, placed
automatically and corrected by the artist (size, shift, mirror: the project's footage fit, each
change one undo step). Side, front and top buttons reset the camera; orbit, pan and zoom are
pyqtgraph's.

Without OpenGL (Qt's offscreen platform) the viewport says so and everything else works: the
posing panel needs no GL.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QKeySequence, QShortcut
from PySide6.QtWidgets import (
    QCheckBox,
    QDoubleSpinBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QMenu,
    QSpinBox,
    QToolButton,
    QVBoxLayout,
    QWidget,
    QWidgetAction,
)

from app.animation import AnimationController
from app.commands import FootageFitCommand
from app.posing import PosingController
from app.state import AppState
from app.widgets.follow import show_value
from app.widgets.sides import SIDE_RGB, SIDE_WORDS
from app.widgets.skeleton_gl import DEFAULT_BONE_OPACITY, SkeletonGLView, opengl_available
from app.workers import FrameLoader
from gaitcore.project.document import FootageFit, Silhouettes
from gaitcore.project.footage_fit import (
    SkeletonExtent,
    reference_image,
    silhouette_heights_px,
    silhouette_outline_px,
    skeleton_extent,
)
from gaitcore.rig.proportions import PARTS, SCALE_RANGE
from gaitcore.rig.skeleton import Skeleton

VIEW_MARGIN = 1.35
OUTLINE_LIFT_M = 0.01
"""The silhouette's outline is drawn this far in front of the footage plane."""
FOOTAGE_WAIT_MS = 100
"""How long a new pose waits for its footage frame, so that both are drawn in one repaint."""

SCRUB_SETTLE_MS = 60
"""Outside playback, the 3D view follows a new frame once no newer one has come for this
long: while the artist scrubs, the software-rendered 3D view (about 20 ms a frame on two
cores) would otherwise hold up every frame of the footage, PC plot and timeline."""


class PoseViewport(QWidget):
    """3D view of the skeleton bound to the state, the posing and the animation."""

    def __init__(self, state: AppState, loader: FrameLoader, posing: PosingController,
                 animation: AnimationController, parent: QWidget | None = None, *,
                 is_playing: Callable[[], bool] = lambda: False) -> None:
        super().__init__(parent)
        self._state = state
        self._posing = posing
        self._animation = animation
        self._skeleton: Skeleton | None = None
        self._template: Skeleton | None = None
        self._extent: SkeletonExtent | None = None
        self._sil: tuple[Silhouettes | None, float | None] = (None, None)
        self._image: tuple[int, np.ndarray] | None = None
        self._base_pose: np.ndarray | None = None
        self.shown_kind = ""
        self._view_name = "side"
        self._rest_root_x = 0.0
        self._dx = 0.0
        self._ref = None
        self._outline_world: list[np.ndarray] = []
        self._fallback = QTimer(self, singleShot=True, interval=FOOTAGE_WAIT_MS)
        self._fallback.timeout.connect(self._draw_pose)
        # Latest frame wins: frames arriving before the timer fires replace each other.
        self._frame_timer = QTimer(self, singleShot=True)
        self._frame_timer.timeout.connect(self._apply_frame)
        self.is_playing = is_playing
        self.shown_pose: np.ndarray | None = None

        self.info = QLabel()
        self.info.setWordWrap(True)
        self.setMinimumSize(260, 200)
        self.hover = QLabel()
        self.hover.setToolTip("The joint under the cursor: left joints blue, right joints red")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(self._camera_bar())
        layout.addLayout(self._shown_bar())
        layout.addLayout(self._fit_bar())
        self.gl_view: SkeletonGLView | None = None
        self.gl_container: QWidget | None = None
        layout.addWidget(self._gl_or_note(), 1)
        layout.addWidget(self.hover)
        layout.addWidget(self.info)

        self._connect(state, loader, animation)
        self._fit = FootageFit()
        self._show_fit()
        self.refresh()

    # -- camera ------------------------------------------------------------------------------
    def set_view(self, name: str) -> None:
        """Look from the side, front or top at the whole skeleton."""
        if self.gl_view is not None and self._extent is not None:
            e = self._extent
            width = e.length_m if name in ("side", "top") else 2 * e.depth_m
            height = 2 * e.depth_m if name == "top" else e.height_m
            along = {"side": 2 * e.depth_m, "top": e.height_m}.get(name, e.length_m)
            self._view_name = name
            self.gl_view.set_view(name, e.box_center_xy,
                                  (width * VIEW_MARGIN, height * VIEW_MARGIN, along))

    # -- construction ------------------------------------------------------------------------
    def _camera_bar(self) -> QHBoxLayout:
        """Side, front, top, Frame; the rig's proportions and their fit."""
        bar = QHBoxLayout()
        self.view_buttons = {}
        for name in ("side", "front", "top"):
            button = QToolButton()
            button.setText(name.capitalize())
            button.setToolTip(f"Look at the skeleton from the {name}")
            button.clicked.connect(lambda _c=False, n=name: self.set_view(n))
            bar.addWidget(button)
            self.view_buttons[name] = button
        self.frame_button = QToolButton()
        self.frame_button.setText("Frame")
        self.frame_button.setToolTip("Frame the whole rig (F)")
        self.proportions = QToolButton()
        self.proportions.setText("Proportions")
        self.proportions.setToolTip("Length of each part of the rig relative to the template")
        self.proportions.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        self.part_scales = self._proportions_menu()
        self.fit_rig = QToolButton()
        self.fit_rig.setText("Fit rig")
        self.fit_rig.setToolTip("Fit the rig's proportions and the footage to this key's "
                                "silhouette (body length, withers, legs, neck, head, tail)")
        self.fit_rig.clicked.connect(self._posing.fit_rig)
        for widget in (self.frame_button, self.proportions, self.fit_rig):
            bar.addWidget(widget)
        bar.addStretch(1)
        return bar

    def _shown_bar(self) -> QHBoxLayout:
        """What is drawn: footage (mirrored or not), outline, onion skin, bone opacity."""
        self.footage = QCheckBox("Footage")
        self.footage.setChecked(True)
        self.flip = QCheckBox("Flip")
        self.flip.setToolTip("Mirror the footage left-right (animal moving to the left)")
        self.outline = QCheckBox("Outline")
        self.outline.setChecked(True)
        self.outline.setToolTip("The silhouette's outline over the footage")
        self.onion = QCheckBox("Onion")
        self.onion.setChecked(True)
        self.onion.setToolTip("The previous and next posed keys, faint (purple before, amber "
                              "after)")
        self.bones = QSpinBox()
        self.bones.setRange(0, 100)
        self.bones.setSingleStep(10)
        self.bones.setValue(round(100 * DEFAULT_BONE_OPACITY))
        self.bones.setSuffix(" %")
        self.bones.setPrefix("bones ")
        self.bones.setToolTip("Opacity of the bones: lower sees the footage through them, "
                              "0 shows the stick figure only")
        bar = QHBoxLayout()
        for widget in (self.footage, self.flip, self.outline, self.onion, self.bones):
            bar.addWidget(widget)
        bar.addStretch(1)
        return bar

    def _fit_bar(self) -> QHBoxLayout:
        """The footage's size and shift relative to the automatic placement."""
        self.fit_scale = _spin("Footage size relative to the automatic fit", " %", 20, 500, 5)
        self.fit_x = _spin("Shift the footage along the direction of travel", " cm", -300, 300, 1,
                           prefix="x ")
        self.fit_y = _spin("Shift the footage up", " cm", -300, 300, 1, prefix="y ")
        self.fit_auto = QToolButton()
        self.fit_auto.setText("Auto")
        self.fit_auto.setToolTip("Back to the automatic fit (silhouette height and centre)")
        bar = QHBoxLayout()
        bar.addWidget(QLabel("Fit"))
        for widget in (self.fit_scale, self.fit_x, self.fit_y, self.fit_auto):
            bar.addWidget(widget)
        bar.addStretch(1)
        return bar

    def _gl_or_note(self) -> QWidget:
        """The GL view in its window container, or a note where OpenGL is missing."""
        if not opengl_available():
            note = QLabel("The 3D viewport needs OpenGL, which this display does not offer.\n"
                          "Pose with the Posing panel; everything else works.")
            note.setAlignment(Qt.AlignmentFlag.AlignCenter)
            note.setWordWrap(True)
            return note
        self.gl_view = SkeletonGLView()
        self.gl_container = QWidget.createWindowContainer(self.gl_view, self)
        self.gl_container.setFocusPolicy(Qt.FocusPolicy.ClickFocus)
        self.gl_view.jointPressed.connect(self._on_joint_pressed)
        self.gl_view.jointDragged.connect(self._on_joint_dragged)
        self.gl_view.endDragged.connect(self._on_end_dragged)
        self.gl_view.jointHovered.connect(self._show_hovered)
        self.gl_view.frameRequested.connect(self.frame_rig)
        return self.gl_container

    def _connect(self, state: AppState, loader: FrameLoader,
                 animation: AnimationController) -> None:
        """The state, the loader and the controls drive the view."""
        loader.frameLoaded.connect(self._on_frame_loaded)
        state.frameChanged.connect(self.refresh)
        state.projectChanged.connect(self.refresh)
        state.projectChanged.connect(self._show_fit)
        state.analysisChanged.connect(self.refresh)
        state.sourceChanged.connect(self._forget_image)
        state.selectedJointChanged.connect(self._show_selected)
        animation.animationChanged.connect(self.refresh)
        self.footage.toggled.connect(self._update_reference)
        self.frame_button.clicked.connect(self.frame_rig)
        shortcut = QShortcut(QKeySequence("F"), self)
        shortcut.setContext(Qt.ShortcutContext.WidgetWithChildrenShortcut)
        shortcut.activated.connect(self.frame_rig)
        self.bones.valueChanged.connect(self._set_opacity)
        self.outline.toggled.connect(self._update_reference)
        self.onion.toggled.connect(lambda _on: self._draw_pose())
        self.flip.toggled.connect(lambda on: self._edit_fit("flip", flip=on))
        self.fit_scale.valueChanged.connect(lambda v: self._edit_fit("scale", scale=v / 100))
        self.fit_x.valueChanged.connect(lambda v: self._edit_fit("shift", offset_x_m=v / 100))
        self.fit_y.valueChanged.connect(lambda v: self._edit_fit("shift", offset_y_m=v / 100))
        self.fit_auto.clicked.connect(self._auto_fit)

    def _proportions_menu(self) -> dict[str, QDoubleSpinBox]:
        """The popup of the Proportions button: one spin box per part of the rig."""
        menu = QMenu(self.proportions)
        panel = QWidget()
        form = QFormLayout(panel)
        boxes = {}
        for part in PARTS:
            box = _spin(f"Length of the rig's {part} relative to the template", " %",
                        100 * SCALE_RANGE[0], 100 * SCALE_RANGE[1], 1)
            box.valueChanged.connect(lambda v, p=part: self._posing.set_proportion(p, v / 100))
            form.addRow(part, box)
            boxes[part] = box
        action = QWidgetAction(menu)
        action.setDefaultWidget(panel)
        menu.addAction(action)
        self.proportions.setMenu(menu)
        return boxes

    def frame_rig(self) -> None:
        """Aim at the rig as shown and fill the view with it (F, as in Blender and Maya)."""
        if self.gl_view is not None:
            self.gl_view.frame()

    def _set_opacity(self, percent: int) -> None:
        if self.gl_view is not None:
            self.gl_view.set_bone_opacity(percent / 100)

    # -- state -> view -----------------------------------------------------------------------
    def refresh(self, *_changed) -> None:
        """Show the pose of the current frame (key pose, prediction or rest) and the footage."""
        skeleton = self._state.skeleton
        if skeleton is not self._skeleton:
            new_rig = self._template is not self._state.template_skeleton  # not a new proportion
            self._skeleton, self._template = skeleton, self._state.template_skeleton
            self._extent = skeleton_extent(skeleton)
            self._rest_root_x = float(skeleton.offsets[0, 0])
            if self.gl_view is not None:
                self.gl_view.set_skeleton(skeleton)
                self.gl_view.set_bone_opacity(self.bones.value() / 100)
                self.gl_view.set_draggable_ends(
                    {j for j in range(skeleton.n_joints) if self._posing.is_draggable_end(j)})
                if new_rig:
                    self.set_view("side")
            self._show_selected(self._state.selected_joint)
            self._update_reference()
        frame = self._state.frame
        if frame in self._posing.frames():
            pose = self._posing.pose_of(frame)
            posed = frame not in self._posing.missing()
            role = "alternate" if frame in self._posing.alternates() else "key"
            self.shown_kind = role if posed else f"{role} (not posed yet)"
            text = (f"frame {frame}: {self.shown_kind}; drag an end (large dot) to move it, "
                    "any other joint to rotate it")
        elif self._animation.animation is not None:
            pose = self._animation.animation.pose_at(frame)
            self.shown_kind = "predicted"
            text = f"frame {frame}: predicted pose"
        else:
            pose = skeleton.rest_pose()
            self.shown_kind = "rest"
            text = f"frame {frame}: rest pose ({self._animation.status or 'no animation yet'})"
        self.shown_pose = pose
        self.info.setText(text)
        waiting = (self._state.source is not None and self.footage.isChecked()
                   and (self._image is None or self._image[0] != frame))
        if waiting:  # draw pose and footage together, once the loader delivers the frame
            self._fallback.start(FOOTAGE_WAIT_MS + (0 if self.is_playing() else SCRUB_SETTLE_MS))
        else:
            self._draw_pose()

    def _draw_pose(self) -> None:
        self._fallback.stop()
        if self.gl_view is None or self.shown_pose is None:
            return
        self.gl_view.set_pose(self.shown_pose)
        # The footage is tracked (the animal stays in its window): follow the root along X.
        self._dx = float(self.gl_view.joint_positions()[0, 0]) - self._rest_root_x
        self.gl_view.follow_x(self._dx)
        if self._ref is not None:
            self.gl_view.place_reference(self._shifted(self._ref.transform))
        self.gl_view.set_outline(self._outline_segments())
        self.gl_view.set_onion(self._onion_positions())

    def _onion_positions(self) -> list[np.ndarray]:
        """Joint positions of the posed keys before and after this frame (cyclically), their
        roots put on the shown pose's root along X (the footage follows the animal)."""
        frame, posing = self._state.frame, self._posing
        posed = sorted(set(posing.frames()) - set(posing.missing()) - {frame})
        if not self.onion.isChecked() or not posed or frame not in posing.frames():
            return []
        before = [f for f in posed if f < frame] or posed
        after = [f for f in posed if f > frame] or posed
        skeleton, root_x = self._state.skeleton, self.gl_view.joint_positions()[0, 0]
        out = []
        for f in dict.fromkeys((before[-1], after[0])):
            pos = skeleton.joint_positions(posing.pose_of(f))
            out.append(pos + [root_x - pos[0, 0], 0.0, 0.0])
        return out

    def _outline_segments(self) -> np.ndarray | None:
        if not self._outline_world:
            return None
        segments = [np.stack([line, np.roll(line, -1, axis=0)], axis=1)
                    for line in self._outline_world]
        return np.concatenate(segments) + [self._dx, 0.0, 0.0]

    def _show_selected(self, name: str) -> None:
        if self.gl_view is not None and self._skeleton is not None:
            names = self._skeleton.joint_names
            self.gl_view.set_selected(names.index(name) if name in names else -1)

    def _forget_image(self, *_changed) -> None:
        self._image = None
        self._update_reference()

    def _on_frame_loaded(self, index: int, image: np.ndarray) -> None:
        self._image = (index, image)  # as the frame view: the loader decodes the newest only
        self._fallback.stop()
        self._frame_timer.start(0 if self.is_playing() else SCRUB_SETTLE_MS)

    def _apply_frame(self) -> None:
        self._draw_pose()
        self._update_reference()

    def _update_reference(self, *_changed) -> None:
        if self.gl_view is None:
            return
        if not self.footage.isChecked() or self._image is None or self._extent is None:
            self._ref, self._outline_world = None, []
            self.gl_view.set_reference(None)
            self.gl_view.set_outline(None)
            return
        silhouettes = self._state.project.silhouettes
        if silhouettes is not self._sil[0]:
            self._sil = (silhouettes,
                         None if silhouettes is None else silhouette_heights_px(silhouettes))
        index, bgr = self._image
        ref = reference_image(bgr, index, self._extent, silhouettes,
                              fit=self._state.project.footage_fit, heights_px=self._sil[1])
        self._ref = ref
        self.gl_view.set_reference(ref.rgba_xy, self._shifted(ref.transform))
        self._outline_world = []
        if silhouettes is not None and self.outline.isChecked():
            for line in silhouette_outline_px(silhouettes, index):
                xyz = (ref.pixel_to_world @ np.c_[line, np.ones(len(line))].T).T
                self._outline_world.append(xyz + [0.0, 0.0, OUTLINE_LIFT_M])
        self.gl_view.set_outline(self._outline_segments())

    def _shifted(self, transform: np.ndarray) -> np.ndarray:
        shift = np.eye(4)
        shift[0, 3] = self._dx
        return shift @ transform

    def _show_fit(self, *_changed) -> None:
        """Show the project's footage fit in the controls and on the plane."""
        fit = self._state.project.footage_fit
        for control, value in ((self.fit_scale, 100 * fit.scale),
                               (self.fit_x, 100 * fit.offset_x_m),
                               (self.fit_y, 100 * fit.offset_y_m), (self.flip, fit.flip)):
            show_value(control, value)
        for part, box in self.part_scales.items():
            show_value(box, 100 * self._state.project.proportions.scale_of(part))
        if fit != self._fit:
            self._fit = fit
            self._update_reference()

    # -- view -> edits -----------------------------------------------------------------------
    def _edit_fit(self, field_name: str, **change) -> None:
        fit = replace(self._state.project.footage_fit, **change)
        if fit != self._state.project.footage_fit:
            self._state.undo_stack.push(FootageFitCommand(self._state, fit, field_name))

    def _auto_fit(self) -> None:
        fit = FootageFit(flip=self._state.project.footage_fit.flip)
        if fit != self._state.project.footage_fit:
            self._state.undo_stack.push(FootageFitCommand(self._state, fit, "fit (automatic)"))

    def _on_joint_pressed(self, joint: int) -> None:
        self._state.set_selected_joint(self._state.skeleton.joint_names[joint])
        frame = self._posing.editable_frame()
        self._base_pose = None if frame is None else self._posing.pose_of(frame)
        self._posing.begin_drag()

    def _on_joint_dragged(self, joint: int, angle_deg: float) -> None:
        if self._base_pose is not None and self.gl_view is not None:
            self._posing.rotate_joint(joint, self._base_pose, self.gl_view.view_axis(), angle_deg)

    def _on_end_dragged(self, joint: int, target_xyz: np.ndarray) -> None:
        if self._base_pose is not None:
            self._posing.drag_end(joint, self._base_pose, target_xyz)

    def _show_hovered(self, joint: int) -> None:
        """Name the joint under the cursor, in its side's colour."""
        skeleton = self._state.skeleton
        if not 0 <= joint < skeleton.n_joints:
            self.hover.setText("")
            return
        j = skeleton.joints[joint]
        how = "drag to move (IK)" if self._posing.is_draggable_end(joint) else "drag to rotate"
        r, g, b = SIDE_RGB[j.side]
        self.hover.setText(f"<span style='color: rgb({r},{g},{b})'>&#9679;</span> <b>{j.name}</b> "
                           f"({SIDE_WORDS[j.side]}): {how}")


def _spin(tip: str, suffix: str, low: float, high: float, step: float, *,
          prefix: str = "") -> QDoubleSpinBox:
    box = QDoubleSpinBox()
    box.setDecimals(0)
    box.setRange(low, high)
    box.setSingleStep(step)
    box.setPrefix(prefix)
    box.setSuffix(suffix)
    box.setToolTip(tip)
    box.setKeyboardTracking(False)
    return box
