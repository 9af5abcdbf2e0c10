"""Is the clip usable? The spectral diagnosis of paper Section 5.2, as in its Figure 9.

The verdict first, in a word with the period and the components it is read on; then the
amplitude spectra of the rhythm's pair and the next component (PC1..PC3 in the paper;
on real footage often other ones, named in the legend), the peak function fitted to the
first of them (scaled to its maximum), the band kept by the filter (shaded), then the
correlation r of every component with its band-passed version, the period of the gait, the
verdict and the advice in plain words, with what the analysis left out and why.
"""

from __future__ import annotations

import html

import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from app.state import AppState
from gaitcore.analysis.analyze import Analysis
from gaitcore.analysis.verdict import QUIET_CORRELATION, Verdict

PC_COLOURS = (QColor(30, 90, 200), QColor(220, 80, 20), QColor(40, 150, 60))
VERDICT_COLOURS = {Verdict.USABLE: "#1a7f1a", Verdict.TRY_SKETCHING: "#b36b00",
                   Verdict.NOT_USABLE: "#b00000"}
THRESHOLD = 0.6


class DiagnosisPanel(QWidget):
    """Spectrum plot and verdict, bound to ``state.analysis``."""

    def __init__(self, state: AppState, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self.plot = pg.PlotWidget()
        self.plot.setLabel("bottom", "frequency (cycles per frame)")
        self.plot.getAxis("bottom").enableAutoSIPrefix(False)
        self.plot.setLabel("left", "amplitude")
        self.plot.setMenuEnabled(False)
        self.plot.setMinimumHeight(170)
        self.plot.addLegend(offset=(-10, 10))
        self._band = pg.LinearRegionItem(movable=False, brush=pg.mkBrush(255, 200, 0, 50),
                                         pen=pg.mkPen(QColor(200, 150, 0)))
        self._f0 = pg.InfiniteLine(angle=90, pen=pg.mkPen(QColor(120, 120, 120),
                                                          style=Qt.PenStyle.DotLine))
        self._curves = [self.plot.plot(pen=pg.mkPen(c, width=2), name=f"PC{k + 1}")
                        for k, c in enumerate(PC_COLOURS)]
        self._peak = self.plot.plot(pen=pg.mkPen("k", width=1.5, style=Qt.PenStyle.DashLine),
                                    name="peak fit")
        self.plot.addItem(self._band)
        self.plot.addItem(self._f0)
        self.verdict = QLabel()  # above the spectrum: read without scrolling
        self.verdict.setWordWrap(True)
        self.verdict.setTextFormat(Qt.TextFormat.RichText)
        self.text = QLabel()
        self.text.setWordWrap(True)
        self.text.setTextFormat(Qt.TextFormat.RichText)
        self.text.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.verdict)
        layout.addWidget(self.plot, 3)
        layout.addWidget(self.text, 2)
        state.analysisChanged.connect(self._on_analysis)
        self._on_analysis(None)

    def _on_analysis(self, analysis: Analysis | None) -> None:
        visible = analysis is not None
        for item in (self._band, self._f0):
            item.setVisible(visible)
        if analysis is None:
            for curve in self._curves + [self._peak]:
                curve.setData([], [])
            self.verdict.setText("")
            self.text.setText("<i>The diagnosis appears once the clip has silhouettes.</i>")
            return
        d = analysis.diagnosis
        f, amp = d.frequencies, d.amplitudes
        legend = self.plot.plotItem.legend
        legend.clear()
        for k, curve in enumerate(self._curves):
            if k < amp.shape[1]:
                curve.setData(f, amp[:, k])
                legend.addItem(curve, analysis.component_names[k])
            else:
                curve.setData([], [])
        legend.addItem(self._peak, "peak fit")
        self._peak.setData(f, d.peak(f) * amp[:, 0].max())
        self._band.setRegion(d.band)
        self._f0.setValue(d.f0)
        high = min(0.5, max(4 * d.band[1], 6 * d.f0))
        self.plot.setXRange(0, high, padding=0)
        self.plot.setYRange(0, amp[f <= high, : len(self._curves)].max() * 1.08, padding=0)
        self.verdict.setText(self._headline(analysis))
        self.text.setText(self._describe(analysis))

    @staticmethod
    def _headline(analysis: Analysis) -> str:
        """The verdict in a word, with the period and the components it is read on."""
        d = analysis.diagnosis
        colour = VERDICT_COLOURS[d.verdict]
        return (f"<b style='color:{colour}; font-size:14pt'>"
                f"{html.escape(d.verdict.value.capitalize())}</b>&nbsp;&nbsp;period "
                f"{d.period_frames:.1f} frames, {html.escape(analysis.pair_name)}")

    def _describe(self, analysis: Analysis) -> str:
        d = analysis.diagnosis
        cells = []
        names = analysis.component_names
        for k, r in enumerate(d.correlations):
            good = r >= THRESHOLD if k < 2 else r <= QUIET_CORRELATION
            style = "" if good else " style='color:#b00000'"
            cells.append(f"<td{style}>{names[k]}&nbsp;{r:.2f}</td>")
        order = list(analysis.components or range(len(d.correlations)))
        variance = analysis.pca.variance_ratio[order] * 100
        fps = self._state.fps
        period = f"{d.period_frames:.1f} frames"
        if fps:
            period += f" ({d.period_frames / fps:.2f} s at {fps:g} fps)"
        lost = len(analysis.lost_frames)
        start, stop = analysis.frame_range
        advice = analysis.advice
        steps = ""
        if advice is not None and advice.cause.value != "none":
            steps += f"<p><b>{html.escape(advice.message)}</b> {html.escape(advice.next_step)}</p>"
        elif advice is not None and advice.next_step:
            steps += f"<p>{html.escape(advice.next_step)}</p>"
        if analysis.alternates_note:
            steps += f"<p style='color:#b00000'>{html.escape(analysis.alternates_note)}</p>"
        for note in () if advice is None else advice.notes:
            steps += f"<p>{html.escape(note)}</p>"
        return (
            f"<table cellspacing='6'><tr><td><b>r</b></td>{''.join(cells)}</tr>"
            f"<tr><td><b>var %</b></td>"
            f"{''.join(f'<td>{v:.1f}</td>' for v in variance)}</tr></table>"
            f"Period of {names[0]}: <b>{period}</b>; band {d.band[0]:.3f}–{d.band[1]:.3f} "
            "cycles/frame."
            + (f" {lost} frame(s) without a whole silhouette were interpolated." if lost else "")
            + f" Frames {start} to {stop - 1}."
            + f"<p>{html.escape(d.reason)}</p>" + steps
            + f"<p style='color:gray'>Usable when r1 and r2 ≥ {THRESHOLD} (paper 5.2);"
            f" good clips keep r3.. ≤ {QUIET_CORRELATION}.</p>"
        )

