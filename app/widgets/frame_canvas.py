"""The view box of the frame view: pan and zoom, or draw rectangles and strokes with the mouse.

Tablets need nothing special: Qt turns unaccepted tablet events into mouse events, so a pen
draws like a mouse (pressure is not used).
"""

from __future__ import annotations

from enum import Enum

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, QRectF, Qt, Signal


class Tool(Enum):
    """What a left drag on the frame does."""

    NAVIGATE = "navigate"
    BOX = "box around the animal"
    SUBJECT_BRUSH = "subject brush"
    BACKGROUND_BRUSH = "background brush"
    SUBJECT = "subject rectangle"
    BACKGROUND = "background rectangle"
    DRAW = "draw"
    ERASE = "erase"

    @property
    def draws_rect(self) -> bool:
        return self in (Tool.BOX, Tool.SUBJECT, Tool.BACKGROUND)

    @property
    def draws_path(self) -> bool:
        return self in (Tool.DRAW, Tool.ERASE, Tool.SUBJECT_BRUSH, Tool.BACKGROUND_BRUSH)

    @property
    def brush_label(self) -> str | None:
        """The scribble label a brush paints ("subject" or "background"), else None."""
        return {Tool.SUBJECT_BRUSH: "subject", Tool.BACKGROUND_BRUSH: "background"}.get(self)


class CanvasViewBox(pg.ViewBox):
    """A y-down, aspect-locked view box whose left drags follow the current :class:`Tool`.

    Signals
    -------
    rectDragged(QRectF, bool)
        Rectangle tools: the dragged rectangle in image pixels; True when the drag ended.
    pathDragged(object, bool)
        Draw and erase: points (k, 2) float64 in image pixels (x, y); True at the end. A
        click gives one point.
    rectClicked(QPointF)
        Rectangle tools: a click without a drag, in image pixels.
    """

    rectDragged = Signal(object, bool)
    pathDragged = Signal(object, bool)
    rectClicked = Signal(object)

    def __init__(self) -> None:
        super().__init__(lockAspect=True, invertY=True, enableMenu=False)
        self.tool = Tool.NAVIGATE
        self._points: list[tuple[float, float]] = []
        self._start = QPointF()

    def mouseDragEvent(self, ev, axis=None) -> None:  # noqa: N802 - pyqtgraph API
        if self.tool is Tool.NAVIGATE or ev.button() != Qt.MouseButton.LeftButton:
            super().mouseDragEvent(ev, axis)
            return
        ev.accept()
        here = self.mapSceneToView(ev.scenePos())
        if ev.isStart():
            self._start = self.mapSceneToView(ev.buttonDownScenePos())
            self._points = [(self._start.x(), self._start.y())]
        self._points.append((here.x(), here.y()))
        if self.tool.draws_rect:
            self.rectDragged.emit(QRectF(self._start, here).normalized(), ev.isFinish())
        else:
            self.pathDragged.emit(np.array(self._points, dtype=np.float64), ev.isFinish())

    def mouseClickEvent(self, ev) -> None:  # noqa: N802 - pyqtgraph API
        if self.tool is Tool.NAVIGATE or ev.button() != Qt.MouseButton.LeftButton:
            super().mouseClickEvent(ev)
            return
        ev.accept()
        here = self.mapSceneToView(ev.scenePos())
        if self.tool.draws_rect:
            self.rectClicked.emit(here)
        else:
            self.pathDragged.emit(np.array([[here.x(), here.y()]]), True)
