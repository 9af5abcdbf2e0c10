"""The timeline scrubber: one row of frames with marks for keys, alternates and lost frames.

Clicking or dragging moves the current frame. Marks: key-images (orange triangles above the
track; the selected key outlined in red), proposed alternates (cyan outlines), accepted alternates (cyan triangles), pinned
keys (a dot), dropped keys (a grey cross), lost frames (red ticks), sketched frames (yellow
ticks under the track).
"""

from __future__ import annotations

from PySide6.QtCore import QPointF, QRectF, QSize, Qt
from PySide6.QtGui import QColor, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QSizePolicy, QWidget

from app.state import AppState

KEY_COLOUR = QColor(255, 140, 0)
ALTERNATE_COLOUR = QColor(0, 170, 220)
LOST_COLOUR = QColor(220, 30, 30)
SKETCH_COLOUR = QColor(230, 190, 0)
CURSOR_COLOUR = QColor(200, 0, 0)
_MARGIN = 12
_LABEL_W = 90


class TimelineWidget(QWidget):
    """A painted scrubber bound to :class:`AppState`."""

    def __init__(self, state: AppState, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self.setMinimumHeight(56)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        self.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        self.setToolTip("Click or drag to move through the clip")
        for signal in (state.frameChanged, state.projectChanged, state.analysisChanged,
                       state.sourceChanged, state.selectedKeyChanged):
            signal.connect(self._repaint)

    def _repaint(self, *_changed) -> None:
        self.update()

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt API
        return QSize(600, 56)

    # -- geometry -------------------------------------------------------------------------
    def _track(self) -> QRectF:
        return QRectF(_MARGIN, 18, max(1, self.width() - 2 * _MARGIN - _LABEL_W), 18)

    def x_of(self, frame: int) -> float:
        """Horizontal position of the centre of ``frame``, in widget pixels."""
        n = max(1, self._state.n_frames)
        track = self._track()
        return track.left() + (frame + 0.5) * track.width() / n

    def frame_at(self, x: float) -> int:
        """The frame under widget position ``x`` (clamped to the clip)."""
        n = self._state.n_frames
        track = self._track()
        return max(0, min(n - 1, int((x - track.left()) / track.width() * n)))

    # -- events ---------------------------------------------------------------------------
    def mousePressEvent(self, event) -> None:  # noqa: N802 - Qt API
        if event.button() == Qt.MouseButton.LeftButton and self._state.n_frames:
            self._state.set_frame(self.frame_at(event.position().x()))

    def mouseMoveEvent(self, event) -> None:  # noqa: N802 - Qt API
        if event.buttons() & Qt.MouseButton.LeftButton and self._state.n_frames:
            self._state.set_frame(self.frame_at(event.position().x()))

    def paintEvent(self, event) -> None:  # noqa: N802 - Qt API
        p = QPainter(self)
        p.setRenderHint(QPainter.RenderHint.Antialiasing)
        p.fillRect(self.rect(), self.palette().window())
        track = self._track()
        p.fillRect(track, QColor(70, 70, 70))
        n = self._state.n_frames
        if n == 0:
            p.setPen(self.palette().text().color())
            p.drawText(track, Qt.AlignmentFlag.AlignCenter, "no footage: File > Open")
            return
        self._paint_ticks(p, track, n)
        self._paint_marks(p, track)
        x = self.x_of(self._state.frame)
        p.setPen(QPen(CURSOR_COLOUR, 2))
        p.drawLine(QPointF(x, track.top() - 4), QPointF(x, track.bottom() + 4))
        p.setPen(self.palette().text().color())
        label = QRectF(track.right() + 8, track.top() - 4, _LABEL_W - 8, track.height() + 8)
        p.drawText(label, Qt.AlignmentFlag.AlignVCenter | Qt.AlignmentFlag.AlignLeft,
                   f"{self._state.frame} / {n - 1}")
        p.end()

    def _paint_ticks(self, p: QPainter, track: QRectF, n: int) -> None:
        step = max(1, 10 ** len(str(n)) // 20)
        p.setPen(QPen(QColor(150, 150, 150), 1))
        for f in range(0, n, step):
            x = self.x_of(f)
            p.drawLine(QPointF(x, track.bottom() - 4), QPointF(x, track.bottom()))
        project, analysis = self._state.project, self._state.analysis
        lost = analysis.lost_frames if analysis is not None else ()
        if not lost and project.silhouettes is not None:
            lost = [int(f) for f in project.silhouettes.roi.lost.nonzero()[0]]
        width = max(2.0, track.width() / n)
        for f in lost:
            p.fillRect(QRectF(self.x_of(f) - width / 2, track.top(), width, track.height()), LOST_COLOUR)
        for f in project.sketched_frames():
            p.fillRect(QRectF(self.x_of(f) - width / 2, track.bottom() + 2, width, 4), SKETCH_COLOUR)

    def _paint_marks(self, p: QPainter, track: QRectF) -> None:
        project, analysis = self._state.project, self._state.analysis
        settings = project.settings
        top = track.top()
        if analysis is not None:
            for f in analysis.key_frames:
                _triangle(p, self.x_of(f), top, KEY_COLOUR, filled=True)
            if self._state.selected_key >= 0:
                _triangle(p, self.x_of(self._state.selected_key), top, CURSOR_COLOUR, filled=False)
            for f in analysis.alternate_frames or ():
                _triangle(p, self.x_of(f), top, ALTERNATE_COLOUR, filled=f in project.alternates)
        for f in project.alternates:
            _triangle(p, self.x_of(f), top, ALTERNATE_COLOUR, filled=True)
        p.setPen(Qt.PenStyle.NoPen)
        p.setBrush(KEY_COLOUR.darker(150))
        for f in settings.pinned:
            p.drawEllipse(QPointF(self.x_of(f), top - 13), 3, 3)
        p.setPen(QPen(QColor(120, 120, 120), 2))
        for f in settings.forbidden:
            x = self.x_of(f)
            p.drawLine(QPointF(x - 4, top - 17), QPointF(x + 4, top - 9))
            p.drawLine(QPointF(x - 4, top - 9), QPointF(x + 4, top - 17))


def _triangle(p: QPainter, x: float, bottom: float, colour: QColor, *, filled: bool) -> None:
    """A small downward triangle whose tip touches the track at ``x``."""
    p.setPen(QPen(colour, 1.5))
    p.setBrush(colour if filled else Qt.BrushStyle.NoBrush)
    p.drawPolygon(QPolygonF([QPointF(x - 5, bottom - 9), QPointF(x + 5, bottom - 9), QPointF(x, bottom)]))
