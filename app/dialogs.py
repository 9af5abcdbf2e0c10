"""Every question the application asks the artist, in one replaceable object.

Controllers call an :class:`Asker` instead of building message boxes themselves, so asking
is separate from doing (as SLEAP's command layer does) and tests substitute a scripted asker.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QInputDialog,
    QLabel,
    QMessageBox,
    QWidget,
)

from gaitcore.footage.sources import DEFAULT_FPS
from gaitcore.project.document import MAX_SPEED_M_S, AnimationOptions
from gaitcore.project.steps import FootageSpeed
from gaitcore.project.storage import SUFFIX
from gaitcore.schema import fps_ok

FOOTAGE_FILTER = "Footage (*.mp4 *.mov *.avi *.mkv *.m4v *.webm *.gif);;All files (*)"
PROJECT_FILTER = f"Gait Studio projects (*{SUFFIX})"
COMMON_RATES = ("15", "24", "25", "30", "50", "60")
"""Frame rates offered for a clip whose files do not say theirs (an image folder)."""


class Asker:
    """Modal dialogs parented to ``parent`` (the main window)."""

    def __init__(self, parent: QWidget | None = None) -> None:
        self._parent = parent

    def error(self, title: str, message: str) -> None:
        """Tell the artist something failed; ``message`` is a one-line gaitcore message."""
        QMessageBox.warning(self._parent, title, message)

    def save_changes(self, name: str) -> str:
        """Ask what to do with unsaved changes: ``"save"``, ``"discard"`` or ``"cancel"``."""
        buttons = (QMessageBox.StandardButton.Save | QMessageBox.StandardButton.Discard
                   | QMessageBox.StandardButton.Cancel)
        answer = QMessageBox.question(self._parent, "Unsaved changes",
                                      f"Save the changes to {name}?", buttons,
                                      QMessageBox.StandardButton.Save)
        return {QMessageBox.StandardButton.Save: "save",
                QMessageBox.StandardButton.Discard: "discard"}.get(answer, "cancel")

    def open_path(self, start: Path | None) -> Path | None:
        """A project, video file or image folder to open (None: cancelled)."""
        path, _ = QFileDialog.getOpenFileName(
            self._parent, "Open project or footage", str(start or ""),
            f"{PROJECT_FILTER};;{FOOTAGE_FILTER}")
        return Path(path) if path else None

    def open_folder(self, start: Path | None) -> Path | None:
        """A folder of frames or of binary masks (None: cancelled)."""
        path = QFileDialog.getExistingDirectory(self._parent, "Open image or mask folder",
                                                str(start or ""))
        return Path(path) if path else None

    def save_path(self, suggested: Path) -> Path | None:
        """Where to save the project (None: cancelled); the suffix is added when missing."""
        path, _ = QFileDialog.getSaveFileName(self._parent, "Save project", str(suggested),
                                              PROJECT_FILTER)
        if not path:
            return None
        p = Path(path)
        return p if p.suffix == SUFFIX else p.with_name(p.name + SUFFIX)

    def locate_footage(self, missing: Path) -> Path | None:
        """The new place of footage that moved (None: open without footage)."""
        QMessageBox.information(
            self._parent, "Footage not found",
            f"The clip of this project is no longer at\n{missing}\n\nShow where it is now "
            "(or cancel to open the project without footage).")
        if missing.suffix:
            path, _ = QFileDialog.getOpenFileName(self._parent, f"Where is {missing.name}?",
                                                  str(missing.parent), FOOTAGE_FILTER)
        else:
            path = QFileDialog.getExistingDirectory(self._parent, f"Where is {missing.name}?",
                                                    str(missing.parent))
        return Path(path) if path else None

    def recover(self, description: str) -> bool:
        """Offer to recover autosaved work; True to recover, False to discard it."""
        answer = QMessageBox.question(
            self._parent, "Recover unsaved work",
            f"Gait Studio did not close normally. Recover the autosaved copy of {description}?\n"
            "(No deletes the copy.)")
        return answer == QMessageBox.StandardButton.Yes

    def open_file(self, title: str, file_filter: str) -> Path | None:
        """A file to read, e.g. a pose table or a BVH (None: cancelled)."""
        path, _ = QFileDialog.getOpenFileName(self._parent, title, "",
                                              f"{file_filter};;All files (*)")
        return Path(path) if path else None

    def export_path(self, title: str, suggested: Path, file_filter: str) -> Path | None:
        """Where to write an export (None: cancelled); the suggested suffix is added if missing."""
        path, _ = QFileDialog.getSaveFileName(self._parent, title, str(suggested), file_filter)
        if not path:
            return None
        p = Path(path)
        return p if p.suffix else p.with_suffix(suggested.suffix)

    def export_folder(self, title: str, suggested: Path) -> Path | None:
        """A folder to export into, created when new (None: cancelled)."""
        path = QFileDialog.getExistingDirectory(self._parent, title, str(suggested.parent))
        return Path(path) if path else None

    def export_options(self, title: str, options: AnimationOptions,
                       footage: FootageSpeed | None = None) -> AnimationOptions | None:
        """The export options, shown with ``options`` filled in and the footage's speed
        (None: it shows no travel) beside the speed (None: cancelled)."""
        dialog = ExportOptionsDialog(options, footage, self._parent)
        dialog.setWindowTitle(title)
        return dialog.options() if dialog.exec() == QDialog.DialogCode.Accepted else None

    def confirm(self, title: str, message: str) -> bool:
        """Ask before a change that drops work (it stays undoable); True to go on."""
        answer = QMessageBox.question(self._parent, title, message)
        return answer == QMessageBox.StandardButton.Yes

    def choose_frame(self, title: str, frames: list[int], *,
                     suggested: int | None = None) -> int | None:
        """One of ``frames`` (None: cancelled), ``suggested`` (if one of them) preselected."""
        first = suggested if suggested in frames else frames[0]
        if frames == list(range(frames[0], frames[0] + len(frames))):
            value, ok = QInputDialog.getInt(self._parent, title, "Frame:", first, frames[0],
                                            frames[-1])
            return value if ok else None
        item, ok = QInputDialog.getItem(self._parent, title, "Frame:", [str(f) for f in frames],
                                        frames.index(first), False)
        return int(item) if ok else None

    def frame_rate(self, current: float | None) -> float | None:
        """A frame rate in frames per second (None: cancelled): the usual rates offered, any
        other typed; ``current`` (the rate playback uses) first."""
        shown = f"{current or DEFAULT_FPS:g}"
        items = [shown] + [r for r in COMMON_RATES if r != shown]
        text, ok = QInputDialog.getItem(self._parent, "Frame rate",
                                        "Frames per second of the clip:", items, 0, True)
        if not ok:
            return None
        try:
            value = float(text)
        except ValueError:
            return None
        return value if fps_ok(value) else None


class HeadlessAsker(Asker):
    """Answers without asking, for ``--screenshot`` runs: errors go to stderr and are kept.

    Attributes
    ----------
    errors : list of str
        Every error reported, as ``"title: message"``.
    """

    def __init__(self) -> None:
        super().__init__(None)
        self.errors: list[str] = []

    def error(self, title: str, message: str) -> None:
        self.errors.append(f"{title}: {message}")
        print(f"gaitstudio: {title}: {message}", file=sys.stderr)

    def save_changes(self, name: str) -> str:
        return "discard"

    def open_path(self, start: Path | None) -> Path | None:
        return None

    def open_folder(self, start: Path | None) -> Path | None:
        return None

    def save_path(self, suggested: Path) -> Path | None:
        return None

    def locate_footage(self, missing: Path) -> Path | None:
        return None

    def recover(self, description: str) -> bool:
        return False

    def open_file(self, title: str, file_filter: str) -> Path | None:
        return None

    def export_path(self, title: str, suggested: Path, file_filter: str) -> Path | None:
        return None

    def export_folder(self, title: str, suggested: Path) -> Path | None:
        return None

    def export_options(self, title: str, options: AnimationOptions,
                       footage: FootageSpeed | None = None) -> AnimationOptions | None:
        return options

    def confirm(self, title: str, message: str) -> bool:
        return False

    def choose_frame(self, title: str, frames: list[int], *,
                     suggested: int | None = None) -> int | None:
        return None

    def frame_rate(self, current: float | None) -> float | None:
        return None

ROOT_CHOICES = (
    ("auto", "Automatic: in place for a loop, else as in the footage"),
    ("in-place", "In place (horizontal root motion removed)"),
    ("footage", "As in the footage (the animal's own progress)"),
    ("forward", "Forward at constant speed"),
    ("as-keys", "As interpolated from the keys (jumps back each cycle)"),
)
NAMING_CHOICES = (("as-is", "As in the skeleton (L_hip)"), ("rigify", "Blender / Rigify (hip.L)"))


class ExportOptionsDialog(QDialog):
    """Root motion, ground contact, loop and bone names of one export, before the file."""

    def __init__(self, options: AnimationOptions, footage: FootageSpeed | None = None,
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._options = options
        self.root = QComboBox()
        for value, label in ROOT_CHOICES:
            self.root.addItem(label, value)
        self.root.setCurrentIndex([v for v, _ in ROOT_CHOICES].index(options.root_motion))
        self.speed = QDoubleSpinBox()
        self.speed.setRange(0.0, MAX_SPEED_M_S)
        self.speed.setDecimals(2)
        self.speed.setSingleStep(0.1)
        self.speed.setSuffix(" m/s")
        self.speed.setSpecialValueText("from the footage" if footage else "from the keys")
        self.speed.setValue(options.root_speed_m_s)
        self.speed.setToolTip("Speed of a forward root; at its lowest, the footage's own "
                              "(or the keys' roots' when the footage shows no travel)")
        self.speed_source = QLabel(
            f"The footage shows {footage.describe()}." if footage is not None else
            "The footage shows no travel (the camera follows the animal, or it stays in "
            "view): give the speed for a root that moves forward.")
        self.speed_source.setWordWrap(True)
        self.contact = QCheckBox("Feet on the ground (plant stance, lift out of the floor)")
        self.contact.setChecked(options.ground_contact)
        self.loop = QCheckBox("One gait cycle that loops")
        self.loop.setChecked(options.loop)
        self.names = QComboBox()
        for value, label in NAMING_CHOICES:
            self.names.addItem(label, value)
        self.names.setCurrentIndex([v for v, _ in NAMING_CHOICES].index(options.bone_names))
        form = QFormLayout(self)
        form.addRow("Root motion:", self.root)
        form.addRow("Speed:", self.speed)
        form.addRow("", self.speed_source)
        form.addRow("", self.contact)
        form.addRow("", self.loop)
        form.addRow("Bone names:", self.names)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok
                                   | QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def options(self) -> AnimationOptions:
        """The options as the controls show them."""
        return replace(self._options, root_motion=self.root.currentData(),
                       root_speed_m_s=round(self.speed.value(), 2),
                       ground_contact=self.contact.isChecked(), loop=self.loop.isChecked(),
                       bone_names=self.names.currentData())
