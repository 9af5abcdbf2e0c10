"""What each principal component changes in the silhouette (paper Figure 7).

One row per component (up to three): the mean silhouette minus two standard deviations along
it, the mean, and the mean plus two standard deviations.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QImage, QPixmap
from PySide6.QtWidgets import QGridLayout, QLabel, QWidget

from app.state import AppState
from gaitcore.analysis.analyze import Analysis

ROWS = 3
SCALE_SD = 2.0
THUMB_W = 72


def grey_pixmap(image: np.ndarray, width: int) -> QPixmap:
    """A (rows, cols) float image in [0, 1] (clipped) as a grey pixmap ``width`` pixels wide."""
    grey = np.ascontiguousarray((np.clip(image, 0.0, 1.0) * 255).astype(np.uint8))
    rows, cols = grey.shape
    qimage = QImage(grey.data, cols, rows, cols, QImage.Format.Format_Grayscale8).copy()
    return QPixmap.fromImage(qimage).scaledToWidth(width,
                                                   Qt.TransformationMode.SmoothTransformation)


class EigenImagesView(QWidget):
    """A grid of mean ± component images, bound to ``state.analysis``."""

    def __init__(self, state: AppState, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        grid = QGridLayout(self)
        grid.setContentsMargins(4, 4, 4, 4)
        for c, title in enumerate((f"−{SCALE_SD:g} sd", "mean", f"+{SCALE_SD:g} sd")):
            grid.addWidget(QLabel(title, alignment=Qt.AlignmentFlag.AlignCenter), 0, c + 1)
        self._row_labels = []
        self._cells: list[list[QLabel]] = []
        for r in range(ROWS):
            label = QLabel(f"PC{r + 1}")
            grid.addWidget(label, r + 1, 0)
            self._row_labels.append(label)
            cells = [QLabel(alignment=Qt.AlignmentFlag.AlignCenter) for _ in range(3)]
            for c, cell in enumerate(cells):
                grid.addWidget(cell, r + 1, c + 1)
            self._cells.append(cells)
        grid.setRowStretch(ROWS + 1, 1)
        state.analysisChanged.connect(self._on_analysis)
        self._on_analysis(None)

    def _on_analysis(self, analysis: Analysis | None) -> None:
        images = None if analysis is None else analysis.pca.eigen_images(SCALE_SD)
        for r in range(ROWS):
            shown = images is not None and r < images.shape[0]
            self._row_labels[r].setVisible(shown)
            for c, cell in enumerate(self._cells[r]):
                cell.setVisible(shown)
                if shown:
                    cell.setPixmap(grey_pixmap(images[r, c], THUMB_W))
                    if c == 1:
                        share = analysis.pca.variance_ratio[r] * 100
                        self._row_labels[r].setText(f"PC{r + 1}\n{share:.1f} %")
