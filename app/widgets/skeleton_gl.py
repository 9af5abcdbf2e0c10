"""The OpenGL scene of the pose viewport: bones, joints, footage plane, ground grid, overlays.

:class:`SkeletonGLView` is pyqtgraph's GL view (orbit with the left button, pan with the
middle button or Ctrl, zoom with the wheel towards the cursor, F frames the rig) on a
``QOpenGLWindow``, embedded in the widgets with ``QWidget.createWindowContainer``. Not a
``QOpenGLWidget``: with one of those in it, Qt composites the whole main window through
OpenGL at every repaint of any widget, which costs about 35 ms per frame on a software
renderer (llvmpipe) and would halve playback.

The skeleton lives in gaitcore's frame (Y up, X forward, side camera on +Z); pyqtgraph's is
Z up, so every item is drawn through :data:`Y_UP_TO_GL` (a rotation of +90 degrees about X).
Each bone is one unit-sphere mesh whose item transform carries it, so a new pose only sets
40-odd 4x4 matrices. Bones are translucent by default (the footage shows through them) and
tinted by side (:mod:`app.widgets.sides`); the stick figure of joints and links is drawn on
top. Overlays: the key-image's silhouette outline over the footage and an onion skin of the
neighbouring keys' poses.

Joints are picked without GL picking: their positions are projected with the view's own
projection and view matrices (:meth:`SkeletonGLView.project`) and the nearest within
:data:`PICK_RADIUS_PX` wins; the joint under the cursor is highlighted before any click.
Pressing on an end (a joint without children: toe, head end, tail tip) and dragging moves it
in the view's plane (``endDragged``, for IK); pressing on any other joint and dragging rotates
it about the view axis; pressing elsewhere orbits as usual.
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph.opengl as gl
from OpenGL import GL
from pyqtgraph.opengl.GLViewWidget import GLViewMixin
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QImage, QVector3D
from PySide6.QtOpenGL import QOpenGLFramebufferObject, QOpenGLWindow

from app.widgets.gl_support import (  # noqa: F401 - share_gl_resources, opengl_available: API
    BLEND_KEEP_ALPHA,
    HEADLIGHT_SHADER,
    ON_TOP,
    numpy_matrix,
    opengl_available,
    qmatrix,
    share_gl_resources,
)
from app.widgets.sides import side_rgba
from gaitcore.rig.skeleton import Skeleton

PICK_RADIUS_PX = 9.0
DRAG_START_PX = 12.0
Y_UP_TO_GL = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
"""gaitcore world (Y up) -> pyqtgraph world (Z up): (x, y, z) -> (x, -z, y)."""
VIEWS = {"side": (0.0, -90.0), "front": (0.0, 0.0), "back": (0.0, 180.0), "top": (89.9, -90.0)}
"""Camera presets as (elevation, azimuth) in pyqtgraph's degrees; side = from gaitcore's +Z."""
FOV_DEG = 30.0
BACKGROUND_RGB = (62, 66, 72)
SELECTED_RGBA = (1.0, 0.85, 0.0, 1.0)
"""Yellow: neither side's colour."""
HOVER_RGBA = (1.0, 1.0, 1.0, 1.0)
SIDE_TINT = 0.65
"""Share of the side colour mixed into the colour of a left or right bone."""
DEFAULT_BONE_OPACITY = 0.35
FRAME_FILL = 0.85
"""Share of the view's width or height the rig fills when framed (F)."""
ONION_RGBA = ((0.55, 0.25, 0.75, 0.7), (0.75, 0.55, 0.05, 0.7))
"""Previous (purple) and next (amber) key's pose in the onion skin: not the sides' colours."""
OUTLINE_RGBA = (0.2, 1.0, 0.35, 0.9)
SEE_THROUGH = {GL.GL_DEPTH_TEST: True, GL.GL_BLEND: True, GL.GL_CULL_FACE: True,
               "glCullFace": (GL.GL_BACK,), "glBlendFuncSeparate": BLEND_KEEP_ALPHA,
               "glDepthMask": (GL.GL_FALSE,)}
"""Translucent bones that hide nothing behind them: no depth writes (STICK items, drawn after
them, turn depth writes back on for the next frame's clear), front faces only, so that each
ellipsoid darkens the footage once."""
STICK = dict(ON_TOP, glDepthMask=(GL.GL_TRUE,))
OPAQUE = {GL.GL_DEPTH_TEST: True, GL.GL_BLEND: False, GL.GL_CULL_FACE: False}


def to_gl(xyz: np.ndarray) -> QVector3D:
    """A gaitcore-frame point as a pyqtgraph-frame vector."""
    x, y, z = (float(v) for v in xyz)
    return QVector3D(x, -z, y)


def from_gl(v: QVector3D) -> np.ndarray:
    """A pyqtgraph-frame vector as a gaitcore-frame point."""
    return np.array([v.x(), v.z(), -v.y()])


class SkeletonGLView(GLViewMixin, QOpenGLWindow):
    """GL scene of one skeleton, its joints and the footage behind it.

    Signals
    -------
    jointPressed(int)
        A joint was clicked (index into ``skeleton.joints``).
    jointDragged(int, float)
        While dragging from a joint that is not an end: total rotation about the view axis
        so far, degrees (positive counterclockwise as seen on screen).
    endDragged(int, object)
        While dragging an end: where the cursor is, in the view's plane through the point
        grabbed, as an ndarray of shape (3,) in gaitcore's frame (metres).
    dragFinished()
    jointHovered(int)
        The joint under the cursor changed (-1: none).
    frameRequested()
        The artist pressed F in the view.
    """

    jointPressed = Signal(int)
    jointDragged = Signal(int, float)
    endDragged = Signal(int, object)
    dragFinished = Signal()
    jointHovered = Signal(int)
    frameRequested = Signal()

    def __init__(self) -> None:
        super().__init__()
        self.frames_drawn = 0
        self._preset: tuple | None = None
        self.setBackgroundColor(BACKGROUND_RGB)
        self.opts["fov"] = FOV_DEG
        self._skeleton: Skeleton | None = None
        self._bones: list[tuple[int, np.ndarray, gl.GLMeshItem]] = []
        self._bone_child: list[int] = []
        self._colors: list[tuple[float, ...]] = []
        self._world = np.zeros((0, 4, 4))
        self._selected = self.hovered = -1
        self._ends: set[int] = set()
        self._opacity = DEFAULT_BONE_OPACITY
        self._drag: tuple[int, np.ndarray, np.ndarray | None] | None = None
        self._end_drag: tuple[int, np.ndarray] | None = None
        self.camera_moved = False
        self._follow_dx = 0.0
        self._sphere = gl.MeshData.sphere(rows=10, cols=16)
        self.grid = gl.GLGridItem(size=QVector3D(12, 12, 1))
        self.grid.setSpacing(0.5, 0.5, 1)
        self.grid.setColor((170, 170, 170, 110))
        self.addItem(self.grid)
        self.reference = gl.GLImageItem(np.zeros((2, 2, 4), np.uint8), smooth=True,
                                        glOptions="translucent")
        self.reference.setDepthValue(-10)  # drawn first: the skeleton stays in front
        self.addItem(self.reference)
        self.outline = self._line_item(-5, OUTLINE_RGBA, 2.0)
        self.onion = [self._line_item(8, color, 2.0) for color in ONION_RGBA]
        self.links = self._line_item(9, (0.1, 0.1, 0.2, 0.6), 2.5)
        self.joints = gl.GLScatterPlotItem(pos=np.zeros((1, 3)), size=7, pxMode=True,
                                           glOptions=STICK)
        self.joints.setDepthValue(10)
        self.joints.setTransform(qmatrix(Y_UP_TO_GL))
        self.addItem(self.joints)

    def _line_item(self, depth: float, color, width: float) -> gl.GLLinePlotItem:
        item = gl.GLLinePlotItem(pos=np.zeros((2, 3)), mode="lines", width=width, color=color,
                                 glOptions=ON_TOP)
        item.setDepthValue(depth)
        item.setTransform(qmatrix(Y_UP_TO_GL))
        item.setVisible(False)
        self.addItem(item)
        return item

    def devicePixelRatioF(self) -> float:  # noqa: N802 - what GLViewMixin calls on a widget
        return self.devicePixelRatio()

    def paintGL(self) -> None:  # noqa: N802 - Qt API
        self.frames_drawn += 1
        super().paintGL()

    def render_image(self) -> QImage:
        """Draw the scene now into an offscreen buffer and return it (device pixels).

        ``grabFramebuffer`` returns whatever was last presented; this is the current state.
        """
        self.makeCurrent()
        w, h = max(self.deviceWidth(), 1), max(self.deviceHeight(), 1)
        fbo = QOpenGLFramebufferObject(w, h,
                                       QOpenGLFramebufferObject.Attachment.CombinedDepthStencil)
        try:
            fbo.bind()
            GL.glViewport(0, 0, w, h)
            region = self.getViewport()
            self.paint(region=region, viewport=region)
            return fbo.toImage()
        finally:
            fbo.release()
            self.doneCurrent()

    def resizeGL(self, w: int, h: int) -> None:  # noqa: N802 - Qt API
        if self._preset is not None and not self.camera_moved:
            self.set_view(*self._preset)  # keep the preset framing until the artist orbits

    # -- scene -------------------------------------------------------------------------------
    def set_skeleton(self, skeleton: Skeleton) -> None:
        """Build one ellipsoid item per bone of ``skeleton`` (replacing the previous rig)."""
        for _, _, item in self._bones:
            self.removeItem(item)
        self._bones, self._colors = [], []
        self._skeleton = skeleton
        for bone in skeleton.bone_ellipsoids():
            local = np.eye(4)
            local[:3, :3] = bone.axes * bone.radii
            local[:3, 3] = bone.center
            side = skeleton.joints[bone.child].side
            tint = 0.0 if side == "C" else SIDE_TINT
            rgb = (1 - tint) * np.array(bone.color) + tint * np.array(side_rgba(side)[:3])
            self._colors.append((*rgb, 1.0))
            item = gl.GLMeshItem(meshdata=self._sphere, smooth=True, shader=HEADLIGHT_SHADER,
                                 color=self._colors[-1])
            self.addItem(item)
            self._bones.append((bone.joint, local, item))
        self._bone_child = [b.child for b in skeleton.bone_ellipsoids()]
        self._ends = {j for j in range(skeleton.n_joints) if j not in skeleton.parents}
        self._world = skeleton.forward_kinematics(skeleton.rest_pose())
        self._selected = self.hovered = -1
        self.set_bone_opacity(self._opacity)
        self._update_items()

    def set_draggable_ends(self, joints: set[int]) -> None:
        """The joints a drag moves by IK (the others turn); drawn larger."""
        self._ends = set(joints)
        self._update_joints()

    def set_bone_opacity(self, opacity: float) -> None:
        """Opacity of the bones in [0, 1]: 1 solid, below 1 see-through, 0 the stick figure only."""
        self._opacity = float(np.clip(opacity, 0.0, 1.0))
        for (_, _, item), child, color in zip(self._bones, self._bone_child, self._colors):
            item.setVisible(self._opacity > 0)
            item.setGLOptions(dict(OPAQUE) if self._opacity >= 1 else dict(SEE_THROUGH))
            item.setColor(self._bone_color(child, color))
        self.update()

    def _bone_color(self, child: int, color: tuple) -> tuple:
        rgba = SELECTED_RGBA if child == self._selected else color
        return (*rgba[:3], self._opacity)

    def set_pose(self, pose: np.ndarray) -> None:
        """Show pose vector ``pose`` of the current skeleton."""
        if self._skeleton is not None:
            self._world = self._skeleton.forward_kinematics(pose)
            self._update_items()

    def set_selected(self, joint: int) -> None:
        """Highlight joint ``joint`` (-1: none) and the bone that ends at it."""
        if joint != self._selected:
            self._selected = joint
            for (_, _, item), child, color in zip(self._bones, self._bone_child, self._colors):
                item.setColor(self._bone_color(child, color))
            self._update_joints()

    def set_hovered(self, joint: int) -> None:
        """Highlight joint ``joint`` as under the cursor (-1: none)."""
        if joint != self.hovered:
            self.hovered = joint
            self._update_joints()
            self.jointHovered.emit(joint)

    def set_onion(self, positions: list[np.ndarray]) -> None:
        """Stick figures of up to two other poses, as joint positions (J, 3) each (gaitcore
        frame): the previous and the next key."""
        for item, pos in zip(self.onion, list(positions) + [None] * len(self.onion)):
            item.setVisible(pos is not None and self._skeleton is not None)
            if pos is not None and self._skeleton is not None:
                item.setData(pos=self._pairs(np.asarray(pos)))

    def set_outline(self, segments: np.ndarray | None) -> None:
        """Line segments (n, 2, 3) drawn over the footage, gaitcore frame; None hides them."""
        self.outline.setVisible(segments is not None and len(segments) > 0)
        if segments is not None and len(segments):
            self.outline.setData(pos=np.asarray(segments, float).reshape(-1, 3))

    def set_reference(self, rgba_xy: np.ndarray | None,
                      transform: np.ndarray | None = None) -> None:
        """Show an image (x, y, RGBA uint8, see GLImageItem) placed by the gaitcore-frame
        ``transform`` (4x4 from image units to metres); None hides it."""
        self.reference.setVisible(rgba_xy is not None)
        if rgba_xy is not None:
            self.reference.setData(rgba_xy)
            self.place_reference(transform)

    def place_reference(self, transform: np.ndarray) -> None:
        """Move the reference image (same texture) by a new texel -> world transform."""
        self.reference.setTransform(qmatrix(Y_UP_TO_GL @ transform))

    def follow_x(self, dx: float) -> None:
        """Keep the camera on a skeleton whose root moved to ``dx`` along X (keeps any pan)."""
        centre = self.opts["center"]
        self.opts["center"] = QVector3D(centre.x() + dx - self._follow_dx, centre.y(), centre.z())
        self._follow_dx = dx
        self.update()

    def set_view(self, name: str, center_xy: tuple[float, float],
                 size_m: tuple[float, float, float]) -> None:
        """Look from a preset (``VIEWS``) at ``center_xy`` so that a box of ``size_m`` (width
        and height on screen, depth along the view) fits in the view, its near face included."""
        elevation, azimuth = VIEWS[name]
        self._preset = (name, center_xy, size_m)
        tan_x = math.tan(math.radians(self.opts["fov"]) / 2)  # pyqtgraph's fov is horizontal
        tan_y = tan_x * max(self.height(), 1) / max(self.width(), 1)
        distance = max(0.5 * size_m[0] / tan_x, 0.5 * size_m[1] / tan_y) + 0.5 * size_m[2]
        cx, cy = center_xy
        self.camera_moved = False
        self.setCameraPosition(pos=QVector3D(cx + self._follow_dx, 0.0, cy), distance=distance,
                               elevation=elevation, azimuth=azimuth)

    def frame(self, points: np.ndarray | None = None) -> None:
        """Aim at ``points`` (gaitcore frame, (n, 3); default the joints as shown) and move the
        camera along its line of sight until they fill :data:`FRAME_FILL` of the view."""
        pts = self.joint_positions() if points is None else np.asarray(points, float)
        if not len(pts):
            return
        self.opts["center"] = to_gl((pts.min(axis=0) + pts.max(axis=0)) / 2)
        w, h = max(self.width(), 1), max(self.height(), 1)
        for _ in range(3):  # screen size goes as 1 / distance near the centre: converges fast
            off = np.abs(self.project(pts) - (w / 2, h / 2)).max(axis=0)
            need = max(2 * off[0] / w, 2 * off[1] / h) / FRAME_FILL
            self.opts["distance"] *= float(np.clip(need, 0.05, 20.0))
        self.camera_moved = True
        self.update()

    def _pairs(self, pos: np.ndarray) -> np.ndarray:
        parents = self._skeleton.parents
        pairs = [(parents[j], j) for j in range(len(parents)) if parents[j] >= 0]
        return pos[np.array(pairs).ravel()] if pairs else np.zeros((2, 3))

    def _update_items(self) -> None:
        for joint, local, item in self._bones:
            item.setTransform(qmatrix(Y_UP_TO_GL @ self._world[joint] @ local))
        if self._skeleton is not None:
            sides = [side_rgba(j.side, 0.95) for j in self._skeleton.joints]
            parents = self._skeleton.parents
            colors = [c for j in range(len(parents)) if parents[j] >= 0 for c in (sides[j],) * 2]
            self.links.setData(pos=self._pairs(self._world[:, :3, 3]),
                               color=np.array(colors) if colors else (0, 0, 0, 0))
            self.links.setVisible(bool(colors))
        self._update_joints()

    def _update_joints(self) -> None:
        pos = self._world[:, :3, 3]
        if not len(pos) or self._skeleton is None:
            return
        colors = np.array([side_rgba(j.side) for j in self._skeleton.joints])
        sizes = np.array([10.0 if j in self._ends else 7.0 for j in range(len(pos))])
        for joint, color, size in ((self.hovered, HOVER_RGBA, 13.0),
                                   (self._selected, SELECTED_RGBA, 15.0)):
            if 0 <= joint < len(pos):
                colors[joint], sizes[joint] = color, size
        self.joints.setData(pos=pos, color=colors, size=sizes)

    # -- picking -----------------------------------------------------------------------------
    def joint_positions(self) -> np.ndarray:
        """World positions (gaitcore frame) of the joints as shown, shape (J, 3)."""
        return self._world[:, :3, 3].copy()

    def _mvp(self) -> np.ndarray:
        w, h = max(self.width(), 1), max(self.height(), 1)
        region = (0, 0, w, h)
        return numpy_matrix(self.projectionMatrix(region, region)) @ numpy_matrix(self.viewMatrix())

    def project(self, points: np.ndarray) -> np.ndarray:
        """Widget pixel coordinates (x right, y down) of gaitcore-frame points (n, 3)."""
        w, h = max(self.width(), 1), max(self.height(), 1)
        p = np.c_[np.asarray(points, float).reshape(-1, 3), np.ones(len(points))]
        clip = (self._mvp() @ Y_UP_TO_GL @ p.T).T
        ndc = clip[:, :3] / clip[:, 3:4]
        return np.column_stack([(ndc[:, 0] + 1) * 0.5 * w, (1 - ndc[:, 1]) * 0.5 * h])

    def unproject(self, xy: tuple[float, float], through: np.ndarray) -> np.ndarray | None:
        """The gaitcore-frame point under widget point ``xy`` in the plane through ``through``
        facing the camera (None if the line of sight runs along that plane)."""
        w, h = max(self.width(), 1), max(self.height(), 1)
        inverse = np.linalg.inv(self._mvp() @ Y_UP_TO_GL)
        ndc = (2 * xy[0] / w - 1, 1 - 2 * xy[1] / h)
        near, far = (inverse @ [*ndc, z, 1.0] for z in (-1.0, 1.0))
        near, far = near[:3] / near[3], far[:3] / far[3]
        normal, ray = self.view_axis(), far - near
        denom = float(ray @ normal)
        if abs(denom) < 1e-12:
            return None
        return near + ray * float((np.asarray(through, float) - near) @ normal) / denom

    def pick(self, xy: tuple[float, float], radius_px: float = PICK_RADIUS_PX) -> int:
        """Index of the joint shown nearest to widget point ``xy`` within ``radius_px``; -1."""
        if not len(self._world):
            return -1
        d = np.hypot(*(self.project(self.joint_positions()) - np.asarray(xy, float)).T)
        best = int(np.argmin(d))
        return best if d[best] <= radius_px else -1

    def view_axis(self) -> np.ndarray:
        """Unit vector from the scene centre towards the camera, gaitcore frame."""
        cam = self.cameraPosition()
        centre = self.opts["center"]
        v = np.array([cam.x() - centre.x(), cam.y() - centre.y(), cam.z() - centre.z()])
        v = Y_UP_TO_GL[:3, :3].T @ v
        return v / (np.linalg.norm(v) or 1.0)

    # -- mouse and keys ----------------------------------------------------------------------
    def mousePressEvent(self, ev) -> None:  # noqa: N802 - Qt API
        pos = ev.position()
        joint = -1
        if ev.button() == Qt.MouseButton.LeftButton and not ev.modifiers():
            joint = self.pick((pos.x(), pos.y()))
        self._drag = self._end_drag = None
        if joint < 0:
            super().mousePressEvent(ev)
            return
        if joint in self._ends:
            self._end_drag = (joint, self.joint_positions()[joint])
        else:
            self._drag = (joint, self.project(self.joint_positions()[joint:joint + 1])[0], None)
        self.jointPressed.emit(joint)
        ev.accept()

    def mouseMoveEvent(self, ev) -> None:  # noqa: N802 - Qt API
        pos = ev.position()
        if self._end_drag is not None:
            joint, grabbed = self._end_drag
            target = self.unproject((pos.x(), pos.y()), grabbed)
            if target is not None:
                self.endDragged.emit(joint, target)
            return
        if self._drag is None:
            buttons = ev.buttons() != Qt.MouseButton.NoButton
            self.camera_moved = self.camera_moved or buttons
            self.set_hovered(-1 if buttons else self.pick((pos.x(), pos.y())))
            super().mouseMoveEvent(ev)
            return
        joint, centre, start = self._drag
        b = np.array([pos.x() - centre[0], centre[1] - pos.y()])  # y up
        if start is None:  # the angle is measured from where the cursor first leaves the joint
            if np.linalg.norm(b) >= DRAG_START_PX:
                self._drag = (joint, centre, b)
            return
        angle = math.degrees(math.atan2(start[0] * b[1] - start[1] * b[0], start @ b))
        self.jointDragged.emit(joint, angle)

    def leaveEvent(self, ev) -> None:  # noqa: N802 - Qt API
        self.set_hovered(-1)
        super().leaveEvent(ev)

    def wheelEvent(self, ev) -> None:  # noqa: N802 - Qt API
        """Zoom towards the point under the cursor (it stays where it is on screen)."""
        self.camera_moved = True
        delta = ev.angleDelta().y() or ev.angleDelta().x()
        if ev.modifiers() & Qt.KeyboardModifier.ControlModifier or not delta:
            super().wheelEvent(ev)  # pyqtgraph: Ctrl + wheel changes the field of view
            return
        factor = 0.999 ** delta
        centre = from_gl(self.opts["center"])
        pos = ev.position()
        under = self.unproject((pos.x(), pos.y()), centre)
        if under is not None:  # points of the focal plane scale about the centre on screen
            self.opts["center"] = to_gl(under + (centre - under) * factor)
        self.opts["distance"] *= factor
        self.update()

    def keyPressEvent(self, ev) -> None:  # noqa: N802 - Qt API
        if ev.key() == Qt.Key.Key_F and not ev.modifiers():
            self.frameRequested.emit()
            ev.accept()
            return
        super().keyPressEvent(ev)

    def mouseReleaseEvent(self, ev) -> None:  # noqa: N802 - Qt API
        if self._drag is not None or self._end_drag is not None:
            self._drag = self._end_drag = None
            self.dragFinished.emit()
        super().mouseReleaseEvent(ev)
