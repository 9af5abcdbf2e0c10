"""The plot of the rhythm's two components (paper Figure 3's PC1 x PC2; on real footage often
another pair, e.g. PC3 x PC5, named on its axes) with the key-image controls.

The trajectory is coloured by time; key-images are orange rings, alternates cyan diamonds,
the current frame a red cross that follows the scrubber. Clicking a point goes to its frame.
Spin boxes choose the number of PCs and keys; buttons pin the current frame into the key
set, drop it (forbid it), and accept the proposed alternates. Each is an undoable command.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QCheckBox,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from app.commands import (
    AcceptAlternatesCommand,
    ChangeSettingsCommand,
    ClearKeyConstraintsCommand,
    ForbidKeyCommand,
    PinKeyCommand,
)
from app.state import AppState
from app.widgets.follow import show_value
from gaitcore.analysis.analyze import Analysis
from gaitcore.errors import GaitInputError

KEY_PEN = pg.mkPen(QColor(255, 140, 0), width=3)
ALT_PEN = pg.mkPen(QColor(0, 170, 220), width=2)
MAX_PCS = 5
MAX_KEYS = 12


class PCPlotWidget(QWidget):
    """PC plot bound to :class:`AppState`.

    Signals
    -------
    messageRaised(str)
        A one-line message for the status bar.
    """

    messageRaised = Signal(str)

    def __init__(self, state: AppState, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._coords = np.zeros((0, 2))
        self._names = ("PC1", "PC2")
        self._first = 0  # source frame of the first row of _coords
        self._build_plot()

        self.pcs = QSpinBox(minimum=1, maximum=MAX_PCS, prefix="PCs: ")
        self.keys = QSpinBox(minimum=1, maximum=MAX_KEYS, prefix="keys: ")
        self.switching = QCheckBox("alternates (walk)")
        self.switching.setToolTip("Propose an alternate per key in the other half-cycle "
                                  "(paper 3.2)")
        self.info = QLabel("no analysis yet")
        self.info.setWordWrap(True)
        self.pin = QPushButton("Pin frame")
        self.pin.setToolTip("Force the current frame into the key set (press again to unpin)")
        self.drop = QPushButton("Drop frame")
        self.drop.setToolTip("Keep the current frame out of the key set (press again to allow)")
        self.clear = QPushButton("Clear")
        self.clear.setToolTip("Unpin and allow every frame")
        self.accept_alt = QPushButton("Accept alternates")

        top = QHBoxLayout()
        for w in (self.pcs, self.keys, self.switching):
            top.addWidget(w)
        top.addStretch(1)
        buttons = QGridLayout()  # two by two: the dock stays narrow beside the footage
        for i, w in enumerate((self.pin, self.drop, self.clear, self.accept_alt)):
            buttons.addWidget(w, i // 2, i % 2)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(top)
        layout.addWidget(self.plot, 1)
        layout.addWidget(self.info)
        layout.addLayout(buttons)

        self.pcs.valueChanged.connect(lambda v: self._change("pcs", v))
        self.keys.valueChanged.connect(lambda v: self._change("keys", v))
        self.switching.toggled.connect(lambda v: self._change("switching", v))
        self.pin.clicked.connect(self._pin)
        self.drop.clicked.connect(self._drop)
        self.clear.clicked.connect(lambda: state.undo_stack.push(ClearKeyConstraintsCommand(state)))
        self.accept_alt.clicked.connect(self._accept_alternates)
        state.projectChanged.connect(self._sync_controls)
        state.analysisChanged.connect(self._on_analysis)
        state.analysisFailed.connect(self._on_failed)
        state.frameChanged.connect(self._move_cursor)
        state.selectedKeyChanged.connect(self._show_selected)
        self._sync_controls()
        self._on_analysis(None)

    def _build_plot(self) -> None:
        """The pair's plot: the loop, its frames, the keys, alternates and the cursor."""
        self.plot = pg.PlotWidget()
        self.plot.setLabel("bottom", "PC1")
        self.plot.setLabel("left", "PC2")
        self.plot.setAspectLocked(True)
        self.plot.showGrid(x=True, y=True, alpha=0.2)
        self.plot.setMenuEnabled(False)
        self._line = pg.PlotCurveItem(pen=pg.mkPen(QColor(170, 170, 170), width=1))
        self._points = pg.ScatterPlotItem(size=7, pen=None, hoverable=True, tip=self._tip)
        self._alternates = pg.ScatterPlotItem(size=16, symbol="d", pen=ALT_PEN, brush=None)
        self._keys = pg.ScatterPlotItem(size=18, symbol="o", pen=KEY_PEN, brush=None)
        self._cursor = pg.ScatterPlotItem(size=16, symbol="+", pen=pg.mkPen("r", width=3))
        self._selected = pg.ScatterPlotItem(size=26, symbol="o", pen=pg.mkPen("r", width=2),
                                            brush=None)
        for item in (self._line, self._points, self._alternates, self._keys, self._selected,
                     self._cursor):
            self.plot.addItem(item)
        self._labels: list[pg.TextItem] = []
        # Markers lie on top of the points and take their clicks: all carry frame numbers.
        for item in (self._points, self._alternates, self._keys, self._selected, self._cursor):
            item.sigClicked.connect(self._on_clicked)

    # -- queries for tests and benchmarks -----------------------------------------------------
    def point_xy(self, frame: int) -> tuple[float, float]:
        """Plot coordinates of source frame ``frame``'s point."""
        row = frame - self._first
        return float(self._coords[row, 0]), float(self._coords[row, 1])

    def cursor_xy(self) -> tuple[float, float] | None:
        """Plot coordinates of the current-frame marker (None when hidden)."""
        xs, ys = self._cursor.getData()
        return (float(xs[0]), float(ys[0])) if len(xs) else None

    # -- state -> widgets ---------------------------------------------------------------------
    def _sync_controls(self, *_changed) -> None:
        s = self._state.project.settings
        for control, value in ((self.pcs, s.pcs), (self.keys, s.keys),
                               (self.switching, s.switching)):
            show_value(control, value)
        self._update_buttons()

    def _on_analysis(self, analysis: Analysis | None) -> None:
        for label in self._labels:
            self.plot.removeItem(label)
        self._labels = []
        if analysis is None:
            self._coords = np.zeros((0, 2))
            for item in (self._line, self._points, self._alternates, self._keys, self._cursor,
                         self._selected):
                item.setData([], [])
            self.info.setText("no analysis yet: segment the clip, sketch it, or open masks")
            self._update_buttons()
            return
        p = analysis.projections
        self._coords = np.column_stack([p[:, 0], p[:, 1] if p.shape[1] > 1 else np.zeros(len(p))])
        names = analysis.component_names
        self._names = (names[0], names[1] if len(names) > 1 else "")
        self.plot.setLabel("bottom", self._names[0])
        self.plot.setLabel("left", self._names[1])
        self.plot.setTitle(f"{self._names[0]} × {self._names[1]}: the gait's loop"
                           if self._names[1] else self._names[0])
        n = len(self._coords)
        cmap = pg.colormap.get("viridis")
        brushes = [pg.mkBrush(c) for c in cmap.map(np.linspace(0, 1, n), mode="qcolor")]
        self._line.setData(self._coords[:, 0], self._coords[:, 1])
        self._first = analysis.first_frame  # the points are rows of the trim
        self._points.setData(x=self._coords[:, 0], y=self._coords[:, 1], brush=brushes,
                             data=self._first + np.arange(n))
        keys = list(analysis.key_frames)  # source frames; the coordinates are rows
        self._keys.setData(self._coords[analysis.rows(keys), 0],
                           self._coords[analysis.rows(keys), 1], data=keys)
        alts = list(analysis.alternate_frames or ())
        self._alternates.setData(self._coords[analysis.rows(alts), 0],
                                 self._coords[analysis.rows(alts), 1], data=alts)
        for f in keys + alts:
            label = pg.TextItem(str(f), color=(90, 50, 0) if f in keys else (0, 90, 120),
                                anchor=(-0.3, 1.1))
            for part in (label, *label.childItems()):  # clicks reach the points beneath
                part.setAcceptedMouseButtons(Qt.MouseButton.NoButton)
            label.setPos(*self._coords[f - analysis.first_frame])
            self.plot.addItem(label)
            self._labels.append(label)
        sel = analysis.selection
        exact = "proven best" if sel.exact else "best found in the time limit"
        self.info.setText(
            f"keys {', '.join(map(str, keys))}: cond(HᵀH) = {sel.condition_number:.3g} ({exact})"
            + (f"; alternates {', '.join(map(str, alts))}" if alts else "")
        )
        self.info.setStyleSheet("")
        if self._state.selected_key not in keys:
            self._state.set_selected_key(-1)
        self._show_selected(self._state.selected_key)
        self._move_cursor(self._state.frame)
        self._update_buttons()

    def _on_failed(self, message: str) -> None:
        self.info.setText(message)
        self.info.setStyleSheet("color: #b00000")
        self.messageRaised.emit(message)

    def _move_cursor(self, frame: int) -> None:
        row = frame - self._first
        if 0 <= row < len(self._coords):
            self._cursor.setData([self._coords[row, 0]], [self._coords[row, 1]], data=[frame])
        else:
            self._cursor.setData([], [])
        self._update_buttons()

    def _show_selected(self, frame: int) -> None:
        row = frame - self._first
        if 0 <= row < len(self._coords):
            self._selected.setData([self._coords[row, 0]], [self._coords[row, 1]], data=[frame])
        else:
            self._selected.setData([], [])

    def _update_buttons(self) -> None:
        s, frame = self._state.project.settings, self._state.frame
        has = self._state.analysis is not None
        self.pin.setText("Unpin frame" if frame in s.pinned else "Pin frame")
        self.drop.setText("Allow frame" if frame in s.forbidden else "Drop frame")
        for w in (self.pin, self.drop):
            w.setEnabled(has)
        self.clear.setEnabled(bool(s.pinned or s.forbidden))
        alts = self._state.analysis.alternate_frames if has else None
        self.accept_alt.setEnabled(bool(alts) and tuple(alts) != self._state.project.alternates)

    def _tip(self, x: float, y: float, data: int) -> str:
        return f"frame {data}\n{self._names[0]} {x:.2f}, {self._names[1]} {y:.2f}"

    # -- widgets -> commands ------------------------------------------------------------------
    def _on_clicked(self, _item, points, event=None) -> None:
        """Go to the frame whose point lies nearest the click (a marker drawn over the points
        does not hide the one under the pointer); a clicked key-image becomes the selected
        key."""
        if not len(points):
            return
        frame = int(points[0].data())
        if event is not None and len(self._coords):
            at = event.pos()  # the items' coordinates are the plot's
            row = int(np.argmin(np.hypot(self._coords[:, 0] - at.x(),
                                         self._coords[:, 1] - at.y())))
            frame = self._first + row
        self._state.set_frame(frame)
        keys = self._state.analysis.key_frames if self._state.analysis is not None else ()
        self._state.set_selected_key(frame if frame in keys else -1)

    def _change(self, field_name: str, value) -> None:
        try:
            settings = replace(self._state.project.settings, **{field_name: value})
        except GaitInputError as exc:
            self.messageRaised.emit(str(exc))
            return
        self._state.undo_stack.push(ChangeSettingsCommand(self._state, settings, field_name))

    def _pin(self) -> None:
        frame = self._state.frame
        pinned = frame not in self._state.project.settings.pinned
        self._state.undo_stack.push(PinKeyCommand(self._state, frame, pinned))

    def _drop(self) -> None:
        frame = self._state.frame
        forbidden = frame not in self._state.project.settings.forbidden
        self._state.undo_stack.push(ForbidKeyCommand(self._state, frame, forbidden))

    def _accept_alternates(self) -> None:
        analysis = self._state.analysis
        if analysis is not None and analysis.alternate_frames:
            self._state.undo_stack.push(AcceptAlternatesCommand(self._state,
                                                                analysis.alternate_frames))
