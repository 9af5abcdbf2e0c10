"""The animation panel: RBF weights over time (paper Figure 10) and the preview options.

One curve w_i(t) per posed frame (each key a colour, its alternate the same colour dashed)
and their sum (black, dotted), a vertical line at the current frame, a dot on each curve at
its own frame (where it is 1). Check boxes drive the preview and the export: band-pass
filtered trajectories, clamped weights, one looping cycle; they are the project's options
(saved with it, each change one undo step). Clicking the plot goes to that frame.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QVBoxLayout, QWidget

from app.animation import AnimationController
from app.posing import PosingController
from app.state import AppState
from app.widgets.follow import show_value
from gaitcore.project.steps import CLAMP_RANGE, Animation


class AnimationView(QWidget):
    """Weights plot and options bound to an :class:`AnimationController`."""

    def __init__(self, state: AppState, controller: AnimationController, posing: PosingController,
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._controller = controller
        self._posing = posing
        self.plot = pg.PlotWidget()
        self.plot.setLabel("bottom", "frame")
        self.plot.setLabel("left", "weight w_i(t)")
        self.plot.showGrid(x=True, y=True, alpha=0.2)
        self.plot.setMenuEnabled(False)
        for side in ("bottom", "left"):  # no "frame (x0.001)" while the plot is empty
            self.plot.getAxis(side).enableAutoSIPrefix(False)
        # The legend in a row of its own under the frame axis, never over the curves.
        self.legend = pg.LegendItem(labelTextSize="8pt", colCount=12)
        self.plot.plotItem.layout.addItem(self.legend, 4, 1)
        self.plot.setMinimumHeight(130)
        self.frame_line = pg.InfiniteLine(angle=90, pen=pg.mkPen("r", width=1))
        self.plot.addItem(self.frame_line)
        self._curves: list[pg.PlotDataItem] = []
        self.filtered = QCheckBox("band-pass filtered")
        self.filtered.setToolTip("Drive the animation with the filtered PC trajectories "
                                 "(paper 5.2)")
        self.clamp = QCheckBox(f"clamp weights to [{CLAMP_RANGE[0]:g}, {CLAMP_RANGE[1]:g}]")
        self.loop = QCheckBox("loop one cycle")
        self.loop.setToolTip("Play and export one gait cycle of the detected period, closed on "
                             "itself")
        self.status = QLabel()
        self.status.setWordWrap(True)
        options = QHBoxLayout()
        for box in (self.filtered, self.clamp, self.loop):
            options.addWidget(box)
            box.toggled.connect(self._on_options)
        options.addStretch(1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(options)
        layout.addWidget(self.plot, 1)
        layout.addWidget(self.status)

        self._show_options()
        state.projectChanged.connect(self._show_options)
        controller.animationChanged.connect(self._show)
        state.analysisChanged.connect(self._set_range)
        controller.statusChanged.connect(self.status.setText)
        state.frameChanged.connect(lambda f: self.frame_line.setValue(f))
        self.plot.scene().sigMouseClicked.connect(self._on_click)
        self._show(controller.animation)
        self.status.setText(controller.status)

    def _set_range(self, *_changed) -> None:
        n = self._state.n_frames
        if n:
            self.plot.setXRange(0, n - 1, padding=0.01)
            self.plot.setYRange(-0.2, 1.2, padding=0)

    def _show_options(self, *_changed) -> None:
        """Tick the boxes as the project says (after an undo, or a project opened)."""
        options = self._controller.options
        for box, value in ((self.filtered, options.filtered), (self.clamp, options.clamp),
                           (self.loop, options.loop)):
            show_value(box, value)

    def _on_options(self, *_checked) -> None:
        options = replace(self._controller.options, filtered=self.filtered.isChecked(),
                          clamp=self.clamp.isChecked(), loop=self.loop.isChecked())
        self._controller.set_options(options)

    def _show(self, animation: Animation | None) -> None:
        for item in self._curves:
            self.plot.removeItem(item)
        self._curves = []
        self.legend.clear()
        if animation is None:
            return
        w = animation.weights
        first = animation.first_frame
        t = first + np.arange(len(w.weights))
        keys, alts = list(self._state.analysis.key_frames), list(self._posing.alternates())
        for i, row in enumerate(w.pose_frames):
            frame = first + row
            # key i and its alternate
            pair = keys.index(frame) if frame in keys else alts.index(frame)
            colour = pg.intColor(pair, hues=max(len(keys), 1), maxHue=300, minValue=120,
                                 maxValue=220)
            style = Qt.PenStyle.DashLine if frame in alts else Qt.PenStyle.SolidLine
            pen = pg.mkPen(colour, width=2, style=style)
            label = f"{'alt' if frame in alts else 'key'} {frame}"
            curve = self.plot.plot(t, w.weights[:, i], pen=pen)
            self.legend.addItem(curve, label)
            dot = self.plot.plot([frame], [w.weights[frame - first, i]], pen=None, symbol="o",
                                 symbolBrush=colour, symbolPen=None, symbolSize=7)
            self._curves += [curve, dot]
        total = self.plot.plot(t, w.total, pen=pg.mkPen("k", width=1.5, style=Qt.PenStyle.DotLine))
        self.legend.addItem(total, "Σ w_i")
        self._curves.append(total)
        if animation.cycle is not None:
            start = first + animation.cycle_start
            band = pg.LinearRegionItem((start, start + len(animation.cycle)),
                                       movable=False, brush=pg.mkBrush(0, 150, 0, 30))
            self.plot.addItem(band)
            self._curves.append(band)
        self.plot.plotItem.layout.activate()  # the legend to its row now, not at the corner
        self.frame_line.setValue(self._state.frame)

    def _on_click(self, event) -> None:
        vb = self.plot.getPlotItem().getViewBox()
        if (event.button() == Qt.MouseButton.LeftButton
                and vb.sceneBoundingRect().contains(event.scenePos())):
            self._state.set_frame(round(vb.mapSceneToView(event.scenePos()).x()))
