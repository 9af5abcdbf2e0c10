"""The footage with its overlays: silhouette tint, ROI window, rectangles, strokes, brush
strokes, onion skin, and the first frame's cut-out before the clip is segmented.

Frames are decoded by a :class:`app.workers.FrameLoader` (latest request wins); the image and
the overlays of one frame are always shown together. Drawing on the frame (rectangles,
strokes, erasing) pushes commands on the undo stack.
"""

from __future__ import annotations

import cv2
import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QPainterPath, QPen
from PySide6.QtWidgets import QGraphicsPathItem, QGraphicsRectItem, QVBoxLayout, QWidget

from app.commands import (
    AddRectCommand,
    AddStrokesCommand,
    EraseStrokesCommand,
    RemoveRectCommand,
    SetBoxCommand,
)
from app.state import AppState
from app.widgets.frame_canvas import CanvasViewBox, Tool
from app.workers import FrameLoader
from gaitcore.errors import GaitInputError
from gaitcore.silhouettes.annotations import Rect, Scribble, Stroke

TINT_RGBA = (0, 190, 255, 100)
SUBJECT_COLOUR = QColor(40, 200, 60)
BACKGROUND_COLOUR = QColor(220, 40, 200)
BOX_COLOUR = QColor(255, 140, 0)
STROKE_COLOUR = QColor(255, 200, 0)
ONION_COLOUR = QColor(0, 160, 255, 110)
ERASE_COLOUR = QColor(255, 40, 40)
_ERASE_RADIUS_PX = 3.0


def _path_item(points_xy: np.ndarray, width: float, colour: QColor) -> QGraphicsPathItem:
    """A polyline drawn with a round pen ``width`` image pixels wide (scales with zoom)."""
    path = QPainterPath(QPointF(*points_xy[0]))
    if len(points_xy) == 1:
        path.lineTo(QPointF(*points_xy[0]))
    for x, y in points_xy[1:]:
        path.lineTo(QPointF(x, y))
    item = QGraphicsPathItem(path)
    pen = QPen(colour, width, Qt.PenStyle.SolidLine, Qt.PenCapStyle.RoundCap,
               Qt.PenJoinStyle.RoundJoin)
    item.setPen(pen)
    return item


def _rect_item(rect: QRectF, colour: QColor, dashed: bool = False) -> QGraphicsRectItem:
    item = QGraphicsRectItem(rect)
    pen = QPen(colour, 2, Qt.PenStyle.DashLine if dashed else Qt.PenStyle.SolidLine)
    pen.setCosmetic(True)
    item.setPen(pen)
    fill = QColor(colour)
    fill.setAlpha(0 if dashed else 40)
    item.setBrush(QBrush(fill))
    return item


class FrameView(QWidget):
    """The current frame of the footage with everything drawn on it.

    Signals
    -------
    frameShown(int)
        Frame ``i`` and its overlays are now on screen.
    messageRaised(str)
        A one-line message for the status bar.
    scribblePainted(Scribble)
        A subject or background brush stroke was painted on the current frame (the tools
        decide whether it re-propagates the segmentation).
    scribblesErased(set, tuple)
        The eraser went over brush strokes of the current frame: their positions in the
        project's scribbles, and the sketch strokes the same drag went over (the tools remove
        both as one undo step and re-propagate).
    """

    frameShown = Signal(int)
    messageRaised = Signal(str)
    scribblePainted = Signal(object)
    scribblesErased = Signal(object, object)

    def __init__(self, state: AppState, loader: FrameLoader, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._loader = loader
        self.canvas = CanvasViewBox()
        self._view = pg.GraphicsView(background=QColor(30, 30, 30))
        self._view.setCentralItem(self.canvas)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self._view)
        self.setMinimumSize(400, 300)
        self._image = pg.ImageItem()
        self._tint = pg.ImageItem()
        self._tint.setZValue(1)
        self.canvas.addItem(self._image)
        self.canvas.addItem(self._tint)
        self._window = _rect_item(QRectF(), QColor(255, 230, 0), dashed=True)
        self._window.setZValue(2)
        self.canvas.addItem(self._window)
        self._overlays: list = []
        self._live: list = []
        self._erasing: set[int] = set()  # strokes under the eraser
        self._erasing_brush: set[int] = set()  # brush strokes under the eraser
        self._pending: tuple[Scribble, ...] = ()
        self._pending_erase: tuple[Scribble, ...] = ()
        self._pending_erase_strokes: set[int] = set()  # ids of sketch strokes erased with them
        self._preview: np.ndarray | None = None
        self._shown = -1
        self._size: tuple[int, int] | None = None
        self.pen_width_px = 6.0
        self.show_silhouette = True
        self.show_onion = True
        state.frameChanged.connect(self._request)
        state.sourceChanged.connect(self._on_source)
        state.projectChanged.connect(self._draw_overlays)
        loader.frameLoaded.connect(self._on_loaded)
        loader.loadFailed.connect(lambda _i, message: self.messageRaised.emit(message))
        self.canvas.rectDragged.connect(self._on_rect_dragged)
        self.canvas.rectClicked.connect(self._on_rect_clicked)
        self.canvas.pathDragged.connect(self._on_path_dragged)

    # -- public ---------------------------------------------------------------------------
    @property
    def shown_frame(self) -> int:
        """The frame on screen (-1 before the first)."""
        return self._shown

    def set_tool(self, tool: Tool) -> None:
        self.canvas.tool = tool
        self._clear_live()
        if tool.draws_rect and self._state.frame != 0:
            self._state.set_frame(0)
            self.messageRaised.emit("Rectangles are drawn on the first frame (paper Section 2.2)")

    def set_overlays(self, *, silhouette: bool | None = None, onion: bool | None = None) -> None:
        """Show or hide the silhouette tint and the onion skin of the previous frame."""
        if silhouette is not None:
            self.show_silhouette = silhouette
        if onion is not None:
            self.show_onion = onion
        self._draw_overlays()

    def set_pending(self, scribbles: tuple[Scribble, ...]) -> None:
        """Brush strokes painted but not yet in the project (a correction is running)."""
        self._pending = tuple(scribbles)
        self._draw_overlays()

    def set_erasing(self, scribbles: tuple[Scribble, ...], strokes: tuple[Stroke, ...] = ()
                    ) -> None:
        """Brush strokes of the project being erased, and sketch strokes erased with them,
        drawn red (their job is running)."""
        self._pending_erase = tuple(scribbles)
        self._pending_erase_strokes = {id(s) for s in strokes}
        self._draw_overlays()

    def set_preview(self, mask: np.ndarray | None) -> None:
        """The first frame's cut-out, (rows, cols) bool, shown on frame 0 while the clip has
        no silhouettes (None: none)."""
        self._preview = mask
        self._draw_overlays()

    @property
    def preview(self) -> np.ndarray | None:
        """The first frame's cut-out shown before the clip is segmented (None: none)."""
        return self._preview

    def image_item(self) -> pg.ImageItem:
        """The footage image item (for tests and benchmarks)."""
        return self._image

    # -- frames ---------------------------------------------------------------------------
    def _on_source(self, source) -> None:
        self._loader.set_source(source)
        self._size = None
        if source is None:
            self._image.clear()
        self._request(self._state.frame)

    def _request(self, frame: int) -> None:
        if self._state.source is not None:
            self._loader.request(frame)
        else:
            self._show(frame)

    def _on_loaded(self, frame: int, image: np.ndarray) -> None:
        self._image.setImage(cv2.cvtColor(image, cv2.COLOR_BGR2RGB), autoLevels=False,
                             levels=(0, 255))
        size = (image.shape[1], image.shape[0])
        if size != self._size:
            self._size = size
            self.canvas.setRange(QRectF(0, 0, *size), padding=0.02)
        self._show(frame)

    def _show(self, frame: int) -> None:
        self._shown = frame
        self._draw_overlays()
        self.frameShown.emit(frame)

    # -- overlays -------------------------------------------------------------------------
    def _draw_overlays(self, *_changed) -> None:
        for item in self._overlays:
            self.canvas.removeItem(item)
        self._overlays = []
        project, frame = self._state.project, self._shown
        if frame < 0:
            return
        self._draw_silhouette(frame)
        box = () if project.box is None or frame != 0 else (project.box,)
        rects_0 = (project.subject_rects, project.background_rects) if frame == 0 else ((), ())
        for rects, colour in ((box, BOX_COLOUR), (rects_0[0], SUBJECT_COLOUR),
                              (rects_0[1], BACKGROUND_COLOUR)):  # first-frame annotations
            for r in rects:
                self._add_overlay(_rect_item(QRectF(r.x, r.y, r.w, r.h), colour), 3)
        if self.show_onion and frame > 0:
            for s in project.strokes_on(frame - 1):
                self._add_overlay(_path_item(s.points_xy, s.width_px, ONION_COLOUR), 3)
        for i, s in enumerate(project.strokes):
            if s.frame == frame:
                erasing = i in self._erasing or id(s) in self._pending_erase_strokes
                colour = ERASE_COLOUR if erasing else STROKE_COLOUR
                self._add_overlay(_path_item(s.points_xy, s.width_px, colour), 4)
        for i, sc in enumerate(project.scribbles):
            if sc.frame == frame:
                erasing = i in self._erasing_brush or sc in self._pending_erase
                colour = ERASE_COLOUR if erasing else _brush_colour(sc.label)
                self._add_overlay(_path_item(sc.points_xy, sc.width_px, colour), 4)
        for sc in self._pending:
            if sc.frame == frame:
                self._add_overlay(_path_item(sc.points_xy, sc.width_px, _brush_colour(sc.label)), 4)

    def _add_overlay(self, item, z: float) -> None:
        item.setZValue(z)
        self.canvas.addItem(item)
        self._overlays.append(item)

    def _draw_silhouette(self, frame: int) -> None:
        sil = self._state.project.silhouettes
        box = None if sil is None or frame >= sil.n_frames else sil.window_xywh(frame)
        self._window.setVisible(box is not None)
        self._tint.setVisible(box is not None and self.show_silhouette)
        if box is None:
            self._draw_preview(frame, sil is None)
            return
        rect = QRectF(*box)
        self._window.setRect(rect)
        if self.show_silhouette:
            self._show_tint(_smooth_upscale(sil.roi.crops[frame], box[2], box[3]), rect)

    def _draw_preview(self, frame: int, unsegmented: bool) -> None:
        """The first frame's cut-out (before the clip is segmented), full frame."""
        mask = self._preview
        if mask is None or frame != 0 or not unsegmented or not self.show_silhouette:
            return
        self._show_tint(mask, QRectF(0, 0, mask.shape[1], mask.shape[0]))
        self._tint.setVisible(True)

    def _show_tint(self, mask: np.ndarray, rect: QRectF) -> None:
        """Tint ``mask`` (rows, cols) bool, laid over ``rect`` of the frame."""
        rgba = np.zeros(mask.shape + (4,), np.uint8)
        rgba[mask] = TINT_RGBA
        self._tint.setImage(rgba, autoLevels=False, levels=(0, 255))
        self._tint.setRect(rect)

    # -- drawing --------------------------------------------------------------------------
    def _clear_live(self) -> None:
        for item in self._live:
            self.canvas.removeItem(item)
        self._live = []
        if self._erasing or self._erasing_brush:
            self._erasing, self._erasing_brush = set(), set()
            self._draw_overlays()

    def _set_live(self, item) -> None:
        self._clear_live()
        item.setZValue(5)
        self.canvas.addItem(item)
        self._live = [item]

    def _on_rect_dragged(self, rect: QRectF, finished: bool) -> None:
        tool = self.canvas.tool
        subject = tool is Tool.SUBJECT
        if not finished:
            colour = {Tool.BOX: BOX_COLOUR,
                      Tool.SUBJECT: SUBJECT_COLOUR}.get(tool, BACKGROUND_COLOUR)
            self._set_live(_rect_item(rect, colour))
            return
        self._clear_live()
        if rect.width() < 2 or rect.height() < 2 or self._state.n_frames == 0:
            return
        try:
            r = Rect.from_corners(rect.left(), rect.top(), rect.right(), rect.bottom())
            if self._size is not None:
                r = r.clipped_to(*self._size)
        except GaitInputError as exc:
            self.messageRaised.emit(str(exc))
            return
        if tool is Tool.BOX:
            self._state.undo_stack.push(SetBoxCommand(self._state, r))
        else:
            self._state.undo_stack.push(AddRectCommand(self._state, r, subject=subject))

    def _on_rect_clicked(self, xy: QPointF) -> None:
        """A click inside a rectangle removes it (the last drawn one on top)."""
        project = self._state.project
        box = () if project.box is None else (project.box,)
        for r in reversed(box + project.subject_rects + project.background_rects):
            if r.x <= xy.x() < r.x + r.w and r.y <= xy.y() < r.y + r.h:
                self._state.undo_stack.push(RemoveRectCommand(self._state, r))
                return

    def _on_path_dragged(self, points: np.ndarray, finished: bool) -> None:
        frame = self._state.frame
        if self._state.n_frames == 0:
            return
        if self.canvas.tool is Tool.ERASE:
            self._erase(frame, points[-1], finished)
            return
        label = self.canvas.tool.brush_label
        if not finished:
            colour = STROKE_COLOUR if label is None else _brush_colour(label)
            self._set_live(_path_item(points, self.pen_width_px, colour))
            return
        self._clear_live()
        if label is not None:
            self.scribblePainted.emit(Scribble(_thin(points), self.pen_width_px, frame, label))
            return
        stroke = Stroke(_thin(points), self.pen_width_px, frame)
        self._state.undo_stack.push(AddStrokesCommand(self._state, [stroke]))

    def _erase(self, frame: int, xy: np.ndarray, finished: bool) -> None:
        """Strokes and brush strokes under the eraser turn red; on release they are erased as
        one undo step: by the tools when the drag went over brush strokes (their erasing may
        re-propagate the segmentation), here otherwise."""
        project = self._state.project
        hits = self._erasing | project.strokes_hit(frame, xy, _ERASE_RADIUS_PX)
        brush = self._erasing_brush | project.scribbles_hit(frame, xy, _ERASE_RADIUS_PX)
        if finished:
            self._erasing, self._erasing_brush = set(), set()
            self._draw_overlays()
            if brush:
                strokes = project.strokes
                self.scribblesErased.emit(brush, tuple(strokes[i] for i in sorted(hits)))
            elif hits:
                self._state.undo_stack.push(EraseStrokesCommand(self._state, hits))
        elif (hits, brush) != (self._erasing, self._erasing_brush):
            self._erasing, self._erasing_brush = hits, brush
            self._draw_overlays()


def _brush_colour(label: str) -> QColor:
    """Subject strokes green, background strokes magenta, see-through."""
    colour = QColor(SUBJECT_COLOUR if label == "subject" else BACKGROUND_COLOUR)
    colour.setAlpha(170)
    return colour


def _thin(points: np.ndarray, min_step_px: float = 1.0) -> np.ndarray:
    """Drop points closer than ``min_step_px`` to the previous kept one (mouse jitter)."""
    kept = [points[0]]
    for p in points[1:]:
        if np.hypot(*(p - kept[-1])) >= min_step_px:
            kept.append(p)
    return np.array(kept)


TINT_MAX_SIDE = 512
"""Longest side of the tint image: the crops (160 px) are upscaled to the window's size up to
this, so that the silhouette's outline on HD footage is smooth rather than blocky."""


def _smooth_upscale(crop: np.ndarray, width: float, height: float) -> np.ndarray:
    """``crop`` (bool) resampled bilinearly to the window's size (capped) and thresholded."""
    rows, cols = crop.shape
    scale = min(width / cols, height / rows, TINT_MAX_SIDE / max(rows, cols))
    if scale <= 1.0:
        return crop
    size = (max(1, round(cols * scale)), max(1, round(rows * scale)))
    return cv2.resize(crop.astype(np.float32), size, interpolation=cv2.INTER_LINEAR) > 0.5
