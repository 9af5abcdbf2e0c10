"""The posing panel: frames to pose, the joint list and one spin box per channel of a joint.

Spin boxes are clamped to the joint limits of the rig; each change is an undoable command
(consecutive changes of one joint merge). Buttons copy and paste poses between keys, mirror
left and right, pose an alternate as its key's mirror, reset, import a pose from a CSV row or
a BVH frame, and change the rig.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QSignalBlocker, Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QDoubleSpinBox,
    QFormLayout,
    QGridLayout,
    QHeaderView,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QPushButton,
    QTreeWidget,
    QTreeWidgetItem,
    QVBoxLayout,
    QWidget,
)

from app.posing import PosingController
from app.state import AppState
from app.widgets.sides import SIDE_RGB, SIDE_WORDS
from gaitcore.rig.skeleton import CHANNEL_ORDER, Skeleton

ANGLE_RANGE_DEG = 180.0
TRANSLATION_RANGE_M = 100.0
LABELS = {"rz": "rz (side view)", "rx": "rx", "ry": "ry", "tx": "tx (m)", "ty": "ty (m)",
          "tz": "tz (m)"}


EXPAND_ALL_JOINTS = 2_000
"""Rigs up to this many posable joints open with their whole tree expanded; bigger ones
show the first EXPAND_DEPTH levels."""
EXPAND_DEPTH = 8

JOINT_INDENT_PX = 12
"""Indentation per level of the joint tree: a horse's hoof, ten levels down, keeps its name."""


class PosePanel(QWidget):
    """Numeric posing of the current key-image, bound to :class:`AppState`."""

    def __init__(self, state: AppState, posing: PosingController,
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._posing = posing
        self._skeleton: Skeleton | None = None

        self.info = QLabel()
        self.info.setWordWrap(True)
        self.frames = QListWidget()
        self.frames.setFlow(QListWidget.Flow.LeftToRight)
        self.frames.setWrapping(True)
        self.frames.setMaximumHeight(58)
        self.frames.setToolTip("Frames to pose: click one to go there")
        self.joints = QTreeWidget()
        self.joints.setHeaderHidden(True)
        self.joints.setMinimumHeight(150)
        self.joints.setIndentation(JOINT_INDENT_PX)
        # as wide as its longest name, scrolled rather than cut where the dock is narrower
        self.joints.header().setSectionResizeMode(0, QHeaderView.ResizeMode.ResizeToContents)
        self.joints.header().setStretchLastSection(False)
        self.spins: dict[str, QDoubleSpinBox] = {}
        form = QFormLayout()
        for ch in CHANNEL_ORDER[3:] + CHANNEL_ORDER[:3]:
            box = QDoubleSpinBox()
            box.setKeyboardTracking(False)
            box.setDecimals(3 if ch.startswith("t") else 2)
            box.setSingleStep(0.01 if ch.startswith("t") else 1.0)
            box.setSuffix(" m" if ch.startswith("t") else "°")
            box.valueChanged.connect(lambda v, c=ch: self._on_spin(c, v))
            form.addRow(LABELS[ch], box)
            self.spins[ch] = box
        self._form = form

        grid = self._build_buttons(posing)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.info)
        layout.addWidget(self.frames)
        layout.addWidget(self.joints, 1)
        layout.addLayout(form)
        layout.addLayout(grid)

        self.frames.itemClicked.connect(
            lambda item: state.set_frame(item.data(Qt.ItemDataRole.UserRole)))
        self.joints.currentItemChanged.connect(self._on_joint_clicked)
        state.projectChanged.connect(self.sync)
        state.analysisChanged.connect(self.sync)
        state.frameChanged.connect(self.sync)
        state.selectedJointChanged.connect(self.sync)
        self.sync()

    def _build_buttons(self, posing: PosingController) -> QGridLayout:
        """The pose edits and imports as buttons, two per row, in :attr:`buttons`."""
        self.buttons: dict[str, QPushButton] = {}
        grid = QGridLayout()
        actions = [
            ("copy", "Copy", posing.copy), ("paste", "Paste", posing.paste),
            ("paste_mirrored", "Paste mirrored", lambda: posing.paste(mirrored=True)),
            ("mirror", "Mirror L/R", posing.mirror),
            ("mirror_key", "Mirror of key", posing.mirror_of_key),
            ("reset_joint", "Reset joint", lambda: posing.reset(joint_only=True)),
            ("reset_pose", "Reset pose", lambda: posing.reset(joint_only=False)),
            ("import_csv", "Pose from CSV...", posing.import_csv),
            ("import_bvh", "Pose from BVH...", posing.import_bvh),
            ("load_rig", "Load rig from BVH...", posing.load_rig),
            ("template", "Horse template", posing.use_template),
        ]
        for i, (key, text, slot) in enumerate(actions):
            button = QPushButton(text)
            button.clicked.connect(lambda _c=False, s=slot: s())
            grid.addWidget(button, i // 2, i % 2)
            self.buttons[key] = button
        self.buttons["mirror_key"].setToolTip("Pose this alternate as the mirror of its key "
                                              "(walks)")
        self.buttons["load_rig"].setToolTip("Pose another skeleton; poses are dropped unless its "
                                            "channels are the same")
        return grid

    # -- for tests and the viewport ------------------------------------------------------------
    def select_joint(self, name: str) -> None:
        """Select joint ``name`` in the list, as a click does."""
        items = self.joints.findItems(name, Qt.MatchFlag.MatchExactly | Qt.MatchFlag.MatchRecursive)
        if items:
            self.joints.setCurrentItem(items[0])

    # -- state -> widgets ----------------------------------------------------------------------
    def sync(self, *_changed) -> None:
        state, posing = self._state, self._posing
        skeleton = state.skeleton
        if skeleton is not self._skeleton:
            self._skeleton = skeleton
            self._fill_joints(skeleton)
        frames, missing, alts = posing.frames(), posing.missing(), posing.alternates()
        self._fill_frames(frames, missing, alts)
        frame = posing.editable_frame()
        if frame is None:
            self.info.setText(f"Frame {state.frame} is not a key-image: go to a frame to pose "
                              "(below) to pose it" if frames
                              else "No key-images yet: analyse the clip")
        else:
            role = "alternate" if frame in alts else "key"
            done = len(frames) - len(missing)
            self.info.setText(f"Frame {frame}: {role} {frames.index(frame) + 1} of {len(frames)} "
                              f"({'posed' if frame not in missing else 'not posed yet'}); "
                              f"{done} of {len(frames)} posed. Rig: {skeleton.name}")
        for key, button in self.buttons.items():
            button.setEnabled(frame is not None or key in ("load_rig", "template"))
        self.buttons["paste"].setEnabled(frame is not None and posing.has_clipboard())
        self.buttons["paste_mirrored"].setEnabled(frame is not None and posing.has_clipboard())
        self.buttons["mirror_key"].setEnabled(frame is not None and frame in alts)
        self._show_joint(state.selected_joint, frame)

    def _fill_joints(self, skeleton: Skeleton) -> None:
        with QSignalBlocker(self.joints):
            self.joints.clear()
            items: dict[str, QTreeWidgetItem] = {}
            for joint in skeleton.joints:
                if not joint.channels:
                    continue
                parent = items.get(joint.parent)
                item = QTreeWidgetItem([joint.name])
                if joint.side != "C":  # left and right in the viewport's colours
                    item.setForeground(0, QColor(*SIDE_RGB[joint.side]))
                    item.setToolTip(0, f"{joint.name}: {SIDE_WORDS[joint.side]} side")
                (parent.addChild(item) if parent is not None else self.joints.addTopLevelItem(item))
                items[joint.name] = item
            if len(items) <= EXPAND_ALL_JOINTS:
                self.joints.expandAll()
            else:  # Qt's expandAll is slow on very deep trees (a 20,000-joint chain: seconds)
                self.joints.expandToDepth(EXPAND_DEPTH)
        limits = skeleton.limits_array()
        self._limits = {c: limits[i] for i, c in enumerate(skeleton.channel_names)}

    def _fill_frames(self, frames, missing, alts) -> None:
        self.frames.clear()
        for f in frames:
            kind = "alt" if f in alts else "key"
            item = QListWidgetItem(f"{kind} {f} {'✗' if f in missing else '✓'}")
            item.setData(Qt.ItemDataRole.UserRole, f)
            item.setForeground(QColor(170, 0, 0) if f in missing else QColor(0, 110, 0))
            self.frames.addItem(item)
            if f == self._state.frame:
                item.setSelected(True)

    def _show_joint(self, name: str, frame: int | None) -> None:
        current = self.joints.currentItem()
        if (current.text(0) if current else "") != name:
            found = self.joints.findItems(name,
                                          Qt.MatchFlag.MatchExactly | Qt.MatchFlag.MatchRecursive)
            with QSignalBlocker(self.joints):
                self.joints.setCurrentItem(found[0] if found and name else None)
        pose = None if frame is None else self._posing.pose_of(frame)
        skeleton = self._state.skeleton
        for ch, box in self.spins.items():
            channel = f"{name}.{ch}"
            have = bool(name) and channel in self._limits
            self._form.setRowVisible(box, have)
            box.setEnabled(have and pose is not None)
            if not have:
                continue
            lo, hi = self._limits[channel]
            span = TRANSLATION_RANGE_M if ch.startswith("t") else ANGLE_RANGE_DEG
            with QSignalBlocker(box):
                box.setRange(lo if np.isfinite(lo) else -span, hi if np.isfinite(hi) else span)
                box.setValue(0.0 if pose is None else float(pose[skeleton.channel_index(channel)]))

    # -- widgets -> edits ----------------------------------------------------------------------
    def _on_joint_clicked(self, item: QTreeWidgetItem | None, _previous=None) -> None:
        self._state.set_selected_joint(item.text(0) if item is not None else "")

    def _on_spin(self, channel: str, value: float) -> None:
        joint = self._state.selected_joint
        if joint:
            self._posing.set_channel(f"{joint}.{channel}", value)
