"""The timeline scrubber: one row of frames with marks for keys, alternates and lost frames.

Clicking or dragging moves the current frame. Marks: key-images (orange triangles above the
track; the selected key outlined in red), proposed alternates (cyan outlines), accepted
alternates (cyan triangles), pinned keys (a dot), dropped keys (a grey cross), lost frames (red
ticks: the segmentation lost the subject there), frames the analysis left out because the
animal is only partly in view there (blue hatching; right-click one to analyse it anyway,
or to leave it out again), frames to check (faint red ticks: the
segmentation's confidence is low there, :attr:`~gaitcore.silhouettes.roto.FrameState.to_check`),
frames corrected with the subject or background brush (violet bars across the track, with a
violet diamond under it), sketched frames (yellow ticks under the track).

The trim (the in and out marks, set with I and O) darkens the frames outside it and has a
handle at each end that can be dragged (one undo step per drag). Under the track, green bars
are the stretches of steady gait the analysis found (brighter: higher r); right-click one to
trim to it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from PySide6.QtCore import QPointF, QRectF, QSize, Qt
from PySide6.QtGui import QBrush, QColor, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QMenu, QSizePolicy, QWidget

from app.commands import BringBackCommand, TrimCommand
from app.state import AppState

KEY_COLOUR = QColor(255, 140, 0)
ALTERNATE_COLOUR = QColor(0, 170, 220)
LOST_COLOUR = QColor(220, 30, 30)
CHECK_COLOUR = QColor(220, 30, 30, 110)
SKETCH_COLOUR = QColor(230, 190, 0)
CORRECTED_COLOUR = QColor(175, 110, 255)
LEFT_OUT_COLOUR = QColor(90, 150, 255)
CURSOR_COLOUR = QColor(200, 0, 0)
TRIM_COLOUR = QColor(250, 250, 250)
OUTSIDE_SHADE = QColor(0, 0, 0, 150)
CYCLE_COLOUR = QColor(40, 180, 80)
_MARGIN = 12
_LABEL_W = 90
_GRAB_PX = 6
_CYCLE_ROW = 14  # height of the row of steady-gait bars under the track


class TimelineWidget(QWidget):
    """A painted scrubber bound to :class:`AppState`."""

    def __init__(self, state: AppState, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self.setMinimumHeight(76)
        self._drag: tuple[str, int] | None = None  # ("in" or "out", frame) while dragging
        self.frames_to_check: Callable[[], Sequence[int]] = tuple
        """The frames the segmentation says are worth a look (set by the main window)."""
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        self.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        self.setToolTip("Click or drag to move through the clip")
        for signal in (state.frameChanged, state.projectChanged, state.analysisChanged,
                       state.sourceChanged, state.selectedKeyChanged):
            signal.connect(self._repaint)

    def _repaint(self, *_changed) -> None:
        self.update()

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt API
        return QSize(600, 76)

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

    # -- trim and cycles -------------------------------------------------------------------
    def trim_range(self) -> tuple[int, int]:
        """Source frames ``start, stop`` of the trim as shown (a handle being dragged counts)."""
        start, stop = self._committed_trim()
        if self._drag is not None:
            side, frame = self._drag
            start, stop = ((min(frame, stop - 1), stop) if side == "in"
                           else (start, max(frame + 1, start + 1)))
        return start, stop

    def _committed_trim(self) -> tuple[int, int]:
        """The project's trim within the footage, stop as a number."""
        start, stop = self._state.project.trim
        n = self._state.n_frames
        return min(start, max(0, n - 1)), n if stop is None else min(stop, n)

    def cycles(self) -> list[tuple[int, int, float, float]]:
        """Stretches of steady gait: (start, stop, period_frames, min r), source frames."""
        analysis = self._state.analysis
        if analysis is None:
            return []
        off = analysis.cycle_offset
        return [(c.start + off, c.stop + off, c.period_frames, min(c.r1, c.r2))
                for c in analysis.cycles]

    def left_out(self) -> tuple[int, ...]:
        """Source frames the analysis left out (the animal only partly in view)."""
        analysis = self._state.analysis
        return () if analysis is None else analysis.partial_frames

    def cycle_at(self, x: float) -> tuple[int, int, float, float] | None:
        frame = self.frame_at(x)
        return next((c for c in self.cycles() if c[0] <= frame < c[1]), None)

    def trim_to(self, start: int, stop: int, text: str = "trim to a stretch") -> None:
        """Trim to source frames ``start <= f < stop`` (one undo step)."""
        n = self._state.n_frames
        self._state.undo_stack.push(TrimCommand(self._state, start, None if stop >= n else stop,
                                                text))

    def _handle_near(self, x: float) -> str | None:
        start, stop = self.trim_range()
        if abs(x - self._edge_x(start)) <= _GRAB_PX:
            return "in"
        if abs(x - self._edge_x(stop)) <= _GRAB_PX:
            return "out"
        return None

    def _edge_x(self, frame: int) -> float:
        """Position of the left edge of ``frame`` (``frame == n``: the right end)."""
        return self.x_of(frame) - 0.5 * self._track().width() / max(1, self._state.n_frames)

    # -- events ---------------------------------------------------------------------------
    def mousePressEvent(self, event) -> None:  # noqa: N802 - Qt API
        if not self._state.n_frames:
            return
        x = event.position().x()
        if event.button() == Qt.MouseButton.RightButton:
            self.context_menu(x).exec(event.globalPosition().toPoint())
        elif event.button() == Qt.MouseButton.LeftButton:
            side = self._handle_near(x)
            if side is not None:
                self._drag = (side, self.frame_at(x) if side == "in" else self.frame_at(x - 1))
                self.update()
            else:
                self._state.set_frame(self.frame_at(x))

    def mouseMoveEvent(self, event) -> None:  # noqa: N802 - Qt API
        if event.buttons() & Qt.MouseButton.LeftButton and self._state.n_frames:
            frame = self.frame_at(event.position().x())
            if self._drag is not None:
                self._drag = (self._drag[0], frame)
                self.update()
            else:
                self._state.set_frame(frame)

    def mouseReleaseEvent(self, event) -> None:  # noqa: N802 - Qt API
        if self._drag is not None and event.button() == Qt.MouseButton.LeftButton:
            start, stop = self.trim_range()
            side = self._drag[0]
            self._drag = None
            if (start, stop) != self._committed_trim():
                self.trim_to(start, stop, f"move the {side} mark")
            self.update()

    def context_menu(self, x: float) -> QMenu:
        """The right-click menu at widget position ``x``: trim to the stretch of steady gait
        under it, or clear the marks."""
        cycle = self.cycle_at(x)
        menu = QMenu(self)
        frame = self.frame_at(x)
        run = _run_around(frame, self.left_out())
        back = _run_around(frame, self._state.project.settings.bring_back)
        if run:
            menu.addAction(f"Analyse {_frames_text(run)} anyway (the animal is only partly in "
                           "view)", lambda: self._state.undo_stack.push(
                               BringBackCommand(self._state, run)))
        elif back:
            menu.addAction(f"Leave {_frames_text(back)} out again",
                           lambda: self._state.undo_stack.push(
                               BringBackCommand(self._state, back, back=False)))
        if cycle is not None:
            start, stop = cycle[0], cycle[1]
            menu.addAction(f"Trim to this stretch (frames {start}–{stop - 1})",
                           lambda: self.trim_to(start, stop))
        menu.addAction("Clear the in and out marks", lambda: self.trim_to(0, self._state.n_frames,
                                                                         "clear the trim"))
        return menu

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
        self._paint_cycles(p, track)
        self._paint_trim(p, track, n)
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
        project = self._state.project
        left_out = set(self.left_out())
        lost = []
        if project.silhouettes is not None:
            lost = [int(f) for f in project.silhouettes.roi.lost.nonzero()[0]]
        width = max(2.0, track.width() / n)
        hatch = QBrush(LEFT_OUT_COLOUR, Qt.BrushStyle.BDiagPattern)
        for f in left_out:
            rect = QRectF(self.x_of(f) - width / 2, track.top(), width, track.height())
            p.fillRect(rect, QColor(LEFT_OUT_COLOUR.red(), LEFT_OUT_COLOUR.green(),
                                    LEFT_OUT_COLOUR.blue(), 90))
            p.fillRect(rect, hatch)
        for f in self.frames_to_check():
            p.fillRect(QRectF(self.x_of(f) - width / 2, track.top(), width, track.height()),
                       CHECK_COLOUR)
        for f in lost:
            p.fillRect(QRectF(self.x_of(f) - width / 2, track.top(), width, track.height()),
                       LOST_COLOUR)
        for f in project.sketched_frames():
            p.fillRect(QRectF(self.x_of(f) - width / 2, track.bottom() + 2, width, 4),
                       SKETCH_COLOUR)
        self._paint_corrected(p, track, width)

    def _paint_corrected(self, p: QPainter, track: QRectF, width: float) -> None:
        """Frames that carry brush strokes: a bar across the track and a diamond under it."""
        p.setPen(Qt.PenStyle.NoPen)
        p.setBrush(CORRECTED_COLOUR)
        for f in self._state.project.corrected_frames():
            x = self.x_of(f)
            p.fillRect(QRectF(x - max(width, 3.0) / 2, track.top(), max(width, 3.0),
                              track.height()),
                       CORRECTED_COLOUR)
            y = track.bottom() + 4  # above the row of steady-gait bars
            p.drawPolygon(QPolygonF([QPointF(x, y - 4), QPointF(x + 3.5, y),
                                     QPointF(x, y + 3.5), QPointF(x - 3.5, y)]))

    def _paint_trim(self, p: QPainter, track: QRectF, n: int) -> None:
        start, stop = self.trim_range()
        left, right = self._edge_x(start), self._edge_x(stop)
        p.fillRect(QRectF(track.left(), track.top(), left - track.left(), track.height()),
                   OUTSIDE_SHADE)
        p.fillRect(QRectF(right, track.top(), track.right() - right, track.height()), OUTSIDE_SHADE)
        if (start, stop) == (0, n):
            return
        p.setPen(QPen(TRIM_COLOUR, 2))
        for x, sign in ((left, 1), (right, -1)):  # brackets: [ at the in mark, ] at the out mark
            p.drawLine(QPointF(x, track.top() - 3), QPointF(x, track.bottom() + 3))
            p.drawLine(QPointF(x, track.top() - 3), QPointF(x + 4 * sign, track.top() - 3))
            p.drawLine(QPointF(x, track.bottom() + 3), QPointF(x + 4 * sign, track.bottom() + 3))

    def _paint_cycles(self, p: QPainter, track: QRectF) -> None:
        top = track.bottom() + 8
        for start, stop, period, r in self.cycles():
            colour = QColor(CYCLE_COLOUR)
            colour.setAlpha(int(90 + 165 * max(0.0, min(1.0, (r - 0.4) / 0.6))))
            left, right = self._edge_x(start), self._edge_x(stop)
            bar = QRectF(left, top, max(2.0, right - left), _CYCLE_ROW)
            p.fillRect(bar, colour)
            p.setPen(QColor(255, 255, 255))
            p.drawText(bar.adjusted(3, 0, 0, 0),
                       Qt.AlignmentFlag.AlignVCenter | Qt.AlignmentFlag.AlignLeft,
                       f"cycle {period:.0f} f, r {r:.2f}")

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
    p.drawPolygon(QPolygonF([QPointF(x - 5, bottom - 9), QPointF(x + 5, bottom - 9),
                             QPointF(x, bottom)]))


def _run_around(frame: int, frames: Sequence[int]) -> tuple[int, ...]:
    """The run of consecutive ``frames`` that holds ``frame`` (empty when it is not one)."""
    have = set(frames)
    if frame not in have:
        return ()
    lo, hi = frame, frame
    while lo - 1 in have:
        lo -= 1
    while hi + 1 in have:
        hi += 1
    return tuple(range(lo, hi + 1))


def _frames_text(frames: tuple[int, ...]) -> str:
    return f"frame {frames[0]}" if len(frames) == 1 else f"frames {frames[0]}–{frames[-1]}"
